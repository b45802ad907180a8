"""Reading rig recordings: CSV, multi-channel WAV, netCDF/HDF5 (xarray), NI TDMS, ASAM MDF4, UFF 58.

A recording is a set of equally sampled channels (e.g. a microphone in Pa and an
eddy-current probe in m, paper §5.1). :func:`open_recording` inspects a file without
loading its samples and returns a :class:`RecordingSource` that yields blocks of samples
in order, so recordings of an hour or more are processed with bounded memory;
:func:`read_recording` loads everything into a labelled :class:`xarray.Dataset`.
"""

from __future__ import annotations

import contextlib
import gc
import logging
import math
import re
import sys
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numba as nb
import numpy as np
import xarray as xr
from numpy.typing import NDArray

from .._validation import InputError, validate_fs, validate_positive

__all__ = ["RecordingSource", "open_recording", "read_recording", "recording_dataset"]

_TIME_NAMES = {"t", "time", "time_s", "times", "zeit"}
_UNIT_RE = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\])]*)\s*[\])]\s*$")
#: Samples per block read from disk by default (about 6.5 s at 40 kHz).
DEFAULT_BLOCK = 1 << 18
#: Key of a file's own time axis in the blocks of the per-format readers (never a channel name).
_TIME = "\0time"


def _split_unit(label: str) -> tuple[str, str]:
    m = _UNIT_RE.match(label)
    if m:
        return m.group(1), m.group(2)
    return label.strip(), ""


def _fail(path: Path | str, what: str, channel: str | None = None) -> InputError:
    """The one-line error for a bad recording: the file, the channel when there is one, what is wrong."""
    where = f"Recording {str(path)!r}" + (f", channel {channel!r}" if channel is not None else "")
    return InputError(f"{where}: {_one_line(what)}")


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def _library_error(e: BaseException) -> str:
    """A library's exception as a short phrase: its type and the first 300 characters of its message."""
    return f"{type(e).__name__}: {_one_line(e)[:300]}"


def _file_rate(path: Path, value: object, what: str, *, interval: bool = False) -> float:
    """A sample rate [Hz] read from a file (or a sample interval [s] with ``interval``): finite and > 0."""
    if isinstance(value, np.generic):
        value = value.item()
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and x > 0):
        unit = "s" if interval else "Hz"
        raise _fail(path, f"its {what} is {value!r} {unit}, not a finite number > 0; give the sample rate fs "
                          "(--fs) to read it anyway.")
    return 1.0 / x if interval else x


@nb.njit(cache=True, nogil=True)
def _all_finite(values):  # pragma: no cover - compiled
    """Whether every value of a 1-D array is finite: ``np.isfinite(values).all()`` in one branch-free
    (vectorised) pass without a temporary array, twice as fast."""
    ok = True
    for i in range(values.shape[0]):
        x = values[i]
        ok &= x - x == 0.0
    return ok


def _check_finite(path: Path, name: str, values: NDArray[np.float64], offset: int,
                  where: Callable[[int], str]) -> None:
    if values.ndim == 1 and _all_finite(values):
        return
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.argmax(bad))
        raise _fail(path, f"non-finite sample ({float(values[i])!r}) at {where(offset + i)}.", channel=name)


