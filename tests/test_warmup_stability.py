"""squealkit._warmup's stability group: it compiles the signatures a stability grid calls."""

from __future__ import annotations

import numpy as np

from squealkit import _warmup


def test_stability_group_compiles_the_types_a_grid_passes():
    # reference: numba's dispatchers list each signature they hold; a grid run after the group
    # must add none to the kernels the group compiles (else the parent compiles them itself)
    from squealkit.models import get_preset
    from squealkit.solvers import small
    from squealkit.stability import _verdicts, stability_map, tracking

    _warmup._stability()
    kernels = (small._radii_range, _verdicts.classify_points, _verdicts.select_modes, tracking._track_column,
               tracking._track_rows, tracking._carry, _verdicts.derived_quantities)
    held = [set(k.signatures) for k in kernels]
    assert all(held)
    stability_map(get_preset("lv2013"), np.linspace(0.0, 0.8, 5), np.radians(np.linspace(-8.0, 8.0, 5)),
                  damped=False)
    assert [set(k.signatures) for k in kernels] == held


def _fake_child(monkeypatch, tmp_path, code):
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    monkeypatch.setitem(_warmup._child, "proc", proc)
    monkeypatch.setitem(_warmup._child, "pending", {"transient", "measurement"})
    monkeypatch.setitem(_warmup._child, "claims", str(tmp_path))
    return proc


def test_a_step_compiles_a_group_the_child_has_not_begun(monkeypatch, tmp_path):
    # the child is busy elsewhere (sleeps, says nothing): waiting for it would idle this process
    proc = _fake_child(monkeypatch, tmp_path, "import time; time.sleep(60)")
    try:
        _warmup.wait(["measurement"])  # returns at once: the group is this process's now
        assert _warmup._child["pending"] == {"transient"}
        assert not _warmup._claim(str(tmp_path), "measurement")  # so the child skips it
    finally:
        proc.kill()
        proc.wait()


def test_a_step_waits_for_a_group_the_child_has_begun(monkeypatch, tmp_path):
    assert _warmup._claim(str(tmp_path), "measurement")  # the child's claim, before it began
    proc = _fake_child(monkeypatch, tmp_path, "print('measurement', flush=True)")
    _warmup.wait(["measurement"])  # returns when the child reports the group done
    assert _warmup._child["pending"] == {"transient"}
    assert proc.wait(timeout=30) == 0


def test_child_skips_the_groups_the_parent_claimed(monkeypatch, tmp_path, capsys):
    called = []
    monkeypatch.setattr(_warmup, "GROUPS", {"a": lambda: called.append("a"), "b": lambda: called.append("b")})
    monkeypatch.setattr(_warmup, "_stamp", lambda: tmp_path / "all.stamp")
    assert _warmup._claim(str(tmp_path), "a")  # the parent's
    assert _warmup._main(str(tmp_path), ["a", "b"]) == 0
    assert called == ["b"] and capsys.readouterr().out.split() == ["b"]
    # every group is in the cache, the claimed one compiled by the parent: the next run needs no child
    assert (tmp_path / "all.stamp").exists()
