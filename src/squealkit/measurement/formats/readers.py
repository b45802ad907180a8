"""Reading rig recordings: CSV, multi-channel WAV, netCDF/HDF5 (xarray), NI TDMS, ASAM MDF4, UFF 58.

A recording is a set of equally sampled channels (e.g. a microphone in Pa and an
eddy-current probe in m, paper §5.1). :func:`open_recording` inspects a file without
loading its samples and returns a :class:`RecordingSource` that yields blocks of samples
in order, so recordings of an hour or more are processed with bounded memory;
:func:`read_recording` loads everything into a labelled :class:`xarray.Dataset`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from ..._validation import InputError, validate_fs, validate_positive

__all__ = ["RecordingSource", "open_recording", "read_recording", "recording_dataset"]

from ._common import FS_METHOD, _fail, _library_error, _scales_for, _to_si
from .delimited import _open_csv
from .mdf import _open_mdf4
from .netcdf import _open_netcdf
from .source import RecordingSource
from .tdms import _open_tdms
from .uff import _open_uff
from .wav import _open_wav


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
        attrs |= {"fs_method": FS_METHOD, "time_jitter_rms": src._extra["time_jitter_rms"]}
    if "fs_from_file" in src._extra:  # the file's rate rounded to the whole Hz its stated precision allows
        attrs |= {"fs_from_file": src._extra["fs_from_file"], "fs_rounding": src._extra["fs_rounding"]}
    ds = recording_dataset(data, src.fs, {n: src.units.get(n, "") for n in names}, attrs)
    for n, unit in src._extra.get("file_units", {}).items():
        if n in ds:
            ds[n].attrs["file_units"] = unit  # the file's (or --unit's) unit, converted to units
    return ds
