"""netCDF and HDF5 recordings (through xarray and h5py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._common import (
    _TIME,
    DEFAULT_BLOCK,
    _attr_str,
    _fail,
    _file_rate,
    _head,
    _head_interval,
    _library_error,
    _mapped_block,
    _sample_where,
    _stored_as_is,
    _time_base,
    _time_extra,
    _TimeFit,
    _values,
)
from .source import RecordingSource

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
                head = np.asarray(_head(h5, tv, dim, n_samples), dtype=float) * scale
                if "fs" in f.attrs:  # both: the attribute sets the rate, the coordinate must agree
                    rate = _file_rate(p, f.attrs["fs"], "fs attribute")
                    _head_interval(p, label, head, _sample_where)
                    fit = _TimeFit()
                    fit.add(head)  # (least squares: the head's steps may be rounded)
                    dt = fit.result()[0]
                    if abs(dt * rate - 1) > 1e-3:
                        raise _fail(p, f"its fs attribute ({rate:.9g} Hz) and its {label} (steps of {dt:.6g} s, "
                                       f"{1 / dt:.9g} Hz) disagree; give fs.")
                    fs = rate
                    extra.update(time_axis=(label, 1.0 / rate))
                else:
                    values = (np.asarray(_values(h5, tv, dim, n_samples, a, min(a + DEFAULT_BLOCK, n_samples)),
                                         dtype=float) * scale for a in range(0, n_samples, DEFAULT_BLOCK))
                    fs, jitter = _time_base(p, label, head, values, n_samples)
                    extra.update(_time_extra(label, fs, jitter))
                extra.update(time_scale=scale)
            elif "fs" in f.attrs:
                fs = _file_rate(p, f.attrs["fs"], "fs attribute")
            else:
                raise _fail(p, "has no 'fs' attribute or time coordinate; give fs.")
        units = {n: _attr_str(variables[n].attrs.get("units", "")) for n in names}
        return RecordingSource(p, "netcdf", float(fs), n_samples, tuple(names), units, {}, extra)


def blocks(src: RecordingSource, names: list[str], block: int, with_time: bool):
    import h5py

    dim = src._extra["dim"]
    keys = {**{n: n for n in names}, **({_TIME: dim} if with_time else {})}
    try:  # netCDF-4 files are HDF5: read slices straight from h5py (much less overhead)
        f = h5py.File(src.path, "r")
    except OSError:
        f = None
    if f is not None:
        with f:
            dsets = {k: f[v] for k, v in keys.items() if v in f}
            plain = len(dsets) == len(keys) and all(
                d.ndim == 1 and d.shape[0] == src.n_samples and not d.attrs.get("scale_factor")
                and not d.attrs.get("add_offset") for d in dsets.values())
            if plain:
                scale = src._extra.get("time_scale", 1.0)
                offsets = {k: _stored_as_is(src.path, d) for k, d in dsets.items()}
                for start in range(0, src.n_samples, block):
                    data = {}
                    stop = min(start + block, src.n_samples)
                    for k, d in dsets.items():  # a damaged chunk is named with its channel
                        try:
                            data[k] = d[start:stop] if offsets[k] is None else _mapped_block(
                                src.path, d.dtype, offsets[k], start, stop)
                        except Exception as e:
                            what = f"time coordinate {dim!r}" if k == _TIME else f"channel {k!r}"
                            raise _fail(src.path, f"{what} could not be read at samples {start}-"
                                                   f"{stop - 1}: "
                                                   f"{_library_error(e)} (a damaged or truncated file?)") from e
                    if with_time and scale != 1.0:  # (in seconds: _TimeAxis.check takes them as they are)
                        data[_TIME] = np.asarray(data[_TIME], dtype=np.float64) * scale
                    yield start, data
                return
    with xr.open_dataset(src.path, engine="h5netcdf", decode_times=False, decode_timedelta=False) as ds:
        scale = src._extra.get("time_scale", 1.0)
        for start in range(0, src.n_samples, block):
            sub = ds[[k for k in keys.values() if k in ds.data_vars]].isel({dim: slice(start, start + block)})
            data = {n: sub[n].values for n in names}
            if with_time:
                data[_TIME] = np.asarray(ds[dim][start:start + block].values, dtype=np.float64) * scale
            yield start, data
