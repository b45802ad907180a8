"""Benchmark: a speed x friction sweep of NLEVP's disk_brake100 (100 DOFs) against a baseline.

Issue 11 asks for a 1000-point sweep over disc speed and friction of disk_brake100 well under
a minute on 2 cores, timed against a baseline in the same run.

Baseline: ``scipy.linalg.eigvals`` on the 200 x 200 state matrix ``[[0, I], [-M^-1 K, -M^-1 C]]``
at each point, one point after another (the state matrices built inside the loop; eigenvalues
only, no vectors, no labels). squealkit: ``fe_stability_map`` (dense method), which also
computes the right eigenvectors, tracks the modes by MAC, gives verdicts and residuals and
labels the result; and with ``track=False`` (eigenvalues only, modes by frequency). Both run
with BLAS on one thread per point (threadpoolctl) unless
``--blas-threads`` says otherwise: on a shared 2-core machine threaded BLAS on 200 x 200
matrices is an order of magnitude slower.

Run:  python benchmarks/bench_fe.py [--rpm 40 --mu 25]

Prints the two times, their ratio, and the largest relative mismatch of the eigenvalues
(squealkit's against the baseline's, both sorted, over the whole grid).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.linalg as sla
from threadpoolctl import threadpool_limits

from squealkit.data import nlevp_path
from squealkit.models import load_fe_model
from squealkit.stability import fe_stability_map


def baseline(model, omegas, mus):
    """eigvals of the state matrix per point; returns (points, 2n) eigenvalues."""
    n = model.n_dof
    M = model.M.toarray()
    parts = {k: getattr(model, k).toarray() for k in model.present}
    out = np.empty((omegas.size * mus.size, 2 * n), dtype=complex)
    p = 0
    for w in omegas:
        for mu in mus:
            f = model.factors(w, mu)
            C = sum(f[k] * parts[k] for k in ("D1", "DR", "DG", "D4") if k in f)
            K = sum(f[k] * parts[k] for k in ("K1", "KR", "KGeo") if k in f)
            A = np.zeros((2 * n, 2 * n))
            A[:n, n:] = np.eye(n)
            A[n:, :n] = -np.linalg.solve(M, K)
            A[n:, n:] = -np.linalg.solve(M, C)
            out[p] = sla.eigvals(A)
            p += 1
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rpm", type=int, default=40, help="disc speeds, 60-240 rpm (NLEVP: 2 pi <= omega <= 8 pi)")
    ap.add_argument("--mu", type=int, default=25, help="friction values, 0-1.5 (mu_ref = 1 is NLEVP's own)")
    ap.add_argument("--workers", type=int, default=2, help="points solved at once by squealkit")
    ap.add_argument("--blas-threads", type=int, default=1, help="BLAS threads for both")
    args = ap.parse_args()
    model = load_fe_model(nlevp_path())
    rpm = np.linspace(60.0, 240.0, args.rpm)
    mu = np.linspace(0.0, 1.5, args.mu)
    omegas = 2 * np.pi * rpm / 60
    print(f"disk_brake100 ({model.n_dof} DOFs): {rpm.size} speeds x {mu.size} frictions = {rpm.size * mu.size} "
          f"points; squealkit workers {args.workers}, BLAS threads {args.blas_threads}")
    with threadpool_limits(args.blas_threads, user_api="blas"):
        t0, c0 = time.perf_counter(), time.process_time()
        ref = baseline(model, omegas, mu)
        t_ref, c_ref = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    ds = fe_stability_map(model, rpm, mu, workers=args.workers)
    t_sk, c_sk = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    ds_fast = fe_stability_map(model, rpm, mu, workers=args.workers, track=False)
    t_fast, c_fast = time.perf_counter() - t0, time.process_time() - c0
    assert (ds_fast.any_unstable.values == ds.any_unstable.values).all()
    # compare: squealkit keeps one eigenvalue per mode (omega_d >= 0; of real roots the larger half)
    got = (ds.growth_rate.values + 1j * ds.omega.values).reshape(-1, model.n_dof)
    err = 0.0
    for g, r in zip(got, ref, strict=True):
        r = r[r.imag > 0]
        g = g[g.imag > 0]
        g, r = g[np.lexsort((g.real, g.imag))], r[np.lexsort((r.real, r.imag))]
        err = max(err, float(np.max(np.abs(g - r) / np.abs(r))))
    print(f"baseline (scipy.linalg.eigvals on the state matrix, per point): {t_ref:8.2f} s wall, {c_ref:8.2f} s CPU")
    print(f"squealkit fe_stability_map (vectors, MAC tracking, verdicts):   {t_sk:8.2f} s wall, {c_sk:8.2f} s CPU")
    print(f"squealkit fe_stability_map(track=False) (eigenvalues, verdicts): {t_fast:8.2f} s wall, {c_fast:8.2f} s CPU")
    print(f"ratio baseline / squealkit (wall): {t_ref / t_sk:.2f}x tracked, {t_ref / t_fast:.2f}x untracked; "
          f"(CPU): {c_ref / c_sk:.2f}x tracked, {c_ref / c_fast:.2f}x untracked; "
          f"unstable fraction {float(ds.any_unstable.mean()):.3f}; "
          f"largest relative eigenvalue mismatch (complex modes) {err:.2e}")


if __name__ == "__main__":
    main()
