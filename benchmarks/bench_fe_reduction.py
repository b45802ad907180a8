"""Built-in FE brake: full sparse band solve vs the parametric (POD) reduction for a sweep.

Run:  PYTHONPATH=src python benchmarks/bench_fe_reduction.py [--n-theta 96] [--n-r N] [--full-points 3]

All times of the comparison are CPU time (time.process_time, all threads): the machine is
shared. Prints: model size and build time; one operating point, 1-16 kHz, by sparse shift-invert
(time, peak resident memory from resource.getrusage, unstable modes); the POD offline cost
(modal basis, snapshot solves, projection); a 10 x 10 speed x friction sweep on the reduced
model; full solves at ``--full-points`` points of that sweep, their time extrapolated to all
100 points (stated as such), the speed-up ratio and the largest relative eigenvalue error
where the residual check passes.
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np

from squealkit.solvers.band import band_eigs


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def main() -> None:
    from squealkit.fe.demo import build_fe_demo
    from squealkit.solvers.reduction import (
        as_fe_model,
        modal_basis,
        pod_basis,
        reduce,
        reduced_eigs,
        reduced_sweep,
    )

    ap = argparse.ArgumentParser()
    ap.add_argument("--n-theta", type=int, default=96)
    ap.add_argument("--n-r", type=int, default=None)
    ap.add_argument("--n-z", type=int, default=1)
    ap.add_argument("--full-points", type=int, default=3)
    args = ap.parse_args()
    band = (1e3, 16e3)

    t0 = time.perf_counter()
    model = build_fe_demo(n_theta=args.n_theta, n_r=args.n_r, n_z=args.n_z)
    t_build = time.perf_counter() - t0
    n = model["n_dofs"]
    print(f"model: n_theta={args.n_theta}, {n} unknowns, nnz(K1)={model['K1'].nnz}, built in {t_build:.1f} s, "
          f"peak RSS {peak_mb():.0f} MB")
    m = as_fe_model(model)

    def full_solve(omega, mu):
        sol = band_eigs(m, omega, mu, band=band, workers=1)  # one point per core, like a sweep
        return sol.eigenvalues, sol.residuals

    # --- one operating point, full sparse solve
    omega0, mu0 = 2 * math.pi * 600 / 60, 0.45
    t0 = time.perf_counter()
    c0 = time.process_time()
    lam, eta = full_solve(omega0, mu0)
    t_full0, c_full0 = time.perf_counter() - t0, time.process_time() - c0
    unstable = lam[lam.real > 0]
    print(f"full sparse shift-invert, 600 rpm, mu={mu0}, {band[0]:.0f}-{band[1]:.0f} Hz: {len(lam)} eigenvalues "
          f"in {t_full0:.1f} s (CPU {c_full0:.1f} s), peak RSS {peak_mb():.0f} MB, max backward error {eta.max():.1e}")
    print("  unstable: " + ", ".join(f"{x.imag / 2 / math.pi:.0f} Hz ({x.real:+.1f} 1/s)" for x in unstable))

    # --- POD offline
    omegas = 2 * math.pi * np.linspace(200, 1500, 10) / 60
    mus = np.linspace(0.3, 0.6, 10)
    t0 = time.process_time()
    V0 = modal_basis(model, freq_max=1.25 * band[1])
    t_modal = time.process_time() - t0
    t0 = time.process_time()
    V = pod_basis(model, [omegas[len(omegas) // 2]], [mus[0], mus[-1]], band=band, extra=V0)
    t_snap = time.process_time() - t0
    t0 = time.process_time()
    red = reduce(model, V)
    t_reduce = time.process_time() - t0
    offline = t_modal + t_snap + t_reduce
    print(f"POD offline (CPU): modal basis {V0.shape[1]} modes to {1.25 * band[1]:.0f} Hz in {t_modal:.1f} s, "
          f"2 snapshot solves (mu 0.3, 0.6), left corrections and POD in {t_snap:.1f} s, "
          f"projection + R factor in {t_reduce:.1f} s; "
          f"basis {red.n_reduced} vectors; peak RSS {peak_mb():.0f} MB")

    # --- reduced sweep
    t0 = time.process_time()
    ds = reduced_sweep(red, omegas, mus, band=band)
    t_sweep = time.process_time() - t0
    print(f"reduced sweep (CPU) 10 speeds x 10 friction = 100 points in {t_sweep:.1f} s "
          f"({t_sweep / 100:.2f} s/point); all eigenvalues trusted at {int(ds.all_trusted.sum())}/100 points; "
          f"unstable at {int(ds.any_unstable.sum())}/100")

    # --- full solves at a few sweep points: time and error
    rng = np.random.default_rng(0)
    picks = [(len(omegas) - 1, 1), (2, len(mus) // 2), *[tuple(rng.integers(0, 10, 2)) for _ in range(8)]]
    # --full-points 100: every point of the sweep (no extrapolation)
    picks = [(i, j) for i in range(10) for j in range(10)] if args.full_points >= 100 else picks[: args.full_points]
    t_full, errs, n_trusted, n_total = [], [], 0, 0
    for i, j in picks:
        t0 = time.perf_counter()
        c0 = time.process_time()
        lam_f, _ = full_solve(omegas[i], mus[j])
        t_full.append(time.process_time() - c0)
        r = reduced_eigs(red, omegas[i], mus[j], band=band)
        err = np.array([np.min(np.abs(lam_f - x)) / abs(x) for x in r["eigenvalue"]])
        n_total += len(err)
        n_trusted += int(r["trusted"].sum())
        if r["trusted"].any():
            errs.append(err[r["trusted"]].max())
        print(f"  point {omegas[i] * 60 / 2 / math.pi:.0f} rpm, mu={mus[j]:.3f}: full {len(lam_f)} eig in "
              f"{t_full[-1]:.1f} s, reduced {len(r['eigenvalue'])}, max rel err (trusted) "
              f"{err[r['trusted']].max() if r['trusted'].any() else float('nan'):.1e}, all {err.max():.1e}")
    mean_full = float(np.mean(t_full))
    full_100 = 100 * mean_full
    total_red = offline + t_sweep
    print(f"full sparse solve at every point (CPU): {mean_full:.1f} s/point measured at {len(t_full)} points, "
          f"EXTRAPOLATED to 100 points: {full_100:.0f} s")
    print(f"POD reduction, offline + 100 points: {total_red:.0f} s -> speed-up {full_100 / total_red:.1f}x "
          f"(online only: {full_100 / t_sweep:.0f}x)")
    print(f"max relative eigenvalue error where the residual check passes: {max(errs) if errs else float('nan'):.1e} "
          f"({n_trusted}/{n_total} eigenvalues trusted at the checked points); peak RSS {peak_mb():.0f} MB")


if __name__ == "__main__":
    main()