def _as_samples(path: Path, name: str, values: Any) -> NDArray[np.float64]:
    """A channel's block as float64; text, byte strings and timestamps are named as such."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "biuf":
        kind = {"M": "timestamps", "m": "time differences", "c": "complex numbers"}.get(arr.dtype.kind, "text")
        raise _fail(path, f"holds {kind} (dtype {arr.dtype}), not numeric samples.", channel=name)
    return arr.astype(np.float64, copy=False)


def _stored_as_is(path: Path, dset: Any) -> int | None:
    """Byte offset in the file of an HDF5 dataset's numbers if they are stored there as they are (one
    contiguous run: not chunked, hence not filtered; written; within the file), else None."""
    if dset.chunks is not None or dset.dtype.kind not in "biuf":
        return None
    offset = dset.id.get_offset()
    if offset is None or offset + dset.size * dset.dtype.itemsize > path.stat().st_size:
        return None
    return int(offset)


def _mapped_block(path: Path, dtype: np.dtype, offset: int, start: int, stop: int) -> NDArray:
    """Values ``[start, stop)`` of a contiguous dataset stored at byte ``offset``, mapped from the file.

    Mapping a block instead of reading it saves copying it out of the operating system's cache
    (three quarters of the time of an h5py read). Copy on write: the array is writable and the file
    never changes. The mapping goes with the block's last reference, so memory stays bounded.
    """
    return np.asarray(np.memmap(path, dtype=dtype, mode="c", offset=offset + start * dtype.itemsize,
                                shape=(stop - start,)))


def _sample_where(k: int) -> str:
    return f"sample {k}"


@nb.njit(cache=True, nogil=True)
def _first_bad_time(t, last, has_last, dt):  # pragma: no cover - compiled
    """The first problem of a block of times, in time order, in one pass: ``k`` if ``t[k]`` is
    not finite, ``-2 - k`` if the step ending at ``t[k]`` goes back or is not ``dt`` within half
    an interval plus 8-significant-digit rounding; -1 when all is well."""
    prev = last
    for i in range(t.shape[0]):
        ti = t[i]
        if not np.isfinite(ti):
            return i
        if i > 0 or has_last:
            step = ti - prev
            if step < 0.0 or abs(step - dt) > 0.5 * dt + 2e-7 * abs(ti):
                return -2 - i
        prev = ti
    return -1


@nb.njit(cache=True, nogil=True)
def _time_steps_ok(t, last, has_last, dt):  # pragma: no cover - compiled
    """Whether a block of times passes the checks of :func:`_first_bad_time` (which locates a problem).

    Branch-free over the block so it compiles to vector instructions: four times faster than the
    scan with an early exit, which then runs only on a block that holds a problem.
    """
    ok = np.isfinite(t[0])
    if has_last:
        step = t[0] - last
        ok = ok and step >= 0.0 and abs(step - dt) <= 0.5 * dt + 2e-7 * abs(t[0])
    for i in range(1, t.shape[0]):
        ti = t[i]
        step = ti - t[i - 1]
        ok &= (ti - ti == 0.0) & (step >= 0.0) & (abs(step - dt) <= 0.5 * dt + 2e-7 * abs(ti))
    return ok


@dataclass
class _TimeAxis:
    """A recording's own time axis, checked block by block as it streams.

    Every step must be one sample interval ``dt``, within half an interval plus the
    rounding of 8 significant digits (how squealkit and most tools print a time column):
    a time that goes back, repeats, jumps (a gap) or is not a number is reported with the
    sample (or CSV line) where it happens.
    """

    path: Path
    label: str
    dt: float
    where: Callable[[int], str] = _sample_where
    last: float | None = None

    def check(self, start: int, t: NDArray[np.float64]) -> None:
        t = np.ascontiguousarray(t, dtype=np.float64)
        if t.size == 0:
            return
        has_last = self.last is not None
        last = self.last if has_last else 0.0
        if _time_steps_ok(t, last, has_last, self.dt):
            self.last = float(t[-1])
            return
        found = int(_first_bad_time(t, last, has_last, self.dt))
        if found >= 0:
            raise _fail(self.path, f"{self.label} is {float(t[found])!r} at {self.where(start + found)}.")
        if found <= -2:
            k_t = -2 - found  # the step ends at t[k_t]
            a = float(t[k_t - 1]) if k_t > 0 else float(self.last)
            b, k = float(t[k_t]), start + k_t
            if b < a:
                what = (f"goes back from {a:.9g} s to {b:.9g} s at {self.where(k)}; it must increase by one sample "
                        f"interval ({self.dt:.6g} s) per sample.")
            elif b - a > self.dt:
                what = (f"jumps from {a:.9g} s to {b:.9g} s at {self.where(k)}: a gap of {b - a:.6g} s where the "
                        f"sample interval is {self.dt:.6g} s.")
            else:
                what = (f"steps by {b - a:.6g} s (from {a:.9g} s to {b:.9g} s) at {self.where(k)} where the sample "
                        f"interval is {self.dt:.6g} s.")
            raise _fail(self.path, f"{self.label} {what}")
        self.last = float(t[-1])


def _head_interval(path: Path, label: str, t: NDArray[np.float64], where: Callable[[int], str]) -> float:
    """The sample interval [s] of a time axis from its first values (their median step), checked."""
    t = np.asarray(t, dtype=np.float64)
    if t.size < 2:
        raise _fail(path, f"{label} has {t.size} value(s) where its first block should hold several.")
    steps = np.diff(t)
    dt = float(np.median(steps)) if steps.size and np.all(np.isfinite(steps)) else math.nan
    if not (math.isfinite(dt) and dt > 0):
        bad_t = ~np.isfinite(t)
        if bad_t.any():
            i = int(np.argmax(bad_t))
            raise _fail(path, f"{label} is {float(t[i])!r} at {where(i)}.")
        i = int(np.argmax(steps <= 0))
        what = f"goes back from {t[i]:.9g} s to {t[i + 1]:.9g} s" if steps[i] < 0 else f"repeats {t[i]:.9g} s"
        raise _fail(path, f"{label} {what} at {where(i + 1)}; a time axis must increase by one sample interval "
                          "per sample (give the sample rate fs, --fs, to ignore it).")
    _TimeAxis(path, label, dt, where).check(0, t)
    return dt


@dataclass(frozen=True)
class RecordingSource:
    """A recording on disk: channel names, units, sample rate, and a block reader.

    Attributes
    ----------
    path : Path
        The recording file.
    fmt : str
        ``"csv"``, ``"wav"``, ``"netcdf"``, ``"tdms"``, ``"mdf4"`` or ``"uff"``.
    fs : float
        Sample rate [Hz].
    n_samples : int
        Samples per channel.
    channels : tuple of str
        Channel names in file order.
    units : dict
        Unit of each channel (``""`` when the file does not say).
    scales : dict of str to float
        Factor from file values to physical units, per channel name (absent: 1).
    """

    path: Path
    fmt: str
    fs: float
    n_samples: int
    channels: tuple[str, ...]
    units: dict[str, str]
    scales: dict[str, float] = field(default_factory=dict)
    _extra: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def synthetic(self) -> bool:
        """Whether the file says it is a synthetic recording (attribute ``synthetic``)."""
        return bool(self._extra.get("synthetic", False))

    @property
    def duration(self) -> float:
        """Length of the recording [s]."""
        return self.n_samples / self.fs

    def resolve(self, channel: str | int) -> str:
        """Channel name for a name or a 0-based index (also given as a digit string).

        Parameters
        ----------
        channel : str or int
            A channel name (for TDMS also the channel part of ``group/channel`` when unique) or
            a 0-based index.

        Returns
        -------
        str
            The channel's name in the file.

        Raises
        ------
        InputError
            If there is no such channel (the message lists the available ones).
        """
        if isinstance(channel, str) and channel in self.channels:
            return channel
        if isinstance(channel, str) and self.fmt == "tdms":
            matches = [c for c in self.channels if c.split("/")[-1] == channel]
            if len(matches) == 1:
                return matches[0]
        idx: int | None = None
        if isinstance(channel, int | np.integer) and not isinstance(channel, bool):
            idx = int(channel)
        elif isinstance(channel, str) and channel.strip().lstrip("-").isdigit():
            idx = int(channel)
        if idx is not None and 0 <= idx < len(self.channels):
            return self.channels[idx]
        other = getattr(self, "_extra", {}).get("non_numeric", {})  # (also lent to in-memory sources)
        hit = [n for n in other if channel in (n, n.split("/")[-1])]
        if hit:
            raise _fail(self.path, f"holds {other[hit[0]]}, not numeric samples; numeric channels: "
                                   f"{', '.join(repr(c) for c in self.channels)}.", channel=hit[0])
        raise InputError(
            f"Channel {channel!r} is not in {str(self.path)!r}; available: "
            f"{', '.join(repr(c) for c in self.channels)} (or an index 0-{len(self.channels) - 1})."
        )

    def _where(self, k: int) -> str:
        """Where sample ``k`` is in the file: a CSV line (the header is line 1) or a sample index."""
        return f"line {k + 2}" if self.fmt == "csv" else f"sample {k}"

    def iter_blocks(
        self, channels: Sequence[str | int], *, block: int = DEFAULT_BLOCK
    ) -> Iterator[tuple[int, dict[str, NDArray[np.float64]]]]:
        """Yield ``(start_sample, {name: samples})`` in order, in physical units, checked.

        Every sample must be finite; where the file has its own time axis (a CSV time column,
        a netCDF time coordinate, MDF4 time stamps) every step of it must be one sample
        interval. Anything wrong, and any failure of the format's library (a corrupted
        compressed chunk, a truncated file), raises :class:`~squealkit.InputError` naming the
        file, the channel and the sample (or CSV line). The time axis is read and checked
        until one pass has gone through the whole recording; later passes over the same
        source (an analysis with a tacho reads the file twice) skip it.

        Parameters
        ----------
        channels : sequence of str or int
            The channels to read (names or indices, see :meth:`resolve`).
        block : int, optional
            Samples per block (default 2**18, about 6.5 s at 40 kHz); the last block is shorter.

        Yields
        ------
        start_sample : int
            Index of the block's first sample.
        data : dict of str to ndarray
            Channel name -> samples (float64, physical units).
        """
        names = [self.resolve(c) for c in channels]
        if isinstance(block, bool) or not isinstance(block, int | np.integer) or block < 1:
            raise InputError(f"Parameter block={block!r} must be a whole number >= 1.")
        spec = self._extra.get("time_axis")
        checked = self._extra.get("time_axis_checked", False)
        axis = _TimeAxis(self.path, spec[0], spec[1], self._where) if spec and not checked else None
        blocks = getattr(self, f"_blocks_{self.fmt}")(names, int(block), axis is not None)
        done = 0
        while True:
            try:
                start, data = next(blocks)
            except StopIteration:
                break
            except InputError:
                raise
            except Exception as e:  # the format's library failed on the file: a damaged or truncated file
                raise _fail(self.path, f"could not be read after {self._where(done)}: {_library_error(e)}",
                            channel=names[0] if len(names) == 1 else None) from e
            out = {}
            for n in names:
                v = _as_samples(self.path, n, data[n])
                if n in self.scales:
                    v = v * self.scales[n]
                _check_finite(self.path, n, v, start, self._where)
                out[n] = v
            if axis is not None:
                axis.check(start, data[_TIME])
            done = start + len(out[names[0]]) if names else done
            yield start, out
        if names and done != self.n_samples:
            raise _fail(self.path, f"ends after {done} samples where {self.n_samples} were announced; the file "
                                   "looks truncated.")
        if names and axis is not None:
            self._extra["time_axis_checked"] = True  # every step of the whole axis passed

    # -- per-format block readers: yield (start, {name: values}) and the time axis under _TIME ----------
    def _blocks_csv(self, names: list[str], block: int, with_time: bool):
        import pandas as pd

        cols = self._extra["columns"]
        wanted = {**{n: cols[n] for n in names}, **({_TIME: self._extra["time_column"]} if with_time else {})}
        start = 0
        try:
            reader = pd.read_csv(self.path, usecols=list(dict.fromkeys(wanted.values())), chunksize=block,
                                 skipinitialspace=True, skip_blank_lines=False)
            for df in reader:
                df = df.iloc[: max(0, self.n_samples - start)]  # empty lines at the end are not rows
                if df.empty:
                    break
                data = {}
                for n, label in wanted.items():
                    col = df[label]
                    if not pd.api.types.is_numeric_dtype(col.dtype) or pd.api.types.is_bool_dtype(col.dtype):
                        vals = pd.to_numeric(col, errors="coerce")
                        i = int(np.argmax(vals.isna().to_numpy()))
                        what = f"time column {label!r}" if n == _TIME else f"channel {n!r}"
                        raise _fail(self.path, f"{what} has a non-numeric value {col.iloc[i]!r} at "
                                               f"{self._where(start + i)}.")
                    data[n] = col.to_numpy(dtype=np.float64)
                yield start, data
                start += len(df)
        except (pd.errors.ParserError, UnicodeDecodeError) as e:
            raise _fail(self.path, f"not a readable CSV: {_library_error(e)}") from e

    def _blocks_wav(self, names: list[str], block: int, with_time: bool):
        from scipy.io import wavfile

        _, raw = wavfile.read(self.path, mmap=True)
        raw = raw.reshape(raw.shape[0], -1)
        full = self._extra["full_scale"]
        idx = [self.channels.index(n) for n in names]
        for start in range(0, self.n_samples, block):
            chunk = np.asarray(raw[start:start + block])
            yield start, {n: chunk[:, i].astype(np.float64) / full for n, i in zip(names, idx, strict=True)}

    def _blocks_netcdf(self, names: list[str], block: int, with_time: bool):
        import h5py

        dim = self._extra["dim"]
        keys = {**{n: n for n in names}, **({_TIME: dim} if with_time else {})}
        try:  # netCDF-4 files are HDF5: read slices straight from h5py (much less overhead)
            f = h5py.File(self.path, "r")
        except OSError:
            f = None
        if f is not None:
            with f:
                dsets = {k: f[v] for k, v in keys.items() if v in f}
                plain = len(dsets) == len(keys) and all(
                    d.ndim == 1 and d.shape[0] == self.n_samples and not d.attrs.get("scale_factor")
                    and not d.attrs.get("add_offset") for d in dsets.values())
                if plain:
                    scale = self._extra.get("time_scale", 1.0)
                    offsets = {k: _stored_as_is(self.path, d) for k, d in dsets.items()}
                    for start in range(0, self.n_samples, block):
                        data = {}
                        stop = min(start + block, self.n_samples)
                        for k, d in dsets.items():  # a damaged chunk is named with its channel
                            try:
                                data[k] = d[start:stop] if offsets[k] is None else _mapped_block(
                                    self.path, d.dtype, offsets[k], start, stop)
                            except Exception as e:
                                what = f"time coordinate {dim!r}" if k == _TIME else f"channel {k!r}"
                                raise _fail(self.path, f"{what} could not be read at samples {start}-"
                                                       f"{stop - 1}: "
                                                       f"{_library_error(e)} (a damaged or truncated file?)") from e
                        if with_time and scale != 1.0:  # (in seconds: _TimeAxis.check takes them as they are)
                            data[_TIME] = np.asarray(data[_TIME], dtype=np.float64) * scale
                        yield start, data
                    return
        with xr.open_dataset(self.path, engine="h5netcdf", decode_times=False, decode_timedelta=False) as ds:
            scale = self._extra.get("time_scale", 1.0)
            for start in range(0, self.n_samples, block):
                sub = ds[[k for k in keys.values() if k in ds.data_vars]].isel({dim: slice(start, start + block)})
                data = {n: sub[n].values for n in names}
                if with_time:
                    data[_TIME] = np.asarray(ds[dim][start:start + block].values, dtype=np.float64) * scale
                yield start, data

    def _blocks_mdf4(self, names: list[str], block: int, with_time: bool):
        from asammdf import MDF

        # asammdf yields each channel in the chunks of its data blocks; cut them into equal blocks.
        # The time stamps come with the first requested channel's samples.
        where = self._extra["where"]
        with _mdf_scratch() as scratch, MDF(self.path, temporary_folder=scratch) as mdf:
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

    def _blocks_uff(self, names: list[str], block: int, with_time: bool):
        # a UFF 58 function is one record per channel: each wanted record is read block by block
        # from its place in the file (pyuff would parse a whole record, and read the whole file to
        # find the records), so memory stays bounded by the block
        records = _uff_records(self.path)
        streams = {n: _uff58_samples(self.path, records[self._extra["sets"][n]], block) for n in names}
        for start in range(0, self.n_samples, block):
            yield start, {n: next(s) for n, s in streams.items()}

    def _blocks_tdms(self, names: list[str], block: int, with_time: bool):
        from nptdms import TdmsFile

        with _quiet_logger("nptdms"), TdmsFile.open(self.path) as f:
            chans = {n: f[n.split("/")[0]][n.split("/", 1)[1]] for n in names}
            for start in range(0, self.n_samples, block):
                yield start, {n: c[start:start + block] for n, c in chans.items()}


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


def _scales_for(channels: Sequence[str], scale: Mapping[str, float] | Sequence[float] | float | None) -> dict:
    if scale is None:
        return {}
    if isinstance(scale, int | float):
        return {c: validate_positive("scale", scale) for c in channels}
    if isinstance(scale, Mapping):
        return {str(k): float(v) for k, v in scale.items()}
    vals = list(scale)
    if len(vals) != len(channels):
        raise InputError(f"Parameter scale has {len(vals)} values for {len(channels)} channels.")
    return {c: float(v) for c, v in zip(channels, vals, strict=True)}


def open_recording(
    path: str | Path,
    *,
    fs: float | None = None,
    scale: Mapping[str, float] | Sequence[float] | float | None = None,
    units: Mapping[str, str] | None = None,
) -> RecordingSource:
    """Inspect a recording file and return a lazy :class:`RecordingSource`.

    Every problem with the file (empty, truncated, damaged, a channel that is text, a sample
    rate that is zero or not a number, a time axis that goes back or jumps) raises
    :class:`~squealkit.InputError` with one line naming the file, the channel and where; the
    samples themselves are checked as they are read (:meth:`RecordingSource.iter_blocks`).

    Parameters
    ----------
    path : path-like
        ``.csv``/``.txt`` (header row; a time column named ``time``/``t``, or give ``fs``),
        ``.wav`` (multi-channel PCM or float), ``.nc``/``.h5``/``.hdf5`` (written by
        xarray; a 1-D time dimension), ``.tdms`` (NI; ``group/channel`` names), ``.mf4``
        (ASAM MDF4, read with asammdf block by block; channels of one sample rate) or
        ``.uff``/``.unv`` (universal file, dataset 58 time histories, read with pyuff one
        channel record at a time).
    fs : float, optional
        Sample rate [Hz]; required for a CSV without a time column, otherwise overrides
        the file's own (its time column or coordinate is then not used nor checked).
    scale : float, sequence or mapping, optional
        Factor per channel from file values to physical units (e.g. Pa per full scale of
        a WAV channel). Keys of a mapping are channel names (resolved like channels).
    units : mapping, optional
        Unit per channel, overriding the file's own (e.g. ``{"ch0": "Pa"}``). A channel in a
        unit of length, pressure, velocity, acceleration, force or voltage other than the SI
        one (``um``, ``mm``, ``mPa``, ``mm/s^2``, ``mV``) is read in SI: its samples
        scaled, its unit the SI one (the file's kept as ``file_units`` by :func:`read_recording`).

    Returns
    -------
    RecordingSource
        The file's channels, units and sample rate; samples are read only by
        :meth:`RecordingSource.iter_blocks`.

    Raises
    ------
    InputError
        If the file is missing, a folder, of an unknown format, or unreadable; one line naming
        the file (and channel).

    Examples
    --------
    >>> src = open_recording("rig.wav", scale={"ch0": 20.0}, units={"ch0": "Pa"})  # doctest: +SKIP
    >>> src.channels, src.fs  # doctest: +SKIP
    (('ch0', 'ch1'), 40000.0)
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"Recording {str(p)!r} does not exist.")
    if p.is_dir():
        raise InputError(f"Recording {str(p)!r} is a folder, not a file.")
    if fs is not None:
        fs = validate_fs(fs)
    suffix = p.suffix.lower()
    openers = {".csv": _open_csv, ".txt": _open_csv, ".wav": _open_wav, ".nc": _open_netcdf, ".h5": _open_netcdf,
               ".hdf5": _open_netcdf, ".nc4": _open_netcdf, ".tdms": _open_tdms, ".mf4": _open_mdf4,
               ".mdf": _open_mdf4, ".uff": _open_uff, ".unv": _open_uff}
    if suffix not in openers:
        raise InputError(f"Recording {str(p)!r} has an unknown format; use .csv, .wav, .nc/.h5, .tdms, "
                         ".mf4 or .uff/.unv.")
    try:
        if p.stat().st_size == 0:
            raise _fail(p, "the file is empty (0 bytes).")
        src = openers[suffix](p, fs)
    except InputError:
        raise
    except Exception as e:  # any parser failure is a user's unreadable file
        raise _fail(p, f"could not be read as {suffix}: {_library_error(e)}") from e
    if src.n_samples < 2:
        raise _fail(p, f"has {src.n_samples} sample(s); at least 2 are needed.")
    if not src.channels:
        raise _fail(p, "has no numeric data channel.")
    unit_map = dict(src.units)
    for k, v in (units or {}).items():
        unit_map[src.resolve(k)] = str(v)
    scales = {src.resolve(k): validate_positive(f"scale of {k}", v)
              for k, v in _scales_for(src.channels, scale).items()}
    unit_map, scales, file_units = _to_si(p, unit_map, scales)
    extra = {**src._extra, "file_units": file_units} if file_units else src._extra
    return RecordingSource(src.path, src.fmt, src.fs, src.n_samples, src.channels, unit_map, scales, extra)


