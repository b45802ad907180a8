"""Golden cases of the adaptive integrators' shared loop (issue #28, item 3: one loop for DP5 and Rodas4).

Recorded from commit f778029 (main before the DP5 and Rodas4 kernels shared one driver loop and took
bundled arguments), with ``SQUEALKIT_THREADS=1``, by running from the repository root::

    SQUEALKIT_THREADS=1 python tests/golden/make_golden_ode_loop.py

It writes ``tests/golden/ode_loop/ode_loop.npz`` (one file: ``<case>/<key>`` entries); :mod:`tests.test_ode_one_loop`
recomputes every case and asserts ``np.array_equal``. The cases aim at the parts of the loop the two methods
share: contact opening and closing (events located on each method's dense output, the step retaken to end at
the crossing), stick/slip events of the regularised sign law with a Stribeck drop, Rodas4 on a friction law
far too stiff for an explicit method (v_reg = 1e-6 m/s), the state and step size carried from chunk to chunk
(small chunks), a batch of runs in parallel, and RK4 (whose kernel takes the same bundles).

Kept apart from ``make_golden_kernels.py``, in a folder of its own: ``test_golden_kernels`` requires every
``tests/golden/*.npz`` to be one of its cases.
"""

from __future__ import annotations

import contextlib
import importlib.util
import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
FILE = HERE / "ode_loop" / "ode_loop.npz"  # apart from the cases of test_golden_kernels, which owns *.npz here


@contextlib.contextmanager
def _small_chunks(samples: int, steps: int):
    """The driver's chunks made small, so a short run crosses several (the state carries over)."""
    from squealkit.transient import _driver

    old = _driver._CHUNK_SAMPLES, _driver._CHUNK_STEPS
    _driver._CHUNK_SAMPLES, _driver._CHUNK_STEPS = samples, steps
    try:
        yield
    finally:
        _driver._CHUNK_SAMPLES, _driver._CHUNK_STEPS = old


def _golden_kernels_script():
    """``make_golden_kernels.py`` beside this file (a script, not a package), loaded by its path."""
    spec = importlib.util.spec_from_file_location("make_golden_kernels", HERE / "make_golden_kernels.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


#: Every numeric variable, coordinate and attribute of a Dataset: the same arrays the kernels' golden cases keep.
_arrays = _golden_kernels_script()._dataset_arrays


def cases() -> dict[str, dict[str, np.ndarray]]:
    """Every case: name -> arrays (short runs: the whole set runs in a few seconds once compiled)."""
    from squealkit.models import get_preset
    from squealkit.transient import Contact, SineRunOut, simulate, simulate_batch

    model = get_preset("lv2013")
    steep = SineRunOut(2e-3, 0.5e-3)  # the contact opens and closes
    sro = SineRunOut(0.3e-3, 1e-3)
    stick = Contact.nonlinear(v_reg=1e-4, mu_static=0.7, v_stribeck=1e-3)  # sticks and slips at 1 mm/s
    stiff = Contact.nonlinear(v_reg=1e-6)
    out: dict[str, dict[str, np.ndarray]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for method in ("dopri5", "rosenbrock"):
            out[f"{method}_contact_opening"] = _arrays(
                simulate(model, mu=0.7, profile=steep, duration=0.004, contact=Contact.nonlinear(), method=method))
            out[f"{method}_stick_slip"] = _arrays(
                simulate(model, mu=0.5, profile=sro, speed=1e-3, duration=0.004, contact=stick, method=method))
            with _small_chunks(16, 64):
                out[f"{method}_chunks"] = _arrays(
                    simulate(model, mu=0.7, profile=steep, duration=0.002, contact=Contact.nonlinear(),
                             method=method))
        out["rosenbrock_stiff_friction"] = _arrays(
            simulate(model, mu=0.4, profile=sro, speed=0.02, duration=0.003, contact=stiff, method="rosenbrock"))
        out["dopri5_batch"] = _arrays(
            simulate_batch(model, mu=[0.5, 0.7], profiles=steep, duration=0.002, contact=Contact.nonlinear()))
        with _small_chunks(16, 64):
            out["rk4_chunks"] = _arrays(simulate(model, mu=0.4, profile=sro, duration=0.002, method="rk4"))
            out["rk4_batch_stick_slip"] = _arrays(
                simulate_batch(model, mu=[0.4, 0.5], profiles=sro, speed=5e-3, duration=0.001, contact=stick,
                               method="rk4"))
    return out


def flat(computed: dict[str, dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {f"{case}/{key}": a for case, arrays in computed.items() for key, a in arrays.items()}


def main() -> int:
    np.savez_compressed(FILE, **flat(cases()))
    print(f"{FILE.name}: {FILE.stat().st_size / 1e3:.0f} kB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
