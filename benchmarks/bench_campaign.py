"""Throughput of ``squealkit campaign`` on a SYNTHETIC J2521-like campaign (not part of the tests).

Usage::

    python benchmarks/bench_campaign.py                   # 40 applications of 10 s at 48 kHz
    python benchmarks/bench_campaign.py --applications 200 --duration 10
    python benchmarks/bench_campaign.py --applications 2000 --runs dask1,dask2   # the issue's campaign

Each application is a 10 s recording at 48 kHz with a microphone, an eddy-current probe and a
tacho (conditions such as pressure and temperature come from the test matrix). Timed in one
run, on the same files:

1. baseline: a plain loop of ``analyze_recording`` over the files (no database, no summary);
2. ``run_campaign`` here, one application after another (DuckDB store, summary.json);
3. ``run_campaign`` on a local Dask cluster with 1 worker, then with 2 workers (1 thread each),
   started as ``squealkit campaign --scheduler local`` starts it (``squealkit.scale.cluster_client``).

``--runs`` picks among ``baseline,serial,dask1,dask2`` (default: all). Prints each time, the ratios
against the baseline, the 1 -> 2 worker speed-up, and the time a 2,000-application matrix would
take at the measured rate. The files take about 15 MB per 10 s application (30 GB for 2,000) in
a temporary folder, removed at the end, or in ``--data DIR``, kept and reused by later runs.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

KW = dict(mic="mic", displacement="displacement", radius=0.05, tacho="tacho")


def _cpu() -> float:
    """CPU seconds (user + system, all threads) of the calling process so far."""
    import psutil

    t = psutil.Process().cpu_times()
    return t.user + t.system


def _warm(path: str) -> None:
    """Import and compile everything in a worker before timing (numba caches, scipy)."""
    from squealkit.measurement import analyze_recording

    analyze_recording(path, **KW)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--applications", type=int, default=40)
    ap.add_argument("--duration", type=float, default=10.0, help="length of each application [s]")
    ap.add_argument("--fs", type=float, default=48000.0)
    ap.add_argument("--runs", default="baseline,serial,dask1,dask2", help="which timings to take")
    ap.add_argument("--data", default=None,
                    help="keep the generated campaign in this folder and reuse it when it is there already "
                         "(default: a temporary folder, removed at the end)")
    args = ap.parse_args()
    runs = set(filter(None, args.runs.split(",")))  # empty: only generate (into --data)
    if not runs <= {"baseline", "serial", "dask1", "dask2"}:
        ap.error(f"--runs {args.runs!r}: choose among baseline, serial, dask1, dask2")

    from squealkit.campaign import read_matrix, run_campaign, synthetic_campaign
    from squealkit.measurement import analyze_recording
    from squealkit.scale import cluster_client

    n, dur = args.applications, args.duration
    t_base = t_serial = None
    with contextlib.ExitStack() as stack:
        d = Path(args.data) if args.data else Path(stack.enter_context(tempfile.TemporaryDirectory()))
        if (d / "truth.json").is_file():
            truth = json.loads((d / "truth.json").read_text())
            if truth["applications"] != n:
                ap.error(f"--data {d} holds {truth['applications']} applications, not {n}")
            print(f"reused    : {n} SYNTHETIC applications in {d}")
        else:
            t0 = time.perf_counter()
            truth = synthetic_campaign(d, n_applications=n, duration=dur, fs=args.fs, seed=1)
            t_gen = time.perf_counter() - t0
            print(f"generated : {n} SYNTHETIC applications of {dur:g} s @ {args.fs / 1000:g} kHz in {t_gen:.1f} s")
        apps = read_matrix(d / "matrix.csv")
        analyze_recording(apps[0].file, **KW)  # warm-up (imports, numba caches)

        if "baseline" in runs:
            t0 = time.perf_counter()
            for a in apps:
                analyze_recording(a.file, **KW)
            t_base = time.perf_counter() - t0

        if "serial" in runs:
            t0 = time.perf_counter()
            s = run_campaign(d / "matrix.csv", d / "out-serial", report=False, **KW)
            t_serial = time.perf_counter() - t0
            assert abs(s["occurrence_percent"] - truth["occurrence_percent"]) < 1e-9

        t_dask, cpu = {}, {}
        for workers in [w for w in (1, 2) if f"dask{w}" in runs]:
            with cluster_client("local", n_workers=workers) as client:  # as `campaign --scheduler local`
                client.run(_warm, str(apps[0].file))
                out = d / f"out-dask{workers}"
                w0, s0 = client.run(_cpu), client.run_on_scheduler(_cpu)
                c0, t0 = time.process_time(), time.perf_counter()
                s = run_campaign(d / "matrix.csv", out, client=client, report=False, **KW)
                t_dask[workers] = time.perf_counter() - t0
                assert abs(s["occurrence_percent"] - truth["occurrence_percent"]) < 1e-9
                w1, s1 = client.run(_cpu), client.run_on_scheduler(_cpu)
                cpu[workers] = (sum(w1[k] - w0[k] for k in w1), s1 - s0, time.process_time() - c0)
                shutil.rmtree(out)

    audio = n * dur

    def ratio(t):
        return f", ratio to baseline {t / t_base:.2f}" if t_base else ""

    if t_base:
        print(f"baseline  : analyze_recording loop      {t_base:7.2f} s  ({audio / t_base:5.0f}x real time)")
    if t_serial:
        print(f"campaign  : run_campaign, serial         {t_serial:7.2f} s  ({audio / t_serial:5.0f}x real time)"
              + ratio(t_serial))
    for w, t in t_dask.items():
        print(f"campaign  : run_campaign, Dask {w} worker(s) {t:7.2f} s  ({audio / t:5.0f}x real time)" + ratio(t))
    if len(t_dask) == 2:
        print(f"scaling   : 1 -> 2 Dask workers: {t_dask[1] / t_dask[2]:.2f}x (wall)")
    for w, (cw, cs, cc) in cpu.items():
        print(f"CPU       : {w} worker(s): workers {cw:6.2f} s ({cw / n * 1000:.0f} ms per application), "
              f"scheduler {cs:5.2f} s, client (store, summary) {cc:5.2f} s; wall {t_dask[w]:.2f} s")
    if len(cpu) == 2:
        # in CPU terms: the workers' share runs in parallel, the scheduler's and the client's need a core too
        w1, w2 = cpu[1][0], cpu[2][0] / 2
        print(f"scaling   : 1 -> 2 workers in CPU terms (worker CPU per worker, ideal cores): {w1 / w2:.2f}x; "
              f"worker CPU grew {cpu[2][0] / cpu[1][0]:.2f}x from 1 to 2 workers")
    timed = [t for t in (t_serial, *t_dask.values()) if t]
    if not timed:
        return
    best = min(timed)
    print(f"2000 apps : about {2000 / n * best / 60:.1f} min at the best rate measured here "
          f"({2000 * dur / 3600:.1f} h of recordings)")


if __name__ == "__main__":
    main()
