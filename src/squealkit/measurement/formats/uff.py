"""Universal file format (UFF 58) recordings, read record by record."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._validation import InputError
from ._common import _fail, _file_rate
from .source import RecordingSource


def _uff_records(path: Path, chunk: int = 1 << 18) -> list[tuple[int, int]]:
    """Byte ranges ``[start, end)`` of a universal file's records, found chunk by chunk.

    A record lies between two delimiter lines ``    -1`` (followed by a line end, or blanks to
    column 80), as pyuff finds them; record ``i`` is pyuff's data set ``i``.
    """
    marks: list[int] = []
    buf, base = b"", 0  # buf starts at file offset base
    with open(path, "rb") as fh:
        while True:
            data = fh.read(chunk)
            buf += data
            keep, last = None, -1
            i = buf.find(b"    -1")
            while i != -1:
                if data and i + 80 > len(buf):  # the mark's line may go on in the next chunk
                    keep = i
                    break
                rest = buf[i + 6:i + 80]
                if not rest or rest[:1] in (b"\n", b"\r") or rest == b" " * 74:
                    marks.append(base + i)
                last = i
                i = buf.find(b"    -1", i + 1)
            if not data:
                break
            keep = max(len(buf) - 85, last + 1) if keep is None else keep
            buf, base = buf[keep:], base + keep
    return [(marks[k], marks[k + 1]) for k in range(0, len(marks) - 1, 2)]


def _uff_headers(path: Path, records: list[tuple[int, int]]) -> list[dict[str, Any] | None]:
    """The header fields of each record that is a dataset 58 (None for the others), reading only
    its first 13 lines; the fields and column widths are pyuff's (``_extract58``)."""
    out: list[dict[str, Any] | None] = []
    with open(path, "rb") as fh:
        for start, _end in records:
            fh.seek(start)
            head = [fh.readline().decode("utf-8", errors="replace").rstrip("\r\n").ljust(80) for _ in range(13)]
            try:
                kind = int(head[1][:6])
            except ValueError:
                kind = None  # not a dataset pyuff knows either: skipped
            if kind != 58:
                out.append(None)
                continue
            try:
                out.append({
                    "id1": head[2][:80].strip(),
                    "id2": head[3][:80].strip(),
                    "num_pts": int(head[8][10:20]),
                    "abscissa_spacing": int(head[8][20:30]),
                    "abscissa_inc": float(head[8][43:56]),
                    "abscissa_inc_text": head[8][43:56].strip(),
                    "ordinate_axis_units_lab": head[10][46:67].strip(),
                })
            except ValueError as e:
                raise _fail(path, f"has a dataset 58 header that cannot be read ({e}).") from e
    return out


