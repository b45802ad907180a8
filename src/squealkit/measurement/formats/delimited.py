"""CSV and text recordings (one column per channel, an optional time column)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ._common import (
    _TIME,
    _TIME_NAMES,
    DEFAULT_BLOCK,
    _fail,
    _library_error,
    _split_unit,
    _time_base,
    _time_extra,
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


def _time_column(p: Path, label: str, n: int):
    """The values of a CSV's time column, in blocks, read once (stops where the parser fails: the block
    reader then says where)."""
    import pandas as pd

    start = 0
    try:
        for df in pd.read_csv(p, usecols=[label], chunksize=DEFAULT_BLOCK, skipinitialspace=True,
                              skip_blank_lines=False):
            t = pd.to_numeric(df[label], errors="coerce").to_numpy(dtype=np.float64)[: max(0, n - start)]
            yield t
            start += t.size
    except (pd.errors.ParserError, ValueError):
        return


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
        fs, jitter = _time_base(p, label, t, _time_column(p, labels[time_i], n_rows), n_rows,
                                lambda k: f"line {k + 2}")
        extra.update(time_column=labels[time_i], **_time_extra(label, fs, jitter))
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
