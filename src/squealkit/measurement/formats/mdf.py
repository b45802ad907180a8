"""ASAM MDF4 recordings (asammdf)."""

from __future__ import annotations

import contextlib
import gc
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._optional import require
from ._common import _TIME, _TIME_NAMES, DEFAULT_BLOCK, _fail, _library_error, _time_base, _time_extra
from .source import RecordingSource


@contextlib.contextmanager
def _mdf(p: Path):
    """``asammdf.MDF(p)``, closed after use; a file it cannot open is one line, without asammdf's
    'Exception ignored in __del__' noise from the half-built object."""
    MDF = require("asammdf", "Reading MDF4").MDF
    hook = sys.unraisablehook

    def quiet(u: Any) -> None:
        if str(getattr(u.object, "__module__", "") or type(u.object).__module__).startswith("asammdf"):
            return
        hook(u)

    with _mdf_scratch() as scratch:
        sys.unraisablehook = quiet
        try:
            try:
                mdf = MDF(p, temporary_folder=scratch)
            except Exception as e:
                msg = f"could not be read as MDF4 (a damaged or truncated file?): {_library_error(e)}"
                e.__traceback__ = None  # frees the half-built object now, while its noise is filtered
                del e
                gc.collect()
                raise _fail(p, msg) from None
        finally:
            sys.unraisablehook = hook
        with mdf:
            yield mdf


@contextlib.contextmanager
def _mdf_scratch() -> Iterator[str]:
    """A private folder for asammdf's temporary files, removed after use.

    asammdf copies a file flagged unfinalised into the temporary folder before reading it,
    and leaves the copy there when the file then fails to read.
    """
    import shutil
    import tempfile

    scratch = tempfile.mkdtemp(prefix="squealkit-mdf4-")
    try:
        yield scratch
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _open_mdf4(p: Path, fs: float | None) -> RecordingSource:
    with _mdf(p) as mdf:
        where: dict[str, tuple[int, int]] = {}
        units: dict[str, str] = {}
        other: dict[str, str] = {}
        n_samples, head = None, None
        for gi, group in enumerate(mdf.groups):
            for ci, ch in enumerate(group.channels):
                if ch.name in where or ch.name.lower() in _TIME_NAMES or ci == mdf.masters_db.get(gi):
                    continue
                kind = int(getattr(ch, "data_type", 0))
                # numeric data types: MDF4 0-5 (integers, floats); MDF3 all but 7 (string) and 8 (bytes)
                if (kind > 5) if str(mdf.version).startswith("4") else kind in (7, 8):
                    other[ch.name] = f"text or bytes (MDF data type {kind})"
                    continue
                if n_samples is None:
                    n_samples = int(group.channel_group.cycles_nr)
                    sig = next(mdf.iter_get(ch.name, group=gi, index=ci))
                    head = (ch.name, gi, np.asarray(sig.timestamps[:64], dtype=float))
                where[ch.name] = (gi, ci)
                units[ch.name] = str(ch.unit)
        synthetic = "SYNTHETIC" in str(mdf.header.comment)
        counts = {n: int(mdf.groups[g].channel_group.cycles_nr) for n, (g, _) in where.items()}
        if not where or n_samples is None or head is None:
            raise _fail(p, "has no numeric channel" + (f" (text: {', '.join(map(repr, other))})." if other
                                                       else "."))
        if len(set(counts.values())) != 1:
            raise _fail(p, f"its channels have different lengths ({', '.join(f'{n}: {k}' for n, k in counts.items())}"
                           " samples); give channels of one sample rate.")
        extra: dict[str, Any] = {"where": where, "synthetic": synthetic, "non_numeric": other}
        if fs is None:
            label = f"time axis of channel {head[0]!r}"
            fs, jitter = _time_base(p, label, head[2], _master_blocks(mdf, head[1], n_samples), n_samples)
            extra.update(_time_extra(label, fs, jitter))
    return RecordingSource(p, "mdf4", float(fs), n_samples, tuple(where), units, {}, extra)


def _master_blocks(mdf: Any, group: int, n: int, block: int = DEFAULT_BLOCK) -> Iterator[NDArray]:
    """The time stamps of data group ``group`` (its master channel), ``block`` records at a time."""
    for start in range(0, n, block):
        yield np.asarray(mdf.get_master(group, record_offset=start, record_count=min(block, n - start)))


def blocks(src: RecordingSource, names: list[str], block: int, with_time: bool):
    MDF = require("asammdf", "Reading MDF4").MDF

    # asammdf yields each channel in the chunks of its data blocks; cut them into equal blocks.
    # The time stamps come with the first requested channel's samples.
    where = src._extra["where"]
    with _mdf_scratch() as scratch, MDF(src.path, temporary_folder=scratch) as mdf:
        its: dict[str, Iterator[NDArray]] = {
            n: (s[0] for s in mdf.iter_get(n, group=where[n][0], index=where[n][1], samples_only=True))
            for n in names}
        if with_time and names:
            n0 = names[0]
            its[_TIME] = (s.timestamps for s in mdf.iter_get(n0, group=where[n0][0], index=where[n0][1]))
        keys = list(its)
        buf: dict[str, list[NDArray]] = {k: [] for k in keys}
        have = dict.fromkeys(keys, 0)
        start = 0
        exhausted: set[str] = set()
        while True:
            for k in keys:
                while have[k] < block and k not in exhausted:
                    try:
                        samples = np.asarray(next(its[k]))
                    except StopIteration:
                        exhausted.add(k)
                        break
                    buf[k].append(samples)
                    have[k] += samples.size
            take = min(min(have.values()), block)
            if take == 0:
                return
            out = {}
            for k in keys:
                joined = np.concatenate(buf[k])
                out[k], rest = joined[:take], joined[take:]
                buf[k], have[k] = [rest], rest.size
            yield start, out
            start += take