def _uff58_samples(path: Path, record: tuple[int, int], block: int) -> Iterator[NDArray[np.float64]]:
    """Samples of one UFF 58 record (real, evenly spaced; ASCII or binary 58b), ``block`` at a time."""
    with open(path, "rb") as fh:
        fh.seek(record[0])
        head = [fh.readline() for _ in range(13)]  # "    -1", the 58 line, 11 header lines
        ord_type, n_pts, even = int(head[8][:10]), int(head[8][10:20]), int(head[8][20:30])
        if ord_type not in (2, 4) or not even:
            raise InputError(f"UFF 58 record of {str(path)!r}: only real, evenly sampled functions are "
                             f"recordings (ordinate type {ord_type}, even spacing {even}).")
        binary = head[1][6:7].lower() == b"b"
        if binary:  # raw floats after the header
            dtype = np.dtype(f"{'<' if int(head[1][7:13]) == 1 else '>'}f{4 if ord_type == 2 else 8}")
            avail = (record[1] - fh.tell()) // dtype.itemsize  # samples before the closing "    -1"
        width, per_line = (13, 6) if ord_type == 2 else (20, 4)  # 6E13.5 or 4E20.12 per line
        carry = np.empty(0)
        for done in range(0, n_pts, block):
            m = min(block, n_pts - done)
            if binary:
                v = np.frombuffer(fh.read(max(0, min(m, avail - done)) * dtype.itemsize), dtype=dtype).astype(float)
            else:  # whole lines, the values past this block carried to the next
                need = m - carry.size
                lines = [fh.readline() for _ in range(max(0, -(-need // per_line)))]
                text = b"".join(ln.rstrip(b"\r\n").ljust(per_line * width) for ln in lines)
                fields = np.frombuffer(text, dtype=f"S{width}")[:n_pts - done - carry.size]
                try:
                    v = np.concatenate([carry, fields.astype(np.float64)])
                except ValueError as e:
                    raise InputError(f"UFF 58 record of {str(path)!r} has a sample that is not a number: "
                                     f"{e}") from e
                v, carry = v[:m], v[m:]
            if v.size < m:
                raise InputError(f"UFF 58 record of {str(path)!r} ends after {done + v.size} of {n_pts} samples.")
            yield v


def _whole_rate(inc_text: str) -> tuple[float, float, float] | None:
    """The whole number of Hz that a sample interval written as text may stand for, or None.

    UFF 58 writes the abscissa increment in E13.5 (6 significant digits): the interval of a
    48 kHz recording, 2.0833...e-05 s, is written 2.08333e-05, whose inverse is 48000.077 Hz. The
    text stands for every interval within half a unit of its last digit; where the rates of that
    interval hold a whole number of Hz, that is the rate (the one with most trailing zeros where
    several do, a round rate such as 1 MHz). Returns ``(rate, low, high)`` [Hz], the rate and the
    range of rates the text stands for, or None.
    """
    m = re.fullmatch(r"[+-]?\d*\.?(\d*)(?:[eEdD]([+-]?\d+))?", inc_text)
    if m is None:
        return None
    inc = float(inc_text.replace("D", "E").replace("d", "e"))
    half = 0.5 * 10.0 ** (int(m[2] or 0) - len(m[1]))
    if not (math.isfinite(inc) and inc > half):
        return None
    low, high = 1.0 / (inc + half), 1.0 / (inc - half)
    whole = range(math.ceil(low), math.floor(high) + 1)
    if not whole:
        return None

    def zeros(k: int) -> int:
        return len(str(k)) - len(str(k).rstrip("0"))

    rate = min(whole, key=lambda k: (-zeros(k), abs(k - 1.0 / inc)))
    return float(rate), low, high


def _open_uff(p: Path, fs: float | None) -> RecordingSource:
    # headers only: the records are found chunk by chunk and only each one's 13 header lines are
    # read (pyuff reads the whole file to find its records, and a whole record to read a header:
    # 632 MB peak to open a 60 s, 48 kHz file); the samples are read later, block by block
    with open(p, "rb") as fh:  # every universal dataset ends with a line "    -1": a file cut short does not
        fh.seek(max(0, p.stat().st_size - 256))
        tail = fh.read().split()
    if not tail or tail[-1] != b"-1":
        raise _fail(p, "is truncated: it does not end with a dataset's closing '-1' line.")
    sets: dict[str, int] = {}
    units: dict[str, str] = {}
    lengths, incs, texts, synthetic = {}, {}, {}, False
    for i, d in enumerate(_uff_headers(p, _uff_records(p))):
        if d is None:
            continue
        name = d["id1"] or f"ch{len(sets)}"
        if name in sets:
            name = f"{name}_{i}"
        sets[name] = i
        units[name] = d["ordinate_axis_units_lab"]
        lengths[name] = d["num_pts"]
        if d["abscissa_spacing"] != 1:
            raise _fail(p, "its abscissa is uneven (abscissa_spacing 0); squealkit reads equally sampled time "
                           "histories.", channel=name)
        incs[name] = d["abscissa_inc"]
        texts[name] = d["abscissa_inc_text"]
        synthetic |= "SYNTHETIC" in d["id2"]
    if not sets:
        raise _fail(p, "has no dataset 58 (function at nodal DOF).")
    if len(set(lengths.values())) != 1:
        raise _fail(p, f"its channels have different lengths ({', '.join(f'{n}: {k}' for n, k in lengths.items())} "
                       "samples); give channels of one sample rate.")
    if fs is None:
        rates = {n: _file_rate(p, v, f"abscissa_inc of channel {n!r}", interval=True) for n, v in incs.items()}
        if max(rates.values()) > min(rates.values()) * (1 + 1e-9):
            raise _fail(p, "its channels have different sample intervals "
                           f"({', '.join(f'{n}: {incs[n]!r} s' for n in incs)}).")
        fs = next(iter(rates.values()))
        rounded = _whole_rate(next(iter(texts.values())))
        if rounded is not None and rounded[0] != fs:  # 6 significant digits: 48 kHz reads 48000.077 Hz
            fs_file, (fs, low, high) = fs, rounded
            extra = {"fs_from_file": fs_file,
                     "fs_rounding": f"the file's abscissa_inc {next(iter(texts.values()))} s (UFF 58 writes 6 "
                                    f"significant digits) gives 1/abscissa_inc = {fs_file:.10g} Hz; the rates it "
                                    f"stands for, {low:.10g}-{high:.10g} Hz, hold the whole rate {fs:g} Hz, used"}
        else:
            extra = {}
    else:
        extra = {}
    first = next(iter(sets))
    return RecordingSource(p, "uff", float(fs), lengths[first], tuple(sets), units, {},
                           {"sets": sets, "synthetic": synthetic, **extra})


def blocks(src: RecordingSource, names: list[str], block: int, with_time: bool):
    # a UFF 58 function is one record per channel: each wanted record is read block by block
    # from its place in the file (pyuff would parse a whole record, and read the whole file to
    # find the records), so memory stays bounded by the block
    records = _uff_records(src.path)
    streams = {n: _uff58_samples(src.path, records[src._extra["sets"][n]], block) for n in names}
    for start in range(0, src.n_samples, block):
        yield start, {n: next(s) for n, s in streams.items()}
