"""Benchmark: the first ``reproduce`` on a fresh install (numba's cache empty) against a warm one.

Three runs of ``squealkit.report.reproduce`` in fresh processes, each with its own numba cache
folder (``NUMBA_CACHE_DIR``), in this order:

1. cold, as shipped: the later steps' kernels compile in a child process on the other core
   (``squealkit._warmup``);
2. cold, the baseline: the same with the child turned off (every kernel compiles in turn);
3. warm: the cache of run 1, everything loaded.

Prints the wall times and the ratios cold/warm. Run on an otherwise idle machine:
``python benchmarks/bench_first_run.py [--quick] [--order stability,transient,nonlinear,measurement]``
(``--order``: the order in which the child compiles its groups in runs 1 and 3, to compare orders).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = """
import sys
from squealkit import _warmup
if sys.argv[2] == "off":
    _warmup.start = lambda groups: False
elif sys.argv[4]:  # the child's groups in this order
    order, start = sys.argv[4].split(","), _warmup.start
    _warmup.start = lambda groups: start([g for g in order if g in groups] + [g for g in groups if g not in order])
from squealkit.report import reproduce
reproduce(sys.argv[1], quick=sys.argv[3] == "quick")
"""


def _run(cache: Path, out: Path, warmup: str, quick: bool, order: str = "") -> float:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "MPLBACKEND": "Agg"}
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", CHILD, str(out), warmup, "quick" if quick else "full", order], env=env,
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="time reproduce(quick=True)")
    ap.add_argument("--order", default="", help="the child's groups in this order (comma-separated names)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cold = _run(tmp / "cache-a", tmp / "r1", "on", args.quick, args.order)
        base = _run(tmp / "cache-b", tmp / "r2", "off", args.quick)
        warm = _run(tmp / "cache-a", tmp / "r3", "on", args.quick, args.order)
    kind = "reproduce --quick" if args.quick else "reproduce"
    print(f"{kind}: cold with the warm-up child {cold:.1f} s, cold without it (baseline) {base:.1f} s, "
          f"warm {warm:.1f} s")
    print(f"  cold/warm {cold / warm:.2f}x (baseline {base / warm:.2f}x); the child saves {base - cold:.1f} s "
          f"({base / cold:.2f}x)")


if __name__ == "__main__":
    main()
