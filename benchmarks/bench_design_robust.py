"""Robust margins on the built-in FE brake: Monte Carlo on the reduced model vs the perturbation estimate.

Run:  PYTHONPATH=src python benchmarks/bench_design_robust.py [--n-theta 16] [--samples 1000]

The machine is shared: every cost is given as CPU time (time.process_time, all threads) and wall
time, measured in this one run, so the ratios compare like with like. Prints the model size; the
common set-up (the POD basis at the operating point and the projection); the Monte Carlo
propensity with its Clopper-Pearson interval and its cost; the perturbation estimate with its
interval and its cost; the ratio of the two; and one sparse band solve of the FULL model, the cost
a Monte Carlo without reduction would pay per sample (extrapolated to all samples, stated as such).
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def timed(fn, *args, **kwargs):
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.process_time() - c0, time.perf_counter() - w0


def main() -> None:
    from squealkit.design._scatter import _uncertain
    from squealkit.design.robust import _fe_setup, robust_margins
    from squealkit.fe.demo import build_fe_demo
    from squealkit.fe.model import rpm_to_disc_speed
    from squealkit.solvers.band import band_eigs
    from squealkit.solvers.reduction import as_fe_model

    ap = argparse.ArgumentParser()
    ap.add_argument("--n-theta", type=int, default=16)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--rpm", type=float, default=500.0)
    ap.add_argument("--mu", type=float, default=0.13)
    args = ap.parse_args()
    band = (10e3, 14e3)
    scatter = {"KR": 0.02, "D1": 0.2, "K1": 0.01}

    model, c_build, _ = timed(lambda: as_fe_model(build_fe_demo(n_theta=args.n_theta)))
    print(f"built-in brake n_theta={args.n_theta}: {model.n_dof} DOFs (built in {c_build:.1f} s CPU)")
    print(f"operating point {args.rpm:g} rpm, mu = {args.mu:g}, band {band[0]:g}-{band[1]:g} Hz, scatter {scatter}")

    unc = _uncertain({k: {"dist": "normal", "mean": 1.0, "std": v} for k, v in scatter.items()})
    disc_speed = float(rpm_to_disc_speed(args.rpm))
    setup, c_set, w_set = timed(_fe_setup, model, disc_speed, args.mu, unc, band, "pod")
    V = setup["reduced"].V
    print(f"set-up (POD basis + projection): {V.shape[1]} basis vectors, {c_set:.2f} s CPU, {w_set:.2f} s wall")

    kw = {"rpm": args.rpm, "mu": args.mu, "band": band, "scatter": scatter, "basis": V, "seed": 1}
    mc, c_mc, w_mc = timed(robust_margins, model, samples=args.samples, method="montecarlo", **kw)
    pe, c_pe, w_pe = timed(robust_margins, model, method="perturbation", **kw)
    m, p = mc.sel(estimator="montecarlo"), pe.sel(estimator="perturbation")
    print(f"Monte Carlo, {args.samples} samples: propensity {m.propensity.item():.3f} "
          f"[{m.propensity_ci_lower.item():.3f}, {m.propensity_ci_upper.item():.3f}] (Clopper-Pearson 95 %), "
          f"{c_mc:.2f} s CPU, {w_mc:.2f} s wall; full-model residual of {mc.attrs['residual_checked']} samples "
          f"<= {mc.attrs['max_residual']:.2g} (trusted: {bool(mc.attrs['trusted'])})")
    print(f"perturbation: propensity {p.propensity.item():.3f} "
          f"[{p.propensity_ci_lower.item():.3f}, {p.propensity_ci_upper.item():.3f}] (per-mode bounds), "
          f"{c_pe:.3f} s CPU, {w_pe:.3f} s wall; modes "
          f"{np.bincount(p.perturbation_status.values, minlength=3).tolist()} valid/stable_bound/indeterminate")
    print(f"ratio Monte Carlo / perturbation (same run): {c_mc / c_pe:.0f}x CPU, {w_mc / w_pe:.0f}x wall")
    worst = np.max(np.abs(m.growth_rate_std.values - p.growth_rate_std.values) / p.growth_rate_std.values)
    print(f"growth-rate standard deviations, Monte Carlo vs perturbation: largest relative difference {worst:.3f}")

    sol, c_full, w_full = timed(band_eigs, model, disc_speed, args.mu, band=band)
    print(f"one FULL sparse band solve: {c_full:.2f} s CPU, {w_full:.2f} s wall ({sol.eigenvalues.size} modes); "
          f"{args.samples} of them, extrapolated: {args.samples * c_full:.0f} s CPU, i.e. "
          f"{args.samples * c_full / (c_set + c_mc):.1f}x the reduced Monte Carlo with its set-up")


if __name__ == "__main__":
    main()
