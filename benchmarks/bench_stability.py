"""Benchmark: the stability map of the damped 3-DOF model against numpy.linalg.eigvals.

Issue 2 asks for a stability map of the damped lv2013 model (c1 = c2 = c3 = 220 N s/m) at
least 10x faster than ``numpy.linalg.eigvals`` on the stacked 6x6 state matrices of the
same grid, from about a million grid points up, with eigenvalues that agree with LAPACK
to 1e-7 relative.

Run:  python benchmarks/bench_stability.py [--points 1000000]

Prints, in one run: the baseline time (eigvals on the prebuilt state matrices: the
matrix build is not charged to the baseline), squealkit's times (eigenvalues only, and
the full labelled, mode-tracked map), the ratios, and the largest relative mismatch
between the two sets of eigenvalues.
"""

from __future__ import annotations

import argparse
import math
import time

import numba
import numpy as np

from squealkit.models import get_preset
from squealkit.stability import eigenvalues, stability_map


def state_matrices(model, mu, t):
    M, C, K = model.mass_matrix(), model.damping_matrix(), model.stiffness_matrix(mu, t)
    n = M.shape[0]
    A = np.zeros((*K.shape[:-2], 2 * n, 2 * n))
    A[..., :n, n:] = np.eye(n)
    A[..., n:, :n] = -np.linalg.solve(M, K)
    A[..., n:, n:] = -np.linalg.solve(M, C)
    return A


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=1_000_000, help="grid points (a square grid)")
    ap.add_argument("--repeat", type=int, default=3, help="best of N for squealkit")
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all cores)")
    args = ap.parse_args()
    if args.threads:
        numba.set_num_threads(args.threads)
    side = round(math.sqrt(args.points))
    model = get_preset("lv2013")  # damped: c1 = c2 = c3 = 220 N s/m
    mu = np.linspace(0.0, 0.8, side)
    theta = np.radians(np.linspace(-8.0, 8.0, side))
    MU, T = np.meshgrid(mu, np.tan(theta), indexing="ij")
    print(f"grid {side} x {side} = {side * side} points, damped 3-DOF lv2013, numba threads {numba.get_num_threads()}")

    stability_map(model, mu[:8], theta[:8], damped=True)  # compile / load the numba cache

    A = state_matrices(model, MU, T)
    t0, c0 = time.perf_counter(), time.process_time()
    ref = np.linalg.eigvals(A)
    t_ref, c_ref = time.perf_counter() - t0, time.process_time() - c0
    del A

    t_eig, c_eig = min(_timed(lambda: eigenvalues(model, MU, tan_theta=T, damped=True)) for _ in range(args.repeat))
    t_map, c_map = min(_timed(lambda: stability_map(model, mu, theta, damped=True)) for _ in range(args.repeat))

    ours = eigenvalues(model, MU, tan_theta=T, damped=True).reshape(-1, 3)
    ref = ref.reshape(-1, 6)
    ref_up = np.sort_complex(np.where(ref.imag >= 0, ref, np.nan + 0j))  # 3 upper-half roots per point
    ref_up = ref_up[:, :3]
    d = np.abs(ref_up[:, :, None] - ours[:, None, :]).min(axis=2).max(axis=1) / np.abs(ref).max(axis=1)
    print(f"numpy.linalg.eigvals (LAPACK geev) on stacked 6x6 state matrices: {t_ref:8.3f} s")
    print(f"squealkit eigenvalues (compiled):                                {t_eig:8.3f} s  "
          f"ratio {t_ref / t_eig:6.1f}x")
    print(f"squealkit stability_map (eigenvalues + tracking + labelled Dataset): {t_map:6.3f} s  "
          f"ratio {t_ref / t_map:6.1f}x")
    print(f"largest relative mismatch to LAPACK: {np.nanmax(d):.2e}  (requirement 1e-7)")
    # CPU time (all threads) measures the work done, robust to other jobs on shared cores
    print(f"CPU time: baseline {c_ref:.3f} s, eigenvalues {c_eig:.3f} s ({c_ref / c_eig:.1f}x), "
          f"map {c_map:.3f} s ({c_ref / c_map:.1f}x)")


def _timed(fn) -> tuple[float, float]:
    """(wall, CPU) seconds of one call."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


if __name__ == "__main__":
    main()