def _to_si(p: Path, units: dict[str, str], scales: dict[str, float]
           ) -> tuple[dict[str, str], dict[str, float], dict[str, str]]:
    """Channels' units in SI (``um`` -> ``m`` with a factor 1e-6 on the samples, ``mPa`` -> ``Pa``).

    The unit of a channel (the file's, or ``units``) says what its values (after ``scale``) are
    in; a length, pressure, velocity, acceleration, force or voltage in another unit is read in
    its SI unit, the factor joining the channel's scale. Returns the SI units, the scales, and
    each converted channel's own unit. A unit pint does not know is kept, with a warning.
    """
    from .._units import channel_to_si

    si_units, out_scales, file_units = dict(units), dict(scales), {}
    for name, unit in units.items():
        factor, si, known = channel_to_si(unit)
        if not known:
            warnings.warn(f"Recording {str(p)!r}: channel {name!r} has the unit {unit!r}, which squealkit does not "
                          "know; its values are taken as they are.", UserWarning, stacklevel=3)
        if si != unit:
            si_units[name], file_units[name] = si, unit
            out_scales[name] = out_scales.get(name, 1.0) * factor
    return si_units, out_scales, file_units


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


#: Seconds per unit of a netCDF time coordinate (CF ``units``: ``"s"``, ``"milliseconds"``, ``"seconds since ..."``).
_TIME_UNITS = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3, "millisecond": 1e-3,
               "milliseconds": 1e-3, "us": 1e-6, "microsecond": 1e-6, "microseconds": 1e-6, "ns": 1e-9,
               "nanosecond": 1e-9, "nanoseconds": 1e-9, "min": 60.0, "minute": 60.0, "minutes": 60.0,
               "h": 3600.0, "hour": 3600.0, "hours": 3600.0, "d": 86400.0, "day": 86400.0, "days": 86400.0}


