"""Benchmark: CPU seconds numba spends compiling the transient kernels on an empty cache (issue #27's cold start).

Each case runs in a fresh process with its own empty ``NUMBA_CACHE_DIR`` and reports the
process's CPU time (user + system, ``resource.getrusage``: not wall time, the machine may be
shared) spent in the first call, which is compilation plus a run of a fraction of a millisecond:

- ``dopri5``: what ``squealkit reproduce``'s warm-up child compiles (``_warmup._transient``);
- ``rosenbrock``, ``rk4``: the other two integrators (one short ``simulate`` each);
- ``floquet``: the monodromy kernel of ``floquet``.

With ``--old REF`` (a git revision, e.g. ``main``) the same cases also run on that revision's
sources (``git archive``), so both paths are measured in the same session. Then, with the cache
warm, the CPU time of a 0.2 s Dormand-Prince run of the paper's case (best of 3).

Run:  python benchmarks/bench_compile.py [--old main] [--cases dopri5,rosenbrock,rk4,floquet]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")
import numpy as np
from squealkit import _warmup
from squealkit.models import get_preset
from squealkit.transient import Contact, SineRunOut, simulate
case, mode = sys.argv[1], sys.argv[2]
model, sro = get_preset("lv2013"), SineRunOut(0.08e-3, 1e-3)

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

def call():
    if case == "dopri5":
        _warmup._transient()
    elif case == "rosenbrock":
        simulate(model, mu=0.4, profile=sro, duration=2e-4, method="rosenbrock", contact=Contact.nonlinear())
    elif case == "rk4":
        simulate(model, mu=0.4, profile=sro, duration=2e-4, method="rk4")
    elif case == "floquet":
        from squealkit.transient.floquet import floquet
        # a short period (5 ms): over the paper's 50 ms the motion at mu = 0.4 outgrows double precision
        floquet(model, mu=0.3, amplitude=0.08e-3, wavelength=1e-3, speed=0.2, steps_per_period=200)

if mode == "compile":
    c = cpu()
    call()
    print(json.dumps({"cpu": cpu() - c}))
else:  # warm cache: run time of a 0.2 s Dormand-Prince run
    simulate(model, mu=0.4, profile=sro, duration=1e-3)
    best = 1e9
    for _ in range(3):
        t = time.process_time()
        simulate(model, mu=0.4, profile=sro, duration=0.2)
        best = min(best, time.process_time() - t)
    print(json.dumps({"run": best}))
"""


def _child(src: Path, cache: Path, case: str, mode: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(src), "SQUEALKIT_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", CHILD, case, mode], env=env, check=True, capture_output=True,
                         text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def _measure(label: str, src: Path, cases: list[str]) -> None:
    for case in cases:
        with tempfile.TemporaryDirectory() as cache:
            try:
                cpu = _child(src, Path(cache), case, "compile")["cpu"]
            except subprocess.CalledProcessError as e:  # one revision's API may differ: say so, measure the rest
                print(f"{label:>5} {case:<11} failed: {(e.stderr or '').strip().splitlines()[-1:]}", flush=True)
                continue
            print(f"{label:>5} {case:<11} compile CPU {cpu:7.1f} s", flush=True)
            if case == "dopri5":
                run = _child(src, Path(cache), case, "run")["run"]
                print(f"{label:>5} {'dopri5':<11} run 0.2 s   {run:7.3f} s CPU (warm cache, best of 3)", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", help="git revision whose sources to measure as well (e.g. main)")
    ap.add_argument("--cases", default="dopri5,rosenbrock,rk4,floquet")
    args = ap.parse_args()
    cases = args.cases.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        if args.old:
            archive = Path(tmp) / "old.tar"
            subprocess.run(["git", "-C", str(ROOT), "archive", "-o", str(archive), args.old, "src"], check=True)
            with tarfile.open(archive) as tf:
                tf.extractall(tmp, filter="data")
            _measure("old", Path(tmp) / "src", cases)
        _measure("new", ROOT / "src", cases)


if __name__ == "__main__":
    main()
