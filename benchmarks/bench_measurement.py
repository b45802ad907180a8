"""Speed and memory of squealkit's rig measurement analysis (not part of the tests).

Usage::

    python benchmarks/bench_measurement.py                 # 60 s recording + 1 h streamed
    python benchmarks/bench_measurement.py --long 600      # shorter long run
    python benchmarks/bench_measurement.py --short 0 --from-file   # 1 h written to netCDF, then analysed
    python benchmarks/bench_measurement.py --long 0 --baseline-src /work/main/src   # against another version

1. A 60 s two-channel 40 kHz SYNTHETIC recording: end-to-end time of
   ``analyze_recording`` from memory and from a netCDF file (read + analyse), as a
   real-time factor (recording length / wall time). Target: >= 300x. Then a decelerating
   stop at 48 kHz with a tacho channel, analysed with the tacho and, as the baseline of the
   same run, at constant rpm (and, with ``--baseline-src``, by another squealkit version, e.g.
   main's checkout, in a subprocess on the same file, interleaved so both see the same load).
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
    return _best2(fn, repeat)[0]


def _best2(fn, repeat: int = 3) -> tuple[float, float]:
    """Best wall and best CPU time (``time.process_time``: this process, all threads) of ``repeat`` calls."""
    wall = cpu = float("inf")
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall, cpu = min(wall, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
    return wall, cpu


def _time_other(src: str, path: Path, rpm: float | None, tacho: str | None = None, repeat: int = 1
                ) -> tuple[float, float]:
    """Best wall and CPU seconds another squealkit version (its ``src`` folder) takes to analyse ``path``."""
    speed = f"tacho={tacho!r}" if tacho else f"rpm={rpm}"
    code = ("import sys,time; sys.path.insert(0, sys.argv[1]); "
            "from squealkit.measurement import analyze_recording as a; "
            f"kw=dict(mic='mic', displacement='displacement', {speed}, radius=0.05); "
            "a(sys.argv[2], **kw); w=c=9e9\n"
            f"for _ in range({repeat}):\n"
            " t0=time.perf_counter(); c0=time.process_time(); a(sys.argv[2], **kw)\n"
            " w=min(w, time.perf_counter()-t0); c=min(c, time.process_time()-c0)\n"
            "print(w, c)")
    out = subprocess.run([sys.executable, "-c", code, src, str(path)], check=True, capture_output=True,
                         text=True).stdout
    w, c = out.strip().splitlines()[-1].split()
    return float(w), float(c)


def short(duration: float, baseline_src: str | None = None) -> None:
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
        if baseline_src:  # interleaved with this version, three times each
            t_file, t_other = float("inf"), float("inf")
            for _ in range(3):
                t_file = min(t_file, _best(lambda: analyze_recording(path, **KW), repeat=1))
                t_other = min(t_other, _time_other(baseline_src, path, 900.0)[0])
    print(f"from .nc  : {duration:g} s read + analysed in {t_file:.3f} s -> {duration / t_file:.0f}x real time")
    if baseline_src:
        print(f"baseline  : {baseline_src}: {t_other:.3f} s -> {duration / t_other:.0f}x real time; "
              f"ratio this / baseline = {t_file / t_other:.2f} (time)")


def tacho(duration: float, baseline_src: str | None, repeat: int = 3) -> None:
    """A decelerating stop read from netCDF with its tacho: wall and CPU time, this code and the baseline."""
    from squealkit.io import save_dataset
    from squealkit.measurement import analyze_recording, synthetic_recording

    rec = synthetic_recording(duration=duration, seed=1, fs=48000.0, rpm_end=300.0)
    with tempfile.TemporaryDirectory() as d:
        path = save_dataset(rec, Path(d) / "stop.nc")
        analyze_recording(path, mic="mic", displacement="displacement", radius=0.05, tacho="tacho")  # warm-up
        times: dict[str, tuple[float, float]] = {}
        for _ in range(repeat):  # interleaved: each contender sees the machine's load of the moment
            for name, kw in (("constant rpm", dict(rpm=600.0)), ("tacho", dict(tacho="tacho"))):
                w, c = _best2(lambda kw=kw: analyze_recording(path, mic="mic", displacement="displacement",
                                                              radius=0.05, **kw), repeat=2)
                old = times.get(name, (float("inf"), float("inf")))
                times[name] = (min(old[0], w), min(old[1], c))
            if baseline_src:
                w, c = _time_other(baseline_src, path, None, tacho="tacho", repeat=2)
                old = times.get("baseline tacho", (float("inf"), float("inf")))
                times["baseline tacho"] = (min(old[0], w), min(old[1], c))
    for name, (w, c) in times.items():
        print(f"stop .nc  : {duration:g} s @ 48 kHz, {name:15s}: wall {w:.3f} s ({duration / w:.0f}x real time), "
              f"CPU {c:.3f} s ({duration / c:.0f}x)")
    print(f"ratio     : tacho / constant rpm = {times['tacho'][1] / times['constant rpm'][1]:.2f} (CPU)")
    if baseline_src:
        print(f"speed-up  : baseline ({baseline_src}) / this, with tacho: "
              f"{times['baseline tacho'][0] / times['tacho'][0]:.2f}x wall, "
              f"{times['baseline tacho'][1] / times['tacho'][1]:.2f}x CPU")


def write_long_file(path: Path, duration: float) -> None:
    """Write a long SYNTHETIC recording to netCDF-4 block by block (float32, bounded memory)."""
    import h5netcdf

    from squealkit.measurement import synthetic_source

    src = synthetic_source(duration=duration, seed=1)
    with h5netcdf.File(path, "w") as f:
        f.dimensions["time"] = src.n_samples
        f.attrs["fs"] = src.fs
        f.attrs["synthetic"] = 1
        var = {}
        for name, unit in (("mic", "Pa"), ("displacement", "m")):
            var[name] = f.create_variable(name, ("time",), "f4", chunks=(1 << 18,))
            var[name].attrs["units"] = unit
        for start, block in src.iter_blocks(["mic", "displacement"], block=1 << 20):
            for name, v in block.items():
                var[name][start:start + v.size] = v.astype("f4")


def long_child(duration: float, path: str | None) -> None:
    from squealkit.measurement import analyze_recording, synthetic_source

    rec = path if path else synthetic_source(duration=duration, seed=1)
    what = f"read from {Path(path).name} ({Path(path).stat().st_size / 1024**3:.2f} GiB)" if path else \
        "generated and streamed"
    t0 = time.perf_counter()
    res = analyze_recording(rec, **KW)
    dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2  # KiB -> GiB (Linux)
    print(f"long      : {duration:g} s SYNTHETIC {what} in chunks: {dt:.1f} s wall "
          f"({duration / dt:.0f}x real time), {len(res.events)} events, rising_fraction "
          f"{res.rising_fraction:.3f}, peak memory {peak:.2f} GiB")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--short", type=float, default=60.0, help="length of the timed recording [s]")
    ap.add_argument("--long", type=float, default=3600.0, help="length of the streamed recording [s] (0: skip)")
    ap.add_argument("--from-file", action="store_true",
                    help="write the long recording to a temporary netCDF file first and analyse the file")
    ap.add_argument("--tacho", type=float, default=30.0, help="length of the timed stop with a tacho [s] (0: skip)")
    ap.add_argument("--baseline-src", default=None,
                    help="src folder of another squealkit version to time in the same run (e.g. /work/main/src)")
    ap.add_argument("--child-long", type=float, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--child-path", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child_long is not None:
        long_child(args.child_long, args.child_path)
        return
    if args.short > 0:
        short(args.short, args.baseline_src)
    if args.tacho > 0:
        tacho(args.tacho, args.baseline_src)
    if args.long > 0:
        cmd = [sys.executable, __file__, "--child-long", str(args.long)]
        with tempfile.TemporaryDirectory() as d:
            if args.from_file:
                path = Path(d) / "long.nc"
                write_long_file(path, args.long)
                cmd += ["--child-path", str(path)]
            subprocess.run(cmd, check=True)


if __name__ == "__main__":
    main()