def _open_netcdf(p: Path, fs: float | None) -> RecordingSource:
    import h5netcdf
    import h5py

    # netCDF-4 is HDF5: h5netcdf lists the variables without reading any samples (xarray would
    # load the time coordinate to index it). Data variables, as in xarray: 1-D numeric variables
    # that are neither a dimension's coordinate nor named in a "coordinates" attribute.
    with h5py.File(p, "r") as h5, h5netcdf.File(h5, "r") as f:
        variables = f.variables
        coords = set(f.dimensions)
        for v in variables.values():
            coords.update(_attr_str(v.attrs.get("coordinates", "")).split())
        one_d = [n for n, v in variables.items() if n not in coords and v.ndim == 1]
        names = [n for n in one_d if np.issubdtype(variables[n].dtype, np.number)]
        if not names:
            raise _fail(p, "has no 1-D numeric variable.")
        dim = variables[names[0]].dimensions[0]
        names = [n for n in names if variables[n].dimensions == (dim,)]
        other = {n: f"values of dtype {variables[n].dtype}" for n in one_d if n not in names}
        n_samples = int(f.dimensions[dim].size)
        extra: dict[str, Any] = {"dim": dim, "synthetic": bool(f.attrs.get("synthetic", 0)), "non_numeric": other}
        if fs is None:
            if dim in variables and n_samples > 1:
                tv = variables[dim]
                tunits = _attr_str(tv.attrs.get("units", "s")).split(" since ")[0].strip().lower() or "s"
                scale = _TIME_UNITS.get(tunits)
                if scale is None:
                    raise _fail(p, f"time coordinate {dim!r} has units {tunits!r}; use seconds, or give fs.")
                label = f"time coordinate {dim!r}"
                dt = _head_interval(p, label, np.asarray(_head(h5, tv, dim, n_samples), dtype=float) * scale,
                                    _sample_where)
                if "fs" in f.attrs:  # both: the attribute sets the rate, the coordinate must agree
                    rate = _file_rate(p, f.attrs["fs"], "fs attribute")
                    if abs(dt * rate - 1) > 1e-3:
                        raise _fail(p, f"its fs attribute ({rate:.9g} Hz) and its {label} (steps of {dt:.6g} s, "
                                       f"{1 / dt:.9g} Hz) disagree; give fs.")
                    dt = 1.0 / rate
                fs = 1.0 / dt
                extra.update(time_axis=(label, dt), time_scale=scale)
            elif "fs" in f.attrs:
                fs = _file_rate(p, f.attrs["fs"], "fs attribute")
            else:
                raise _fail(p, "has no 'fs' attribute or time coordinate; give fs.")
        units = {n: _attr_str(variables[n].attrs.get("units", "")) for n in names}
        return RecordingSource(p, "netcdf", float(fs), n_samples, tuple(names), units, {}, extra)


