"""NI TDMS recordings (npTDMS)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._common import _fail, _file_rate, _quiet_logger
from .source import RecordingSource


def _open_tdms(p: Path, fs: float | None) -> RecordingSource:
    from nptdms import TdmsFile

    with open(p, "rb") as fh:
        if fh.read(4) != b"TDSm":
            raise _fail(p, "is not a TDMS file: it does not start with the 'TDSm' lead-in tag.")
    with _quiet_logger("nptdms") as said, TdmsFile.open(p) as f:
        synthetic = bool(int(f.properties.get("synthetic", 0) or 0))
        chans, units, lengths, incs, other = [], {}, {}, {}, {}
        for g in f.groups():
            for c in g.channels():
                name = f"{g.name}/{c.name}"
                if c.dtype is None or np.dtype(c.dtype).kind not in "biuf":
                    other[name] = "text" if c.dtype is None or np.dtype(c.dtype).kind in "OSU" else \
                        f"values of dtype {c.dtype}"
                    continue
                chans.append(name)
                units[name] = str(c.properties.get("unit_string", ""))
                lengths[name] = len(c)
                if "wf_increment" in c.properties:
                    incs[name] = c.properties["wf_increment"]
    truncated = [m for m in said if "less data than expected" in m or "incomplete" in m or "multiple of" in m]
    if truncated:
        raise _fail(p, f"is truncated (nptdms: {truncated[0]})")
    if not chans:
        raise _fail(p, "has no numeric channel" + (f" (text: {', '.join(map(repr, other))})." if other else "."))
    if len(set(lengths.values())) != 1:
        raise _fail(p, f"its channels have different lengths ({', '.join(f'{n}: {k}' for n, k in lengths.items())}"
                       " samples); give channels of one sample rate.")
    if fs is None:
        if not incs:
            raise _fail(p, "has no wf_increment property (the sample interval); give fs.")
        rates = {n: _file_rate(p, v, f"wf_increment of channel {n!r}", interval=True) for n, v in incs.items()}
        if max(rates.values()) > min(rates.values()) * (1 + 1e-9):
            raise _fail(p, "its channels have different sample intervals "
                           f"({', '.join(f'{n}: {incs[n]!r} s' for n in incs)}).")
        fs = next(iter(rates.values()))
    extra = {"synthetic": synthetic, "non_numeric": other}
    return RecordingSource(p, "tdms", float(fs), lengths[chans[0]], tuple(chans), units, {}, extra)


def blocks(src: RecordingSource, names: list[str], block: int, with_time: bool):
    from nptdms import TdmsFile

    with _quiet_logger("nptdms"), TdmsFile.open(src.path) as f:
        chans = {n: f[n.split("/")[0]][n.split("/", 1)[1]] for n in names}
        for start in range(0, src.n_samples, block):
            yield start, {n: c[start:start + block] for n, c in chans.items()}
