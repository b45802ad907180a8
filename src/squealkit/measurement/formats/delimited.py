"""CSV and text recordings (one column per channel, an optional time column)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ._common import (
    _TIME,
    _TIME_NAMES,
    DEFAULT_BLOCK,
    _fail,
    _head_interval,
    _library_error,
    _split_unit,
    _time_steps_ok,
)
from .source import RecordingSource


def _csv_rows(p: Path, n_fields: int) -> int:
    """Count a CSV's data rows, checking on the way that every row has the header's fields.

    Reads the file once in blocks of lines (bounded memory). A row with more or fewer
    fields (a truncated last row, a row from another table) or an empty row between data
    rows is reported with its line number; empty lines at the very end are ignored.
    A block (4 MiB) whose comma count is its row count times the header's is taken as
    right without looking at each row; only rows with fields too many and others (or empty
    lines) with as many too few in the same block could hide there (a short row then still
    fails as a missing sample). Blocks holding a quote character are left to the CSV parser (a quoted
    field may hold a comma).
    """
    line = 1  # lines before the current block (the header is line 1)
    first_blank: int | None = None
    rows = 0
    with open(p, "rb") as fh:
        fh.readline()
        rest = b""
        while True:
            chunk = fh.read(1 << 22)
            at_end = not chunk
            data = rest + chunk
            if not at_end:
                cut = data.rfind(b"\n") + 1
                data, rest = data[:cut], data[cut:]
            elif data and not data.endswith(b"\n"):
                data += b"\n"
            if data and first_blank is None and data.count(b",") == (n_fields - 1) * data.count(b"\n"):
                # the common case, at the speed of bytes.count: as many fields in the block as rows x fields
                n_lines = data.count(b"\n")
                rows += n_lines
                line += n_lines
            elif data:
                a = np.frombuffer(data, dtype=np.uint8)
                nl = np.flatnonzero(a == 10)
                length = np.diff(nl, prepend=-1) - 1
                blank = (length == 0) | ((length == 1) & (a[np.maximum(nl - 1, 0)] == 13))
                if b'"' in data:
                    fields = np.full(nl.size, n_fields)
                else:
                    fields = np.diff(np.searchsorted(np.flatnonzero(a == 44), nl), prepend=0) + 1
                bad = (fields != n_fields) & ~blank
                if first_blank is not None and nl.size and not blank.all():
                    raise _fail(p, f"line {first_blank} is empty; data rows must follow each other.")
                if bad.any():
                    i = int(np.argmax(bad))
                    before = np.flatnonzero(blank[:i])
                    if before.size:
                        raise _fail(p, f"line {line + 1 + int(before[0])} is empty; data rows must follow each other.")
                    more = "extra fields" if fields[i] > n_fields else "missing fields (a truncated row?)"
                    has = f"{fields[i]} field" + ("" if fields[i] == 1 else "s")
                    raise _fail(p, f"line {line + 1 + i} has {has} where the header has {n_fields}: {more}.")
                if blank.any():
                    j = int(np.argmax(blank))
                    if not blank[j:].all():
                        raise _fail(p, f"line {line + 1 + j} is empty; data rows must follow each other.")
                    first_blank = first_blank or line + 1 + j
                    rows += j
                elif first_blank is None:
                    rows += nl.size
                line += nl.size
            if at_end:
                return rows


#: Jitter of a time column (RMS about its least-squares line, as a share of the sample interval) above which
#: reading it warns: the rounding of 7 decimals at 48 kHz is 0.14 %.
_JITTER_WARN = 0.05


def _last_time(p: Path, column: int) -> float:
    """The time in the last data row of a CSV (NaN when it cannot be read from the file's tail)."""
    import csv

    with open(p, "rb") as fh:
        fh.seek(0, 2)
        fh.seek(max(0, fh.tell() - 4096))
        lines = [ln for ln in fh.read().decode("utf-8", errors="replace").splitlines() if ln.strip()]
    try:
        return float(next(csv.reader([lines[-1]]))[column])
    except (IndexError, ValueError, StopIteration):
        return math.nan


def _fit_time_column(p: Path, label: str, column: int, n: int, t0: float, dt0: float) -> tuple[float, float]:
    """Sample interval [s] of a CSV's whole time column by least squares, and the RMS of its residuals [s].

    A time column rounded to a few decimals has steps that are each off by up to the rounding
    (7 decimals at 48 kHz: 2.08e-5 or 2.09e-5 s for 2.0833e-5 s); the slope of time against
    sample index over the whole column is not. One pass over the column, in blocks, about
    the line through the first and last times (so the sums hold only the residuals' size).
    Falls back to ``dt0`` (the first rows' median step) where a value is not a number or a step
    is not one sample interval: the block reader then says where.
    """
    import pandas as pd

    t_last = _last_time(p, column)
    dt1 = (t_last - t0) / (n - 1) if math.isfinite(t_last) and t_last > t0 else dt0
    kbar, skk = (n - 1) / 2.0, n * (n * n - 1.0) / 12.0
    s_ku = s_u = s_uu = last = 0.0
    start = 0
    try:
        for df in pd.read_csv(p, usecols=[label], chunksize=DEFAULT_BLOCK, skipinitialspace=True,
                              skip_blank_lines=False):
            t = pd.to_numeric(df[label], errors="coerce").to_numpy(dtype=np.float64)[: max(0, n - start)]
            k = np.arange(start, start + t.size, dtype=np.float64)
            u = t - t0 - dt1 * k
            if not (t.size and _time_steps_ok(np.ascontiguousarray(t), last, start > 0, dt0)):
                return dt0, math.nan  # a step that is not one sample interval: the block reader says where
            last = float(t[-1])
            s_ku += float(np.dot(k - kbar, u))
            s_u += float(u.sum())
            s_uu += float(np.dot(u, u))
            start += t.size
    except (pd.errors.ParserError, ValueError):
        return dt0, math.nan
    if start != n or n < 3:
        return dt0, math.nan
    slope = s_ku / skk
    dt = dt1 + slope
    if not (math.isfinite(dt) and dt > 0):
        return dt0, math.nan
    ss = s_uu - s_u * s_u / n - slope * slope * skk
    return dt, math.sqrt(max(ss, 0.0) / (n - 2))


def _open_csv(p: Path, fs: float | None) -> RecordingSource:
    import csv

    import pandas as pd

    with open(p, encoding="utf-8", errors="replace", newline="") as fh:
        header = next(csv.reader([fh.readline()]), [])
    n_rows = _csv_rows(p, len(header))
    try:
        head = pd.read_csv(p, nrows=64, skipinitialspace=True)
    except pd.errors.EmptyDataError as e:
        raise _fail(p, "the file is empty.") from e
    if n_rows < 2:
        raise _fail(p, f"has {n_rows} data row(s); at least 2 are needed (fewer than 2 rows).")
    labels = [str(c) for c in head.columns]
    parsed = [_split_unit(c) for c in labels]
    time_i = next((i for i, (n, _) in enumerate(parsed) if n.lower() in _TIME_NAMES), None)
    if time_i is None and fs is None:
        raise _fail(p, "has no time column (named 'time' or 't'); give the sample rate fs.")
    extra: dict[str, Any] = {}
    if time_i is not None and fs is None:
        label = f"time column {labels[time_i]!r}"
        col = head.iloc[:, time_i]
        t = pd.to_numeric(col, errors="coerce").to_numpy(dtype=float)
        if np.isnan(t).any():
            i = int(np.argmax(np.isnan(t)))
            raise _fail(p, f"{label} has a non-numeric value {col.iloc[i]!r} at line {i + 2}.")
        dt = _head_interval(p, label, t, lambda k: f"line {k + 2}")
        dt, jitter = _fit_time_column(p, labels[time_i], time_i, n_rows, float(t[0]), dt)
        fs = 1.0 / dt
        extra.update(time_column=labels[time_i], time_axis=(label, dt), time_jitter_rms=jitter)
        if jitter > _JITTER_WARN * dt:
            warnings.warn(f"Recording {str(p)!r}: its {label} has a jitter of {jitter:.3g} s RMS about a uniform "
                          f"time base, {jitter / dt:.0%} of the sample interval ({dt:.6g} s); the samples are "
                          f"taken as uniform at fs = {fs:.9g} Hz (least squares over the whole column).",
                          UserWarning, stacklevel=3)
    channels, units, columns = [], {}, {}
    for i, (name, unit) in enumerate(parsed):
        if i == time_i:
            continue
        channels.append(name)
        units[name] = unit
        columns[name] = labels[i]
    if not channels:
        raise _fail(p, "has only a time column and no data channel.")
    return RecordingSource(p, "csv", float(fs), n_rows, tuple(channels), units, {}, {"columns": columns, **extra})


def blocks(src: RecordingSource, names: list[str], block: int, with_time: bool):
    import pandas as pd

    cols = src._extra["columns"]
    wanted = {**{n: cols[n] for n in names}, **({_TIME: src._extra["time_column"]} if with_time else {})}
    start = 0
    try:
        reader = pd.read_csv(src.path, usecols=list(dict.fromkeys(wanted.values())), chunksize=block,
                             skipinitialspace=True, skip_blank_lines=False)
        for df in reader:
            df = df.iloc[: max(0, src.n_samples - start)]  # empty lines at the end are not rows
            if df.empty:
                break
            data = {}
            for n, label in wanted.items():
                col = df[label]
                if not pd.api.types.is_numeric_dtype(col.dtype) or pd.api.types.is_bool_dtype(col.dtype):
                    vals = pd.to_numeric(col, errors="coerce")
                    i = int(np.argmax(vals.isna().to_numpy()))
                    what = f"time column {label!r}" if n == _TIME else f"channel {n!r}"
                    raise _fail(src.path, f"{what} has a non-numeric value {col.iloc[i]!r} at "
                                           f"{src._where(start + i)}.")
                data[n] = col.to_numpy(dtype=np.float64)
            yield start, data
            start += len(df)
    except (pd.errors.ParserError, UnicodeDecodeError) as e:
        raise _fail(src.path, f"not a readable CSV: {_library_error(e)}") from e