def _head(h5: Any, variable: Any, name: str, n_samples: int, count: int = 64) -> NDArray:
    """The first ``count`` values of a 1-D netCDF variable of the root group.

    Read from its HDF5 dataset (``h5``, the open file) when that holds all ``n_samples`` numbers:
    then h5netcdf returns the dataset's values as they are, and reading them through it costs
    fifteen times as much (0.8 ms). Otherwise (a dataset shorter than its dimension, padded
    with fill values; strings) through h5netcdf's ``variable``.
    """
    import h5py

    dset = h5.get(name)
    if isinstance(dset, h5py.Dataset) and dset.shape == (n_samples,) and dset.dtype.kind in "biuf":
        return dset[:count]
    return variable[:count]


def _attr_str(value: Any) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


@contextlib.contextmanager
def _quiet_logger(package: str) -> Iterator[list[str]]:
    """Collect (instead of printing) what ``package`` logs through its own console handler (nptdms has one)."""
    seen: list[str] = []

    def keep(record: logging.LogRecord) -> bool:
        if record.name.split(".")[0] == package:
            seen.append(record.getMessage())
            return False
        return True

    handlers = {h for name, lg in logging.Logger.manager.loggerDict.items()
                if name.split(".")[0] == package and isinstance(lg, logging.Logger) for h in lg.handlers}
    for h in handlers:
        h.addFilter(keep)
    try:
        yield seen
    finally:
        for h in handlers:
            h.removeFilter(keep)


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


