"""Speed and memory of squealkit's rig measurement analysis (not part of the tests).

Usage::

    python benchmarks/bench_measurement.py                 # 60 s recording + 1 h streamed
    python benchmarks/bench_measurement.py --long 600      # shorter long run

1. A 60 s two-channel 40 kHz SYNTHETIC recording: end-to-end time of
   ``analyze_recording`` from memory and from a netCDF file (read + analyse), as a
   real-time factor (recording length / wall time). Target: >= 300x.
2. A long SYNTHETIC recording (default one hour) streamed block by block through the
   chunked analysis in a fresh subprocess; prints wall time (including generating the
   samples) and the subprocess's peak resident memory (``resource.getrusage``).
   Target: < 2 GiB.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

KW = dict(mic="mic", displacement="displacement", rpm=900.0, radius=0.05)


def _best(fn, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def short(duration: float) -> None:
    from squealkit.io import save_dataset
    from squealkit.measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=duration, seed=1)
    analyze_recording(rec, **KW)  # warm-up
    t_mem = _best(lambda: analyze_recording(rec, **KW))
    print(f"in memory : {duration:g} s SYNTHETIC 2 ch @ 40 kHz analysed in {t_mem:.3f} s "
          f"-> {duration / t_mem:.0f}x real time")
    with tempfile.TemporaryDirectory() as d:
        path = save_dataset(rec, Path(d) / "rec.nc")
        t_file = _best(lambda: analyze_recording(path, **KW))
    print(f"from .nc  : {duration:g} s read + analysed in {t_file:.3f} s -> {duration / t_file:.0f}x real time")


def long_child(duration: float) -> None:
    from squealkit.measurement import analyze_recording, synthetic_source

    src = synthetic_source(duration=duration, seed=1)
    t0 = time.perf_counter()
    res = analyze_recording(src, **KW)
    dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2  # KiB -> GiB (Linux)
    print(f"long      : {duration:g} s SYNTHETIC streamed in chunks: {dt:.1f} s wall incl. generating the "
          f"samples ({duration / dt:.0f}x real time), {len(res.events)} events, rising_fraction "
          f"{res.rising_fraction:.3f}, peak memory {peak:.2f} GiB")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--short", type=float, default=60.0, help="length of the timed recording [s]")
    ap.add_argument("--long", type=float, default=3600.0, help="length of the streamed recording [s] (0: skip)")
    ap.add_argument("--child-long", type=float, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child_long is not None:
        long_child(args.child_long)
        return
    short(args.short)
    if args.long > 0:
        subprocess.run([sys.executable, __file__, "--child-long", str(args.long)], check=True)


if __name__ == "__main__":
    main()
