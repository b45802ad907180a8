"""Cost of checking a whole recording as it streams (not part of the tests; issue #15).

Usage::

    python benchmarks/bench_readers.py                  # 60 s, 3 channels + time, 40 kHz CSV and netCDF
    python benchmarks/bench_readers.py --seconds 300 --repeat 5

squealkit now checks every CSV row's field count and every step of a file's own time axis
(CSV time column, netCDF time coordinate) while it streams the samples. The baseline, in the
same run and on the same files, is the bare library read: ``pandas.read_csv`` in chunks of
the same block size, reading the same columns (time included), and ``h5py`` slices of the
same variables; squealkit's figure is ``open_recording`` + ``iter_blocks`` over all channels
(opening counts the rows, checks the fields; iterating parses, converts and checks). Times
are the best of ``--repeat`` runs, CPU time (``time.process_time``) beside wall time, as the
machine is shared.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))


def _best(fn, repeat: int) -> tuple[float, float]:
    wall, cpu = float("inf"), float("inf")
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall, cpu = min(wall, time.perf_counter() - w0), min(cpu, time.process_time() - c0)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    import h5py
    import pandas as pd

    from squealkit.measurement import open_recording, recording_dataset
    from squealkit.measurement.formats._common import DEFAULT_BLOCK
    from squealkit.measurement.formats.writers import write_recording

    fs = 40000.0
    n = int(args.seconds * fs)
    rng = np.random.default_rng(0)
    rec = recording_dataset({c: rng.standard_normal(n) for c in ("mic", "displacement", "tacho")}, fs)
    with tempfile.TemporaryDirectory() as d:
        for suffix in (".csv", ".nc"):
            path = write_recording(rec, Path(d) / f"r{suffix}")
            size = path.stat().st_size / 2**20

            def ours(path=path) -> None:
                src = open_recording(path)
                for _ in src.iter_blocks(src.channels):
                    pass

            if suffix == ".csv":
                def base(path=path) -> None:
                    for _ in pd.read_csv(path, chunksize=DEFAULT_BLOCK, skipinitialspace=True):
                        pass
                name = "pandas.read_csv (chunked, all columns)"
            else:
                def base(path=path) -> None:
                    with h5py.File(path, "r") as f:
                        dsets = [f[v] for v in ("time", "mic", "displacement", "tacho")]
                        for s in range(0, n, DEFAULT_BLOCK):
                            for ds in dsets:
                                ds[s:s + DEFAULT_BLOCK]
                name = "h5py slices (time + 3 channels)"
            ours()  # warm caches and imports
            w_o, c_o = _best(ours, args.repeat)
            w_b, c_b = _best(base, args.repeat)
            print(f"{suffix} {args.seconds:g} s x 3 channels at 40 kHz ({size:.0f} MiB): squealkit open+stream "
                  f"{w_o:.3f} s wall / {c_o:.3f} s CPU; baseline {name} {w_b:.3f} s / {c_b:.3f} s; "
                  f"ratio {w_o / w_b:.2f} wall, {c_o / c_b:.2f} CPU")


if __name__ == "__main__":
    main()
