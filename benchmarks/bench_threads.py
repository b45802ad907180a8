"""Benchmark: small jobs on one thread against numba's parallel kernels on every core.

squealkit's stability and transient kernels are numba ``prange`` loops. A parallel call
wakes every worker thread and waits for the slowest; for a small call that start-up costs
more than the work, and when the cores are shared with other jobs a waiting call stalls
until every worker gets a core. ``squealkit._threads.threads_for`` therefore runs calls
below ``SERIAL_BELOW`` eigenvalue points (and single transient runs) on one thread. This
prints, in one run, for each job size, alternating: the time with every kernel forced onto
all of numba's threads (what squealkit did before ``threads_for``), with the default
choice, and on one thread (``--threads 1``); then the same for whole small jobs (a
critical friction, i.e. a bisection of many tiny calls, and a single transient run).

Run:  python benchmarks/bench_threads.py [--load 1] [--repeat 5]

``--load N`` starts N busy-looping processes for the run (a machine shared with other
jobs) and ends them afterwards.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import subprocess
import sys
import time

import numba
import numpy as np

from squealkit._threads import SERIAL_BELOW, limit_threads, thread_limit
from squealkit.models import get_preset
from squealkit.stability import critical_friction, eigenvalues
from squealkit.transient import simulate

#: the modules that call threads_for
_CALL_SITES = tuple(importlib.import_module(f"squealkit.{m}")
                    for m in ("stability.eigen", "stability.ensemble", "transient._driver"))


@contextlib.contextmanager
def forced_parallel():
    """Every kernel on all threads whatever its size: squealkit before threads_for."""
    saved = [m.threads_for for m in _CALL_SITES]
    for m in _CALL_SITES:
        m.threads_for = lambda work_items, **kw: thread_limit()
    try:
        yield
    finally:
        for m, f in zip(_CALL_SITES, saved, strict=True):
            m.threads_for = f


def best_of(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def three_ways(fn, repeat: int) -> tuple[float, float, float]:
    """Best times of ``fn`` forced parallel, by default and on 1 thread, alternating."""
    par, auto, one = [], [], []
    for _ in range(repeat):
        with forced_parallel():
            par.append(best_of(fn, 1))
        auto.append(best_of(fn, 1))
        with limit_threads(1):
            one.append(best_of(fn, 1))
    return min(par), min(auto), min(one)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5, help="best of N, serial and parallel alternating")
    ap.add_argument("--load", type=int, default=0, help="busy-looping processes to run alongside")
    args = ap.parse_args()
    model = get_preset("lv2013")
    pool = numba.config.NUMBA_NUM_THREADS
    # compile / load every kernel once, on both thread counts
    for n in (1, pool):
        with limit_threads(n):
            eigenvalues(model, np.linspace(0, 0.8, 64), tan_theta=0.0, damped=True)
            simulate(model, mu=0.4, duration=1e-3)
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.load)]
    try:
        print(f"numba threads {pool}, competing busy processes {args.load}, SERIAL_BELOW = {SERIAL_BELOW} points")
        head = f"{f'{pool} threads':>12} {'default':>10} {'1 thread':>10} {f'{pool} thr / 1 thr':>14}"
        print(f"{'eigenvalue points':>18} {head}   [ms per call]")
        for points in (1, 10, 100, 1_000, 5_000, 10_000, 20_000, 50_000, 200_000):
            mu = np.linspace(0.0, 0.8, points)
            reps = max(1, min(200, 20_000 // points))

            def job(mu=mu, reps=reps):
                for _ in range(reps):
                    eigenvalues(model, mu, tan_theta=0.0, damped=True)

            tp, ta, t1 = (t / reps * 1e3 for t in three_ways(job, args.repeat))
            print(f"{points:>18} {tp:>12.3f} {ta:>10.3f} {t1:>10.3f} {tp / t1:>14.2f}")
        print(f"{'small job':>32} {head}   [s]")
        jobs = {
            "critical_friction (bisection)": lambda: critical_friction(model, damped=True),
            "simulate, 0.05 s, one run": lambda: simulate(model, mu=0.4, duration=0.05),
        }
        for name, fn in jobs.items():
            tp, ta, t1 = three_ways(fn, max(1, args.repeat // 2))
            print(f"{name:>32} {tp:>12.3f} {ta:>10.3f} {t1:>10.3f} {tp / t1:>14.2f}")
    finally:
        for p in hogs:
            p.kill()
            p.wait()


if __name__ == "__main__":
    main()