@contextlib.contextmanager
def _mdf(p: Path):
    """``asammdf.MDF(p)``, closed after use; a file it cannot open is one line, without asammdf's
    'Exception ignored in __del__' noise from the half-built object."""
    try:
        from asammdf import MDF
    except ImportError as e:
        raise InputError("Reading MDF4 needs asammdf: pip install 'squealkit[daq]'.") from e
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
                    head = (ch.name, np.asarray(sig.timestamps[:64], dtype=float))
                where[ch.name] = (gi, ci)
                units[ch.name] = str(ch.unit)
        synthetic = "SYNTHETIC" in str(mdf.header.comment)
        counts = {n: int(mdf.groups[g].channel_group.cycles_nr) for n, (g, _) in where.items()}
    if not where or n_samples is None or head is None:
        raise _fail(p, "has no numeric channel" + (f" (text: {', '.join(map(repr, other))})." if other else "."))
    if len(set(counts.values())) != 1:
        raise _fail(p, f"its channels have different lengths ({', '.join(f'{n}: {k}' for n, k in counts.items())} "
                       "samples); give channels of one sample rate.")
    extra: dict[str, Any] = {"where": where, "synthetic": synthetic, "non_numeric": other}
    if fs is None:
        label = f"time axis of channel {head[0]!r}"
        dt = _head_interval(p, label, head[1], _sample_where)
        fs = float(np.round(1.0 / dt, 6))
        extra["time_axis"] = (label, dt)
    return RecordingSource(p, "mdf4", float(fs), n_samples, tuple(where), units, {}, extra)


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
    lengths, incs, synthetic = {}, {}, False
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
    first = next(iter(sets))
    return RecordingSource(p, "uff", float(fs), lengths[first], tuple(sets), units, {},
                           {"sets": sets, "synthetic": synthetic})


