"""Built-in FE brake: a 3-parameter, 1000-point DOE on the reduced model against full solves (issue #26).

Run:  PYTHONPATH=src python benchmarks/bench_design.py [--n-theta 16] [--points 10] [--full-points 5]

Design parameters: the pad and disc stiffness K1 (scale 0.8-1.4), the friction stiffness KR
(0.6-1.1) and the material damping D1 (1-3), a full factorial grid of ``--points`` values each
(10: 1000 points) at 500 rpm, mu = 0.6, 1-16 kHz. The DOE is :func:`squealkit.design.doe_sweep`
(a POD basis at the nominal design, enriched with what it misses of the full model's modes at the 8 corners, then
one small dense solve per point with the exact full-model backward error of every pair). In the
same run ``--full-points`` points of the grid, drawn at random (seed 1), are solved in the full
model by the sparse band solver (:func:`squealkit.solvers.band.band_eigs`); their mean time gives
the cost of the whole grid by full solves (extrapolated, and said so). Prints CPU times
(time.process_time, all threads) and wall times, the ratio, and the largest difference of the
largest growth rate between the DOE and the full solves.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main() -> None:
    from threadpoolctl import threadpool_limits

    from squealkit.design import design_parameters, doe_sweep
    from squealkit.fe import FEModel, rpm_to_disc_speed
    from squealkit.fe.demo import build_fe_demo
    from squealkit.solvers.band import band_eigs

    ap = argparse.ArgumentParser()
    ap.add_argument("--n-theta", type=int, default=16)
    ap.add_argument("--points", type=int, default=10, help="values per parameter (10: a 1000-point grid)")
    ap.add_argument("--full-points", type=int, default=5)
    args = ap.parse_args()
    rpm, mu, band = 500.0, 0.6, (1e3, 16e3)

    t0 = time.perf_counter()
    d = build_fe_demo(n_theta=args.n_theta)
    model = FEModel.from_matrices(**{k: d[k] for k in ("M", "D1", "DG", "K1", "KR", "KGeo")},
                                  disc_speed_ref=d["disc_speed_ref"], mu_ref=d["mu_ref"])
    print(f"model: built-in brake n_theta={args.n_theta}, {model.n_dof} DOFs, "
          f"built in {time.perf_counter() - t0:.1f} s")
    table = {"pad": "K1", "friction": "KR", "damping": "D1"}
    k = args.points
    values = {"pad": np.linspace(0.8, 1.4, k), "friction": np.linspace(0.6, 1.1, k),
              "damping": np.linspace(1.0, 3.0, k)}

    with threadpool_limits(1, user_api="blas"):  # the same single BLAS thread for both sides
        c0, w0 = time.process_time(), time.perf_counter()
        ds = doe_sweep(model, table, values, rpm, mu, band=band)
        c_doe, w_doe = time.process_time() - c0, time.perf_counter() - w0
        n = ds.sizes["point"]
        print(f"DOE: {n} points, basis {ds.attrs['basis_size']} vectors (pod + what 8 corners add), "
              f"CPU {c_doe:.1f} s, wall {w_doe:.1f} s ({1e3 * c_doe / n:.1f} ms CPU a point, offline included); "
              f"trusted points {int(ds.all_trusted.sum())}/{n}, largest residual {float(ds.max_residual.max()):.2g}, "
              f"unstable points {int((ds.n_unstable > 0).sum())}, Pareto points {int(ds.pareto.sum())}")

        params = design_parameters(table, model)
        rng = np.random.default_rng(1)
        sample = rng.choice(n, size=min(args.full_points, n), replace=False)
        w = float(rpm_to_disc_speed(rpm))
        cpu, wall, diff = [], [], []
        for i in sample:
            changed = model
            for p, v in zip(params, ds.value.values[i], strict=True):
                changed = p.apply(changed, v)
            c0, w0 = time.process_time(), time.perf_counter()
            sol = band_eigs(changed, w, mu, band=band, workers=1)
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
            full_max = float(sol.eigenvalues.real.max())
            diff.append(abs(full_max - float(ds.max_growth_rate[i])) / max(abs(full_max), 1.0))
            print(f"  full solve at point {i} {np.round(ds.value.values[i], 3).tolist()}: CPU {cpu[-1]:.2f} s, "
                  f"largest growth rate {full_max:.6g} (DOE {float(ds.max_growth_rate[i]):.6g}) 1/s")
    per_cpu, per_wall = float(np.mean(cpu)), float(np.mean(wall))
    print(f"full solves: {per_cpu:.2f} s CPU ({per_wall:.2f} s wall) a point; the {n} points would take "
          f"{per_cpu * n:.0f} s CPU (extrapolated from {len(sample)})")
    print(f"ratio full / reduced DOE: {per_cpu * n / c_doe:.1f}x CPU, {per_wall * n / w_doe:.1f}x wall; "
          f"largest relative difference of the largest growth rate: {max(diff):.2g}")


if __name__ == "__main__":
    main()
