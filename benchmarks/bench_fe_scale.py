"""Benchmark: the FE path at scale (issue #25): LU backends, the subspace projection, 10^5-10^6 DOFs.

Parts (each prints its figures; run one at a time on a shared machine, with ``nice``):

``--lu-rule 48 96``
    One factorisation and 40 two-vector solves of the band solve's complex ``P(s)`` (8 kHz) and
    of the real symmetric ``K1``, SuperLU against PARDISO, one thread: the measurements behind
    :data:`squealkit.solvers.lu.PARDISO_MIN_DOF`.
``--band 176``
    The band solve (1-16 kHz, 600 rpm, mu 0.45, two walks) of the built-in brake at
    ``n_theta=176`` (115 326 DOFs) with ``lu="superlu"`` and then ``lu="pardiso"``, each in a
    fresh subprocess (its own peak memory); then the subspace projection of the same model
    (``method="subspace"``): times, ratios against SuperLU, the largest relative difference of
    the eigenvalues and the residuals.
``--check 48``
    The subspace projection against the full band solve on a mid-size brake (8 802 DOFs):
    eigenvalues in the band, their largest relative difference and the residuals.
``--subspace 560 --n-r 49``
    The subspace path on a brake of about 10^6 DOFs (``n_theta=560, n_r=49``: 1.0e6 unknowns):
    the model built, the memory estimate, the real modes to 24 kHz, one operating point
    projected and every eigenpair's residual in the full model; each stage's wall time, the
    process's peak resident memory (``resource.getrusage`` ``ru_maxrss``) and the load average.

Run:  nice -n 10 python benchmarks/bench_fe_scale.py --band 176

Measured 2026-12-03 on the shared 2-core, 23 GB machine (SQUEALKIT_THREADS=2, nice 10; the load
average, from the other users' jobs, is part of each figure):

- ``--band 176`` (115 326 DOFs, load 8.6-11): SuperLU 397.9 s, peak 4.97 GB; PARDISO 556.1 s
  (0.72x), peak 8.66 GB, the same 44 eigenvalues to 1.0e-13; the subspace path 115.7 s (3.44x
  SuperLU's band solve), peak 1.92 GB, 99 real modes, eigenvalues within 4.8e-3 relative of the
  band solve's, full-model residuals up to 3.4e-7.
- ``--check 48`` (8 802 DOFs, load ~12): subspace to 1.5x the band's top (102 modes) 5.6e-3
  largest relative difference (median 5.1e-4), to 2x (146 modes) 2.5e-3 (median 4.3e-4); the
  same 5 unstable modes as the band solve; residuals 9.6e-11..1.2e-5.
- ``--subspace 352`` (476 586 DOFs, load 3-5): built in 40 s, 102 real modes to 24 kHz in 382 s,
  one operating point 18 s (44 eigenvalues, residuals 3.3e-13..4.2e-8, 7 unstable), total 440 s,
  peak RSS 8.41 GB.
- ``--subspace 560 --n-r 49`` (1 199 790 DOFs, load 2-3.6, run once): built in 136 s with a peak
  RSS of 15.3 GB; PARDISO's analysis then predicted about 7.6 GiB for its factor (11.4 GiB with the
  copies of K_sym) against a limit of 8.6 GiB (80 % of what was available with the model held),
  and the solve was refused in one line before the numerical factorisation.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DISC_SPEED = 2 * math.pi * 600 / 60
MU = 0.45
BAND = (1000.0, 16000.0)
NAMES = ("M", "D1", "DG", "DR", "D4", "K1", "KR", "KGeo")


def _peak_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # kB on Linux


def _load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def _model(n_theta: int, n_r: int | None = None, n_z: int = 1):
    from squealkit.fe import FEModel
    from squealkit.fe.demo import build_fe_demo

    d = build_fe_demo(n_theta=n_theta, n_r=n_r, n_z=n_z)
    m = FEModel.from_matrices(**{k: d[k] for k in NAMES if d[k] is not None}, disc_speed_ref=d["disc_speed_ref"],
                              mu_ref=d["mu_ref"], f_ref=d["f_ref"])
    return m


def lu_rule(sizes: list[int]) -> None:
    from threadpoolctl import threadpool_limits

    from squealkit.solvers.lu import factorize, fill_reducing_order

    for nt in sizes:
        m = _model(nt)
        M, C, K = m.mass_matrix(), m.damping_matrix(DISC_SPEED, MU), m.stiffness_matrix(DISC_SPEED, MU)
        s = 2j * math.pi * 8000
        rng = np.random.default_rng(0)
        for what, P, perm in (("complex P(s)", (s * s) * M + s * C + K, fill_reducing_order(M, C, K)),
                              ("real symmetric K1", m.K1.tocsr(), fill_reducing_order(m.K1, M))):
            B = rng.standard_normal((P.shape[0], 2)) + (0j if np.iscomplexobj(P.data) else 0)
            line = []
            with threadpool_limits(1):
                for backend in ("superlu", "pardiso"):
                    t = time.perf_counter()
                    f = factorize(P, perm, lu=backend)
                    tf = time.perf_counter() - t
                    t = time.perf_counter()
                    for _ in range(40):
                        f.solve(B)
                    ts = time.perf_counter() - t
                    line.append(f"{backend} factor {tf:.2f} s, 40 solves {ts:.2f} s, {f.nnz:.3g} entries")
                    del f
            print(f"n={P.shape[0]} {what}: " + "; ".join(line) + f" ({_load()})", flush=True)


def band_child(n_theta: int, backend: str, out: str) -> None:
    """One band solve (or the subspace path) in this process; figures to ``out`` (.npz)."""
    t0 = time.perf_counter()
    m = _model(n_theta)
    built = time.perf_counter() - t0
    t0 = time.perf_counter()
    if backend == "subspace":
        from squealkit.solvers.subspace import subspace_basis, subspace_eigs

        basis = subspace_basis(m, freq_max=1.5 * BAND[1])
        sol = subspace_eigs(m, DISC_SPEED, MU, band=BAND, basis=basis)
        extra = basis.n_modes
    else:
        from squealkit.solvers.band import band_eigs

        sol = band_eigs(m, DISC_SPEED, MU, band=BAND, workers=2, lu=backend)
        extra = 0
    wall = time.perf_counter() - t0
    np.savez(out, lam=sol.eigenvalues, res=sol.residuals, n=m.n_dof, built=built, wall=wall, peak=_peak_gb(),
             modes=extra, load=os.getloadavg()[0])


def _run_child(n_theta: int, backend: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "r.npz")
        subprocess.run([sys.executable, __file__, "--child", backend, "--n-theta", str(n_theta), "--out", out],
                       check=True)
        r = dict(np.load(out))
    print(f"  {backend}: {int(r['n'])} DOFs, solve {float(r['wall']):.1f} s (model built in "
          f"{float(r['built']):.1f} s), {r['lam'].size} eigenvalues, max residual {r['res'].max():.1e}, "
          f"peak RSS {float(r['peak']):.2f} GB"
          + (f", {int(r['modes'])} real modes" if int(r["modes"]) else "") + f", load {float(r['load']):.1f}",
          flush=True)
    return r


def band(n_theta: int) -> None:
    print(f"band solve 1-16 kHz at n_theta={n_theta}, 600 rpm, mu {MU}; {_load()}", flush=True)
    ref = _run_child(n_theta, "superlu")
    for backend in ("pardiso", "subspace"):
        r = _run_child(n_theta, backend)
        print(f"  {backend}: {float(ref['wall']) / float(r['wall']):.2f}x SuperLU's time", flush=True)
        if r["lam"].size == ref["lam"].size:
            rel = np.abs(r["lam"] - ref["lam"]) / np.abs(ref["lam"])
            print(f"  {backend}: eigenvalues vs SuperLU's: largest relative difference {rel.max():.1e}", flush=True)
        else:
            print(f"  {backend}: {r['lam'].size} eigenvalues against SuperLU's {ref['lam'].size}", flush=True)


def check(n_theta: int) -> None:
    from squealkit.solvers.band import band_eigs
    from squealkit.solvers.subspace import subspace_basis, subspace_eigs

    m = _model(n_theta)
    band_ = (1000.0, 16000.0)
    t = time.perf_counter()
    ref = band_eigs(m, DISC_SPEED, MU, band=band_)
    t_ref = time.perf_counter() - t
    print(f"n={m.n_dof}: band solve {t_ref:.1f} s, {ref.eigenvalues.size} eigenvalues, max residual "
          f"{ref.residuals.max():.1e}", flush=True)
    for factor in (1.5, 2.0, 3.0):
        t = time.perf_counter()
        basis = subspace_basis(m, freq_max=factor * band_[1])
        sol = subspace_eigs(m, DISC_SPEED, MU, band=band_, basis=basis)
        ts = time.perf_counter() - t
        msg = (f"  subspace to {factor:g}x the top ({basis.n_modes} modes, {basis.backend}): {ts:.1f} s, "
               f"{sol.eigenvalues.size} eigenvalues, residuals {sol.residuals.min():.1e}..{sol.residuals.max():.1e}")
        if sol.eigenvalues.size == ref.eigenvalues.size:
            rel = np.abs(sol.eigenvalues - ref.eigenvalues) / np.abs(ref.eigenvalues)
            dsig = np.abs(sol.eigenvalues.real - ref.eigenvalues.real)
            msg += (f"; relative difference max {rel.max():.1e} (median {np.median(rel):.1e}), growth rate "
                    f"max {dsig.max():.2g} 1/s")
        print(msg, flush=True)
        unstable = [f"{x.imag / 2 / math.pi:.0f} Hz ({x.real:+.2f})" for x in sol.eigenvalues if x.real > 0]
        print("    unstable (subspace): " + ", ".join(unstable), flush=True)
    print("    unstable (band):     " + ", ".join(f"{x.imag / 2 / math.pi:.0f} Hz ({x.real:+.2f})"
                                               for x in ref.eigenvalues if x.real > 0), flush=True)


def subspace(n_theta: int, n_r: int | None, n_z: int) -> None:
    from squealkit.fe.demo import fe_demo_dofs
    from squealkit.solvers import lu
    from squealkit.solvers.memory import memory_limit, subspace_memory
    from squealkit.solvers.subspace import subspace_basis, subspace_eigs

    start = time.perf_counter()
    print(f"subspace path: n_theta={n_theta}, n_r={n_r}, n_z={n_z} (disc alone ~{fe_demo_dofs(n_theta, n_r, n_z)} "
          f"DOFs), LU backend {lu.lu_backend()}; {_load()}", flush=True)
    t = time.perf_counter()
    m = _model(n_theta, n_r, n_z)
    nnz = m.K1.nnz
    print(f"  model: {m.n_dof} DOFs, nnz(K1) {m.K1.nnz:.3g}, built in {time.perf_counter() - t:.1f} s; peak RSS "
          f"{_peak_gb():.2f} GB; {_load()}", flush=True)
    est = subspace_memory(m.n_dof, nnz, 100, backend="pardiso") / 2**30
    print(f"  memory estimate of the factor + 100 modes: {est:.1f} GiB; limit {memory_limit() / 2**30:.1f} GiB",
          flush=True)
    t = time.perf_counter()
    basis = subspace_basis(m, freq_max=1.5 * BAND[1])
    print(f"  real modes: {basis.n_modes} up to {basis.freq_max:g} Hz ({basis.backend}) in "
          f"{time.perf_counter() - t:.1f} s; peak RSS {_peak_gb():.2f} GB; {_load()}", flush=True)
    t = time.perf_counter()
    sol = subspace_eigs(m, DISC_SPEED, MU, band=BAND, basis=basis, vectors=False)
    print(f"  one operating point: {sol.eigenvalues.size} eigenvalues in 1-16 kHz in {time.perf_counter() - t:.1f} s, "
          f"full-model residuals {sol.residuals.min():.1e}..{sol.residuals.max():.1e} (median "
          f"{np.median(sol.residuals):.1e}); unstable: "
          + ", ".join(f"{x.imag / 2 / math.pi:.0f} Hz ({x.real:+.2f} 1/s)" for x in sol.eigenvalues if x.real > 0),
          flush=True)
    print(f"  total {time.perf_counter() - start:.1f} s; peak RSS {_peak_gb():.2f} GB; {_load()}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lu-rule", nargs="*", type=int)
    ap.add_argument("--band", type=int)
    ap.add_argument("--check", type=int)
    ap.add_argument("--subspace", type=int)
    ap.add_argument("--n-r", type=int, default=None)
    ap.add_argument("--n-z", type=int, default=1)
    ap.add_argument("--child")
    ap.add_argument("--n-theta", type=int)
    ap.add_argument("--out")
    a = ap.parse_args()
    if a.child:
        band_child(a.n_theta, a.child, a.out)
    elif a.lu_rule:
        lu_rule(a.lu_rule)
    elif a.band:
        band(a.band)
    elif a.check:
        check(a.check)
    elif a.subspace:
        subspace(a.subspace, a.n_r, a.n_z)
    else:
        ap.print_help()


if __name__ == "__main__":
    main()
