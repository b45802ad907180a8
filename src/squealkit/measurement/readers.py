"""Reading rig recordings: CSV, multi-channel WAV, netCDF/HDF5 (xarray), NI TDMS, ASAM MDF4, UFF 58.

A recording is a set of equally sampled channels (e.g. a microphone in Pa and an
eddy-current probe in m, paper §5.1). :func:`open_recording` inspects a file without
loading its samples and returns a :class:`RecordingSource` that yields blocks of samples
in order, so recordings of an hour or more are processed with bounded memory;
:func:`read_recording` loads everything into a labelled :class:`xarray.Dataset`.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from .._validation import InputError, validate_fs, validate_positive

__all__ = ["RecordingSource", "open_recording", "read_recording", "recording_dataset"]

_TIME_NAMES = {"t", "time", "time_s", "times", "zeit"}
_UNIT_RE = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\])]*)\s*[\])]\s*$")
#: Samples per block read from disk by default (about 6.5 s at 40 kHz).
DEFAULT_BLOCK = 1 << 18


def _split_unit(label: str) -> tuple[str, str]:
    m = _UNIT_RE.match(label)
    if m:
        return m.group(1), m.group(2)
    return label.strip(), ""


def _check_finite(name: str, values: NDArray[np.float64], offset: int) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"Channel {name!r} has a non-finite sample ({values[i]!r}) at sample {offset + i}.")


@dataclass(frozen=True)
class RecordingSource:
    """A recording on disk: channel names, units, sample rate, and a block reader.

    Attributes
    ----------
    path : Path
    fmt : str
        ``"csv"``, ``"wav"``, ``"netcdf"`` or ``"tdms"``.
    fs : float
        Sample rate [Hz].
    n_samples : int
    channels : tuple of str
        Channel names in file order.
    units : dict
        Unit of each channel (``""`` when the file does not say).
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
        """Channel name for a name or a 0-based index (also given as a digit string)."""
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
        raise InputError(
            f"Channel {channel!r} is not in {str(self.path)!r}; available: "
            f"{', '.join(repr(c) for c in self.channels)} (or an index 0-{len(self.channels) - 1})."
        )

    def iter_blocks(
        self, channels: Sequence[str | int], *, block: int = DEFAULT_BLOCK
    ) -> Iterator[tuple[int, dict[str, NDArray[np.float64]]]]:
        """Yield ``(start_sample, {name: samples})`` in order, in physical units, checked finite."""
        names = [self.resolve(c) for c in channels]
        reader = getattr(self, f"_blocks_{self.fmt}")
        for start, data in reader(names, block):
            out = {}
            for n in names:
                v = np.asarray(data[n], dtype=np.float64)
                if n in self.scales:
                    v = v * self.scales[n]
                _check_finite(n, v, start)
                out[n] = v
            yield start, out

    # -- per-format block readers ------------------------------------------------------
    def _blocks_csv(self, names: list[str], block: int):
        import pandas as pd

        cols = self._extra["columns"]
        usecols = [cols[n] for n in names]
        start = 0
        try:
            for df in pd.read_csv(self.path, usecols=usecols, chunksize=block, skipinitialspace=True):
                data = {}
                for n in names:
                    col = df[cols[n]]
                    if not pd.api.types.is_numeric_dtype(col.dtype) or pd.api.types.is_bool_dtype(col.dtype):
                        vals = pd.to_numeric(col, errors="coerce")
                        i = int(np.argmax(vals.isna().to_numpy()))
                        raise InputError(
                            f"Channel {n!r} has a non-numeric sample {col.iloc[i]!r} at sample {start + i}."
                        )
                    data[n] = col.to_numpy(dtype=np.float64)
                yield start, data
                start += len(df)
        except (pd.errors.ParserError, UnicodeDecodeError) as e:
            raise InputError(f"File {str(self.path)!r} is not a readable CSV: {e}") from e

    def _blocks_wav(self, names: list[str], block: int):
        from scipy.io import wavfile

        _, raw = wavfile.read(self.path, mmap=True)
        raw = raw.reshape(raw.shape[0], -1)
        full = self._extra["full_scale"]
        idx = [self.channels.index(n) for n in names]
        for start in range(0, self.n_samples, block):
            chunk = np.asarray(raw[start:start + block])
            yield start, {n: chunk[:, i].astype(np.float64) / full for n, i in zip(names, idx, strict=True)}

    def _blocks_netcdf(self, names: list[str], block: int):
        import h5py

        try:  # netCDF-4 files are HDF5: read slices straight from h5py (much less overhead)
            with h5py.File(self.path, "r") as f:
                dsets = {n: f[n] for n in names}
                if all(d.ndim == 1 and d.shape[0] == self.n_samples and not d.attrs.get("scale_factor")
                       for d in dsets.values()):
                    for start in range(0, self.n_samples, block):
                        yield start, {n: d[start:start + block] for n, d in dsets.items()}
                    return
        except (OSError, KeyError):
            pass
        dim = self._extra["dim"]
        with xr.open_dataset(self.path, engine="h5netcdf") as ds:
            for start in range(0, self.n_samples, block):
                sub = ds[names].isel({dim: slice(start, start + block)}).load()
                yield start, {n: sub[n].values for n in names}

    def _blocks_mdf4(self, names: list[str], block: int):
        from asammdf import MDF

        # asammdf yields each channel in the chunks of its data blocks; cut them into equal blocks
        with MDF(self.path) as mdf:
            its = {n: mdf.iter_get(n, group=self._extra["where"][n][0], index=self._extra["where"][n][1],
                                   samples_only=True) for n in names}
            buf: dict[str, list[NDArray]] = {n: [] for n in names}
            have = dict.fromkeys(names, 0)
            start = 0
            done = False
            while not done:
                for n in names:
                    while have[n] < block:
                        try:
                            samples = np.asarray(next(its[n])[0], dtype=np.float64)
                        except StopIteration:
                            done = True
                            break
                        buf[n].append(samples)
                        have[n] += samples.size
                m = min(have.values())
                if m == 0:
                    return
                take = min(m, block)
                out = {}
                for n in names:
                    joined = np.concatenate(buf[n])
                    out[n], rest = joined[:take], joined[take:]
                    buf[n], have[n] = [rest], rest.size
                yield start, out
                start += take
                if done:
                    while min(have.values()) > 0:
                        take = min(min(have.values()), block)
                        out = {}
                        for n in names:
                            joined = np.concatenate(buf[n])
                            out[n], rest = joined[:take], joined[take:]
                            buf[n], have[n] = [rest], rest.size
                        yield start, out
                        start += take

    def _blocks_uff(self, names: list[str], block: int):
        # a UFF 58 function is one record per channel: each wanted record is read block by block
        # from its place in the file (pyuff would parse a whole record, and read the whole file to
        # find the records), so memory stays bounded by the block
        records = _uff_records(self.path)
        streams = {n: _uff58_samples(self.path, records[self._extra["sets"][n]], block) for n in names}
        for start in range(0, self.n_samples, block):
            yield start, {n: next(s) for n, s in streams.items()}

    def _blocks_tdms(self, names: list[str], block: int):
        from nptdms import TdmsFile

        with TdmsFile.open(self.path) as f:
            chans = {n: f[n.split("/")[0]][n.split("/", 1)[1]] for n in names}
            for start in range(0, self.n_samples, block):
                yield start, {n: c[start:start + block] for n, c in chans.items()}


