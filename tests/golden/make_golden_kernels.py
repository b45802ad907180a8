"""Golden cases of the compiled kernels: run once on the code before a refactor, then compared bit for bit.

Run from the repository root: ``python tests/golden/make_golden_kernels.py`` (with ``SQUEALKIT_THREADS=1``).
It writes ``tests/golden/<case>.npz``; :mod:`tests.test_golden_kernels` recomputes every case with the
same settings and asserts ``np.array_equal`` against the stored arrays. The cases cover each
integrator (Dormand-Prince 5(4), Rodas4, fixed-step RK4), the paper's run-out, loss of contact with
its located events, the Stribeck law, a batch of runs in parallel, ``floquet``/``floquet_map`` (the
transient monodromy) and the limit-cycle branch whose Floquet multipliers use the nonlinear monodromy.

A case is rewritten only where its numbers change on purpose, with the change said here:
``limit_cycle_branch.npz`` was rewritten when a branch whose contact may open went from 128 to 512
time samples per period (harmonic balance's AFT, to make the kinks of the opening contact 4x smaller:
the continuation robustness change). Against the 128-sample case: amplitudes and mu of the points moved
by up to 6.6e-4 relative, frequencies by 5.8e-6 relative (0.014 Hz), the largest Floquet multiplier by
1.0e-4; the same number of points and the same stability flags.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _dataset_arrays(ds) -> dict[str, np.ndarray]:
    """Every numeric variable and coordinate of a Dataset, and its numeric attributes."""
    out: dict[str, np.ndarray] = {}
    for name in list(ds.data_vars) + list(ds.coords):
        a = np.asarray(ds[name].values)
        if a.dtype.kind in "fciub":
            out[f"var:{name}"] = a
    for k, v in ds.attrs.items():
        if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool):
            out[f"attr:{k}"] = np.asarray(v)
    return out


def cases() -> dict[str, dict[str, np.ndarray]]:
    """Every golden case: name -> arrays (small, fast settings)."""
    from squealkit.models import get_preset
    from squealkit.nonlinear import limit_cycle_branch
    from squealkit.transient import Contact, SineRunOut, simulate, simulate_batch
    from squealkit.transient.floquet import floquet, floquet_map

    model = get_preset("lv2013")
    sro = SineRunOut(0.08e-3, 1e-3)  # the paper's Fig. 4 run-out
    big = SineRunOut(2e-3, 0.5e-3)   # steep enough for the contact to open and close (then diverges)
    out: dict[str, dict[str, np.ndarray]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out["dopri5_runout"] = _dataset_arrays(simulate(model, mu=0.4, profile=sro, duration=0.01))
        out["rk4_runout"] = _dataset_arrays(simulate(model, mu=0.4, profile=sro, duration=0.01, method="rk4"))
        out["rosenbrock_runout"] = _dataset_arrays(
            simulate(model, mu=0.4, profile=sro, duration=0.005, method="rosenbrock"))
        nl = Contact.nonlinear()
        out["dopri5_contact_loss"] = _dataset_arrays(
            simulate(model, mu=0.7, profile=big, duration=0.01, contact=nl))
        out["rosenbrock_contact_loss"] = _dataset_arrays(
            simulate(model, mu=0.7, profile=big, duration=0.01, contact=nl, method="rosenbrock"))
        strib = Contact.nonlinear(mu_static=0.6, v_stribeck=0.01)
        out["dopri5_stribeck"] = _dataset_arrays(simulate(model, mu=0.4, profile=sro, duration=0.01, contact=strib))
        out["rosenbrock_stribeck"] = _dataset_arrays(
            simulate(model, mu=0.4, profile=sro, duration=0.005, contact=strib, method="rosenbrock"))
        out["rk4_stribeck"] = _dataset_arrays(
            simulate(model, mu=0.4, profile=sro, duration=0.005, contact=strib, method="rk4"))
        out["dopri5_batch"] = _dataset_arrays(
            simulate_batch(model, mu=[0.3, 0.5], profiles=sro, duration=0.005, contact=nl))
        out["rk4_batch"] = _dataset_arrays(
            simulate_batch(model, mu=[0.3, 0.5], profiles=sro, duration=0.005, method="rk4"))
        r = floquet(model, mu=0.4, amplitude=0.08e-3, wavelength=1e-3, speed=0.02, steps_per_period=3000)
        out["floquet"] = {"exponent": np.asarray(r.floquet_exponent), "frozen_mean": np.asarray(r.frozen_mean),
                          "multipliers": np.asarray(r.multipliers)}
        out["floquet_map"] = _dataset_arrays(
            floquet_map(model, mu=[0.3, 0.4], amplitude=[0.0, 8e-5], wavelength=1e-3, speed=0.02,
                        steps_per_period=2000))
        out["limit_cycle_branch"] = _dataset_arrays(
            limit_cycle_branch(model, (0.3, 0.6), harmonics=6, n_points=4, n_floquet=128, check_harmonics=False))
    return out


def main() -> int:
    for name, arrays in cases().items():
        np.savez_compressed(HERE / f"{name}.npz", **arrays)
    total = sum(p.stat().st_size for p in HERE.glob("*.npz"))
    print(f"{len(list(HERE.glob('*.npz')))} golden files, {total / 1e3:.0f} kB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
