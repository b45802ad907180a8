"""Shared pieces of the recording readers: errors that name the file, sample checks, the time axis, units."""

from __future__ import annotations

import contextlib
import logging
import math
import re
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from ..._validation import InputError, validate_positive

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


def _to_si(p: Path, units: dict[str, str], scales: dict[str, float]
           ) -> tuple[dict[str, str], dict[str, float], dict[str, str]]:
    """Channels' units in SI (``um`` -> ``m`` with a factor 1e-6 on the samples, ``mPa`` -> ``Pa``).

    The unit of a channel (the file's, or ``units``) says what its values (after ``scale``) are
    in; a length, pressure, velocity, acceleration, force or voltage in another unit is read in
    its SI unit, the factor joining the channel's scale. Returns the SI units, the scales, and
    each converted channel's own unit. A unit pint does not know is kept, with a warning.
    """
    from ..._units import channel_to_si

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