def _uff_records(path: Path, chunk: int = 1 << 22) -> list[tuple[int, int]]:
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
        Sample rate [Hz]; required for a CSV without a time column, otherwise overrides.
    scale : float, sequence or mapping, optional
        Factor per channel from file values to physical units (e.g. Pa per full scale of
        a WAV channel). Keys of a mapping are channel names (resolved like channels).
    units : mapping, optional
        Unit per channel, overriding the file's own (e.g. ``{"ch0": "Pa"}``).

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
    try:
        if suffix in (".csv", ".txt"):
            src = _open_csv(p, fs)
        elif suffix == ".wav":
            src = _open_wav(p, fs)
        elif suffix in (".nc", ".h5", ".hdf5", ".nc4"):
            src = _open_netcdf(p, fs)
        elif suffix == ".tdms":
            src = _open_tdms(p, fs)
        elif suffix in (".mf4", ".mdf"):
            src = _open_mdf4(p, fs)
        elif suffix in (".uff", ".unv"):
            src = _open_uff(p, fs)
        else:
            raise InputError(f"Recording {str(p)!r} has an unknown format; use .csv, .wav, .nc/.h5, .tdms, "
                             ".mf4 or .uff/.unv.")
    except InputError:
        raise
    except Exception as e:  # any parser failure is a user's unreadable file
        raise InputError(f"Recording {str(p)!r} could not be read as {suffix}: {type(e).__name__}: {e}") from e
    if src.n_samples < 2:
        raise InputError(f"Recording {str(p)!r} has {src.n_samples} sample(s); at least 2 are needed.")
    if not src.channels:
        raise InputError(f"Recording {str(p)!r} has no data channel.")
    unit_map = dict(src.units)
    for k, v in (units or {}).items():
        unit_map[src.resolve(k)] = str(v)
    scales = {src.resolve(k): validate_positive(f"scale of {k}", v)
              for k, v in _scales_for(src.channels, scale).items()}
    return RecordingSource(src.path, src.fmt, src.fs, src.n_samples, src.channels, unit_map, scales, src._extra)


