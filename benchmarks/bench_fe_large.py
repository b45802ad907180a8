"""Benchmark: the built-in FE brake at about 10^5 DOFs, eigenvalues in 1-16 kHz at one operating point.

Issue 11 asks for this in under 2 minutes on 2 cores, in bounded memory. The model is
built (``--size 176``: 115 326 unknowns) and solved by
:func:`squealkit.solvers.band.band_eigs` (shift-invert, one sparse LU per shift, walks
over the band in ``--workers`` threads) at 600 rpm, mu = 0.45. Baseline in the same run:
another squealkit version (``--baseline-src``, e.g. a worktree of an older commit) solving the
same model in a fresh subprocess, after this one.

Each run prints wall and CPU time (time.process_time, all threads), its process's peak resident
memory (resource.getrusage ru_maxrss), the number of eigenvalues and shift-invert solves, the
largest backward error and the unstable modes; then the ratio and the largest relative
difference between the two eigenvalue sets.

Run:  nice python benchmarks/bench_fe_large.py [--size 176] [--workers 2] [--baseline-src DIR]
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


def solve(size: int, workers: int, out: str) -> None:
    """Build the model, solve the band once and write eigenvalues and timings to ``out`` (.npz)."""
    import squealkit
    from squealkit.fe.demo import build_fe_demo
    from squealkit.models import FEModel
    from squealkit.solvers import band as sparse

    t0, c0 = time.perf_counter(), time.process_time()
    demo = build_fe_demo(n_theta=size)
    model = FEModel.from_matrices(**{k: demo[k] for k in ("M", "D1", "DG", "DR", "D4", "K1", "KR", "KGeo")
                                     if demo[k] is not None},
                                  disc_speed_ref=demo["disc_speed_ref"], mu_ref=demo["mu_ref"], f_ref=demo["f_ref"])
    del demo
    built = time.perf_counter() - t0, time.process_time() - c0
    shifts = []
    # the shift-invert operator: ShiftInvert (block Krylov-Schur), _shift_operator in older versions
    name = "ShiftInvert" if hasattr(sparse, "ShiftInvert") else "_shift_operator"
    operator = getattr(sparse, name)

    def counting(*args, **kwargs):
        shifts.append(args[3])
        return operator(*args, **kwargs)

    setattr(sparse, name, counting)
    t0, c0 = time.perf_counter(), time.process_time()
    sol = sparse.band_eigs(model, 2 * math.pi * 600 / 60, 0.45, band=(1e3, 16e3), workers=workers)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    np.savez(out, lam=sol.eigenvalues, res=sol.residuals, n=model.n_dof, built=built, wall=wall, cpu=cpu,
             shifts=np.array(shifts), source=squealkit.__file__,
             peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)


def run(label: str, src: str, size: int, workers: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "sol.npz")
        subprocess.run([sys.executable, __file__, "--child", out, "--size", str(size), "--workers", str(workers)],
                       check=True, env={**os.environ, "PYTHONPATH": src})
        r = dict(np.load(out))
    lam = r["lam"]
    print(f"{label} ({Path(str(r['source'])).parents[1]}): {int(r['n'])} unknowns "
          f"(built in {r['built'][0]:.1f} s); {lam.size} eigenvalues in "
          f"1-16 kHz from {r['shifts'].size} shifts; wall {float(r['wall']):.1f} s, CPU {float(r['cpu']):.1f} s; "
          f"peak RSS {float(r['peak_mb']):.0f} MB; max backward error {r['res'].max():.1e}", flush=True)
    grow = lam[lam.real > 0]
    print("  shifts [Hz]: " + ", ".join(f"{s.imag / 2 / math.pi:.0f}" for s in r["shifts"]))
    print("  unstable: " + ", ".join(f"{x.imag / 2 / math.pi:.0f} Hz ({x.real:+.1f} 1/s)" for x in grow), flush=True)
    return r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=176, help="elements around the disc (176: 115 326 unknowns)")
    ap.add_argument("--workers", type=int, default=2, help="walks solved at once")
    ap.add_argument("--baseline-src", default=None, help="another squealkit's src folder, timed after this one")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        solve(args.size, args.workers, args.child)
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    new = run("squealkit band_eigs", here, args.size, args.workers)
    if args.baseline_src:
        old = run(f"baseline ({args.baseline_src})", args.baseline_src, args.size, args.workers)
        a, b = new["lam"], old["lam"]
        diff = max((np.min(np.abs(b - x)) / abs(x) for x in a), default=0.0)
        print(f"ratio baseline / this: wall {float(old['wall']) / float(new['wall']):.2f}x, CPU "
              f"{float(old['cpu']) / float(new['cpu']):.2f}x; eigenvalues {a.size} against {b.size}, largest "
              f"relative difference {diff:.1e}")


if __name__ == "__main__":
    main()
