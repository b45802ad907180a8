"""Multi-channel WAV recordings (integer or float samples, a full scale per channel)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._common import _fail, _file_rate
from .source import RecordingSource


def _open_wav(p: Path, fs: float | None) -> RecordingSource:
    from scipy.io import wavfile

    try:
        rate, raw = wavfile.read(p, mmap=True)
    except ValueError as e:
        if "mmap length is greater than file size" not in str(e):
            raise
        raise _fail(p, "is truncated: its header announces more samples than the file holds.") from e
    n_ch = 1 if raw.ndim == 1 else raw.shape[1]
    if np.issubdtype(raw.dtype, np.integer):
        info = np.iinfo(raw.dtype)
        full = float(-info.min) if info.min < 0 else float(info.max)
    else:
        full = 1.0
    chans = tuple(f"ch{i}" for i in range(n_ch))
    rate = fs or _file_rate(p, rate, "sample rate (WAV header)")
    return RecordingSource(p, "wav", float(rate), raw.shape[0], chans, dict.fromkeys(chans, ""), {},
                           {"full_scale": full})


def blocks(src: RecordingSource, names: list[str], block: int, with_time: bool):
    from scipy.io import wavfile

    _, raw = wavfile.read(src.path, mmap=True)
    raw = raw.reshape(raw.shape[0], -1)
    full = src._extra["full_scale"]
    idx = [src.channels.index(n) for n in names]
    for start in range(0, src.n_samples, block):
        chunk = np.asarray(raw[start:start + block])
        yield start, {n: chunk[:, i].astype(np.float64) / full for n, i in zip(names, idx, strict=True)}