def _open_csv(p: Path, fs: float | None) -> RecordingSource:
    import pandas as pd

    try:
        head = pd.read_csv(p, nrows=64, skipinitialspace=True)
    except pd.errors.EmptyDataError as e:
        raise InputError(f"Recording {str(p)!r} is empty.") from e
    if head.shape[0] < 2:
        raise InputError(f"Recording {str(p)!r} has fewer than 2 data rows.")
    labels = [str(c) for c in head.columns]
    parsed = [_split_unit(c) for c in labels]
    time_i = next((i for i, (n, _) in enumerate(parsed) if n.lower() in _TIME_NAMES), None)
    if time_i is None and fs is None:
        raise InputError(f"Recording {str(p)!r} has no time column (named 'time' or 't'); give the sample rate fs.")
    if time_i is not None and fs is None:
        t = pd.to_numeric(head.iloc[:, time_i], errors="coerce").to_numpy(dtype=float)
        dt = np.diff(t)
        if not np.all(np.isfinite(dt)) or np.median(dt) <= 0:
            raise InputError(f"Time column {labels[time_i]!r} of {str(p)!r} is not numeric and increasing.")
        fs = 1.0 / float(np.median(dt))
    with open(p, "rb") as fh:
        n_lines = sum(chunk.count(b"\n") for chunk in iter(lambda: fh.read(1 << 24), b""))
        fh.seek(-1, 2)
        last = fh.read(1)
    n_samples = n_lines - 1 + (0 if last == b"\n" else 1)
    channels, units, columns = [], {}, {}
    for i, (name, unit) in enumerate(parsed):
        if i == time_i:
            continue
        channels.append(name)
        units[name] = unit
        columns[name] = labels[i]
    if not channels:
        raise InputError(f"Recording {str(p)!r} has only a time column and no data channel.")
    return RecordingSource(p, "csv", float(fs), n_samples, tuple(channels), units, {}, {"columns": columns})


def _open_wav(p: Path, fs: float | None) -> RecordingSource:
    from scipy.io import wavfile

    rate, raw = wavfile.read(p, mmap=True)
    n_ch = 1 if raw.ndim == 1 else raw.shape[1]
    if np.issubdtype(raw.dtype, np.integer):
        info = np.iinfo(raw.dtype)
        full = float(-info.min) if info.min < 0 else float(info.max)
    else:
        full = 1.0
    chans = tuple(f"ch{i}" for i in range(n_ch))
    return RecordingSource(p, "wav", float(fs or rate), raw.shape[0], chans, dict.fromkeys(chans, ""), {},
                           {"full_scale": full})


def _open_netcdf(p: Path, fs: float | None) -> RecordingSource:
    import h5netcdf

    # netCDF-4 is HDF5: h5netcdf lists the variables without reading any samples (xarray would
    # load the time coordinate to index it). Data variables, as in xarray: 1-D numeric variables
    # that are neither a dimension's coordinate nor named in a "coordinates" attribute.
    with h5netcdf.File(p, "r") as f:
        variables = f.variables
        coords = set(f.dimensions)
        for v in variables.values():
            coords.update(_attr_str(v.attrs.get("coordinates", "")).split())
        names = [n for n, v in variables.items()
                 if n not in coords and v.ndim == 1 and np.issubdtype(v.dtype, np.number)]
        if not names:
            raise InputError(f"Recording {str(p)!r} has no 1-D numeric variable.")
        dim = variables[names[0]].dimensions[0]
        names = [n for n in names if variables[n].dimensions == (dim,)]
        n_samples = int(f.dimensions[dim].size)
        if fs is None:
            if "fs" in f.attrs:
                fs = validate_fs(f.attrs["fs"], "fs attribute")
            elif dim in variables and n_samples > 1:
                t = np.asarray(variables[dim][:64], dtype=float)
                fs = 1.0 / float(np.median(np.diff(t)))
            else:
                raise InputError(f"Recording {str(p)!r} has no 'fs' attribute or time coordinate; give fs.")
        units = {n: _attr_str(variables[n].attrs.get("units", "")) for n in names}
        extra = {"dim": dim, "synthetic": bool(f.attrs.get("synthetic", 0))}
        return RecordingSource(p, "netcdf", float(fs), n_samples, tuple(names), units, {}, extra)


def _attr_str(value: Any) -> str:
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