def recording_dataset(
    channels: Mapping[str, NDArray[np.float64]], fs: float, units: Mapping[str, str] | None = None,
    attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Label equally sampled channels as a Dataset with a ``time`` coordinate [s].

    Parameters
    ----------
    channels : mapping of str to array_like
        Channel name -> samples, all of one length ``n``.
    fs : float
        Sample rate [Hz]; ``time = arange(n) / fs``.
    units : mapping of str to str, optional
        Unit per channel (stored as each variable's ``units`` attribute; default ``""``).
    attrs : mapping, optional
        Further Dataset attributes (``fs`` is always set).

    Returns
    -------
    xarray.Dataset
        One float64 variable per channel along ``time``.
    """
    fs = validate_fs(fs)
    n = len(next(iter(channels.values())))
    ds = xr.Dataset(
        {k: ("time", np.asarray(v, dtype=np.float64), {"units": (units or {}).get(k, "")})
         for k, v in channels.items()},
        coords={"time": ("time", np.arange(n) / fs, {"units": "s"})},
        attrs={"fs": fs, **(attrs or {})},
    )
    return ds


def read_recording(path: str | Path, channels: Sequence[str | int] | None = None, **kwargs: Any) -> xr.Dataset:
    """Load (some channels of) a recording into memory as a labelled Dataset.

    Keyword arguments are those of :func:`open_recording`. Use :func:`open_recording` and
    :meth:`RecordingSource.iter_blocks` for recordings too long to hold in memory.

    Parameters
    ----------
    path : str or Path
        The recording file (formats as in :func:`open_recording`).
    channels : sequence of str or int, optional
        Channel names or 0-based indices to load (default: all).
    **kwargs
        ``fs``, ``scale``, ``units`` of :func:`open_recording`.

    Returns
    -------
    xarray.Dataset
        As :func:`recording_dataset`, with a ``source`` attribute naming the file.
    """
    src = open_recording(path, **kwargs)
    names = [src.resolve(c) for c in (channels if channels is not None else src.channels)]
    parts: dict[str, list] = {n: [] for n in names}
    for _, block in src.iter_blocks(names):
        for n in names:
            parts[n].append(block[n])
    data = {n: np.concatenate(v) for n, v in parts.items()}
    attrs: dict[str, Any] = {"source": str(src.path)}
    if "time_jitter_rms" in src._extra:
        attrs |= {"fs_method": "least-squares slope of the time column against the sample index",
                  "time_jitter_rms": src._extra["time_jitter_rms"]}
    ds = recording_dataset(data, src.fs, {n: src.units.get(n, "") for n in names}, attrs)
    for n, unit in src._extra.get("file_units", {}).items():
        if n in ds:
            ds[n].attrs["file_units"] = unit  # the file's (or --unit's) unit, converted to units
    return ds
