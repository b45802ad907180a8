"""squealkit._warmup: the child that compiles a report's later kernels on the other core."""

from __future__ import annotations

import numba
import pytest

from squealkit import _warmup


def test_transient_group_compiles_no_stability_kernel(monkeypatch):
    # The parent compiles the stability kernels while the child compiles the integrator: the
    # child's run must not call one (it would compile it a second time, on the other core).
    from squealkit.solvers import small as _kernels
    from squealkit.stability import _schema, _solve, _verdicts, eigen, tracking

    def refuse(*args, **kwargs):
        raise AssertionError("the warm-up child called a stability kernel")

    # the kernels where the stability modules call them (imported by name: patched there, undone
    # after this test, so that a later test's eigenvalues get the real kernels)
    for module in (_kernels, _verdicts, eigen, _solve, _schema, tracking):
        for name in dir(module):
            if isinstance(getattr(module, name), numba.core.registry.CPUDispatcher):
                monkeypatch.setattr(module, name, refuse)
    # the child swaps the eigenvalues a run calls (its step bound's and its growth rate's) for LAPACK's
    # stand-in: undone after this test, so that later tests in this process (tests/test_stribeck.py's
    # growth rates) see the real one
    import importlib

    for sim in (importlib.import_module("squealkit.transient._step"),
                importlib.import_module("squealkit.transient._result")):
        monkeypatch.setattr(sim, "eigenvalues", sim.eigenvalues)
    _warmup._transient()


def test_lapack_stand_in_gives_the_eigenvalues():
    # reference: squealkit's own verified eigenvalues (LAPACK agrees to 1e-9 relative at this point)
    import numpy as np

    from squealkit.models import get_preset
    from squealkit.stability import eigenvalues

    model = get_preset("lv2013")
    got = _warmup._lapack_eigenvalues(model, [0.2, 0.5], 0.05, damped=True)
    want = eigenvalues(model, [0.2, 0.5], tan_theta=0.05, damped=True)
    for g, w in zip(got, want, strict=True):
        assert np.sort_complex(g) == pytest.approx(np.sort_complex(w), rel=1e-9)


def test_no_child_when_capped_to_one_thread_or_the_cache_is_warm(monkeypatch, tmp_path):
    monkeypatch.setenv("SQUEALKIT_THREADS", "1")
    assert not _warmup.start(["measurement"])
    monkeypatch.delenv("SQUEALKIT_THREADS")
    stamp = tmp_path / "warm.stamp"
    stamp.touch()
    monkeypatch.setattr(_warmup, "_stamp", lambda: stamp)
    assert not _warmup.start(["measurement"])
    assert not _warmup.start(["no such group"])


@pytest.mark.slow
def test_child_compiles_its_groups_and_reports_each(monkeypatch, tmp_path):
    monkeypatch.delenv("SQUEALKIT_THREADS", raising=False)
    monkeypatch.setattr(_warmup, "_stamp", lambda: tmp_path / "cold.stamp")  # a cache said to be cold
    if not _warmup._worth_starting():
        pytest.skip("one core: no child is started")
    try:
        assert _warmup.start(["measurement"])
        proc = _warmup._child["proc"]
        _warmup.wait(["measurement"])  # returns once the child said it is done
        assert _warmup._child["pending"] == set()
        assert proc.wait(timeout=120) == 0
        _warmup.wait(["measurement"])  # nothing pending: returns at once
    finally:
        _warmup.stop()
    assert not (tmp_path / "cold.stamp").exists()  # only a child that compiled every group writes it