def _open_tdms(p: Path, fs: float | None) -> RecordingSource:
    from nptdms import TdmsFile

    with TdmsFile.open(p) as f:
        synthetic = bool(int(f.properties.get("synthetic", 0) or 0))
        chans, units, lengths, incs = [], {}, [], []
        for g in f.groups():
            for c in g.channels():
                name = f"{g.name}/{c.name}"
                chans.append(name)
                units[name] = str(c.properties.get("unit_string", ""))
                lengths.append(len(c))
                if "wf_increment" in c.properties:
                    incs.append(float(c.properties["wf_increment"]))
    if not chans:
        raise InputError(f"Recording {str(p)!r} has no channel.")
    if len(set(lengths)) != 1:
        raise InputError(f"Channels of {str(p)!r} have different lengths {sorted(set(lengths))}.")
    if fs is None:
        if not incs:
            raise InputError(f"Recording {str(p)!r} has no wf_increment property; give fs.")
        fs = 1.0 / validate_positive("wf_increment", incs[0])
    return RecordingSource(p, "tdms", float(fs), lengths[0], tuple(chans), units, {}, {"synthetic": synthetic})


def _open_mdf4(p: Path, fs: float | None) -> RecordingSource:
    try:
        from asammdf import MDF
    except ImportError as e:
        raise InputError("Reading MDF4 needs asammdf: pip install 'squealkit[daq]'.") from e
    with MDF(p) as mdf:
        where: dict[str, tuple[int, int]] = {}
        units: dict[str, str] = {}
        n_samples, rate = None, None
        for gi, group in enumerate(mdf.groups):
            for ci, ch in enumerate(group.channels):
                if ch.name in where or ch.name.lower() in _TIME_NAMES or ci == mdf.masters_db.get(gi):
                    continue
                sig = mdf.get(group=gi, index=ci, raw=True) if n_samples is None else None
                if sig is not None:
                    n_samples = len(sig.timestamps)
                    rate = float(np.round(1.0 / float(np.median(np.diff(sig.timestamps[:64]))), 6))
                where[ch.name] = (gi, ci)
                units[ch.name] = str(ch.unit)
        synthetic = "SYNTHETIC" in str(mdf.header.comment)
    if not where or n_samples is None:
        raise InputError(f"Recording {str(p)!r} has no channel.")
    counts = {n: int(mdf_len) for n, mdf_len in _mdf_lengths(p, where).items()}
    if len(set(counts.values())) != 1:
        raise InputError(f"Channels of {str(p)!r} have different lengths {sorted(set(counts.values()))}; "
                         "give channels of one sample rate.")
    return RecordingSource(p, "mdf4", float(fs or rate), n_samples, tuple(where), units, {},
                           {"where": where, "synthetic": synthetic})


def _mdf_lengths(p: Path, where: Mapping[str, tuple[int, int]]) -> dict[str, int]:
    from asammdf import MDF

    with MDF(p) as mdf:
        return {n: int(mdf.groups[g].channel_group.cycles_nr) for n, (g, _) in where.items()}


def _open_uff(p: Path, fs: float | None) -> RecordingSource:
    try:
        import pyuff
    except ImportError as e:
        raise InputError("Reading UFF needs pyuff: pip install 'squealkit[daq]'.") from e
    uff = pyuff.UFF(str(p))
    types = list(uff.get_set_types())
    sets: dict[str, int] = {}
    units: dict[str, str] = {}
    lengths, incs, synthetic = [], [], False
    for i, t in enumerate(types):
        if int(t) != 58:
            continue
        d = uff.read_sets(i)
        name = str(d.get("id1", "")).strip() or f"ch{len(sets)}"
        if name in sets:
            name = f"{name}_{i}"
        sets[name] = i
        units[name] = str(d.get("ordinate_axis_units_lab", "")).strip()
        lengths.append(int(d["num_pts"]))
        incs.append(float(d["abscissa_inc"]))
        synthetic |= "SYNTHETIC" in str(d.get("id2", ""))
    if not sets:
        raise InputError(f"Recording {str(p)!r} has no dataset 58 (function at nodal DOF).")
    if len(set(lengths)) != 1:
        raise InputError(f"Channels of {str(p)!r} have different lengths {sorted(set(lengths))}.")
    return RecordingSource(p, "uff", float(fs or 1.0 / validate_positive("abscissa_inc", incs[0])), lengths[0],
                           tuple(sets), units, {}, {"sets": sets, "synthetic": synthetic})


def recording_dataset(
    channels: Mapping[str, NDArray[np.float64]], fs: float, units: Mapping[str, str] | None = None,
    attrs: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """Label equally sampled channels as a Dataset with a ``time`` coordinate [s]."""
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
    """
    src = open_recording(path, **kwargs)
    names = [src.resolve(c) for c in (channels if channels is not None else src.channels)]
    parts: dict[str, list] = {n: [] for n in names}
    for _, block in src.iter_blocks(names):
        for n in names:
            parts[n].append(block[n])
    data = {n: np.concatenate(v) for n, v in parts.items()}
    return recording_dataset(data, src.fs, {n: src.units.get(n, "") for n in names}, {"source": str(src.path)})
