"""Shared pieces of the recording readers: errors that name the file, sample checks, the time axis, units."""

from __future__ import annotations

import contextlib
import logging
import math
import re
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
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


#: Jitter of a time axis (RMS about its least-squares line, as a share of the sample interval) above which
#: reading it warns: the rounding of 7 decimals at 48 kHz is 0.14 %.
_JITTER_WARN = 0.05
#: Values at the start of a time axis whose own least-squares slope is the reference line of :class:`_TimeFit`.
_REF_SAMPLES = 1 << 12
#: How the sample rate of a recording with a time axis is found (its ``fs_method`` attribute).
FS_METHOD = "least-squares slope of the time axis against the sample index"


@nb.njit(cache=True, nogil=True)
def _line_sums(t, k0, t0, ref):  # pragma: no cover - compiled
    """Mean of ``u = t - t0 - ref k`` over a block (``k = k0, k0 + 1, ...``) and its centred sums
    ``sum (k - mean k)(u - mean u)`` and ``sum (u - mean u)^2``, in two passes without temporaries."""
    m = t.shape[0]
    s = 0.0
    for i in range(m):
        s += t[i] - t0 - ref * (k0 + i)
    ub = s / m
    kb = k0 + (m - 1) / 2.0
    sku = 0.0
    suu = 0.0
    for i in range(m):
        uc = t[i] - t0 - ref * (k0 + i) - ub
        sku += (k0 + i - kb) * uc
        suu += uc * uc
    return ub, sku, suu


class _TimeFit:
    """The least-squares line of a time axis against its sample index, fed block by block.

    A time axis rounded to a few decimals has steps that are each off by up to the rounding
    (7 decimals at 48 kHz: 2.08e-5 or 2.09e-5 s for 2.0833e-5 s); the slope of time against
    sample index over the whole axis is not. The sums are taken about a reference line (the
    first 4096 values' own fit), so they hold only the residuals' size, and merged block by
    block as centred sums (Chan, Golub and LeVeque's pairwise update): an hour at 48 kHz, or a
    clock 1000 s in, keeps the residuals of a 1e-7 s rounding to three digits whatever the blocks.
    """

    def __init__(self) -> None:
        self.n = 0
        self._t0 = self._ref = math.nan
        self._kbar = self._ubar = self._skk = self._sku = self._suu = 0.0
        self._pending: list[NDArray[np.float64]] = []

    def add(self, t: NDArray) -> None:
        """Take the next values of the axis (any block size, in order)."""
        t = np.asarray(t, dtype=np.float64).ravel()
        if self.n:
            self._merge(t)
            return
        self._pending.append(t)
        if sum(v.size for v in self._pending) >= _REF_SAMPLES:
            self._start()

    def _start(self) -> None:
        head = np.concatenate(self._pending) if self._pending else np.empty(0)
        self._pending = []
        if head.size == 0:
            return
        k = np.arange(head.size, dtype=np.float64) - (head.size - 1) / 2.0
        self._t0 = float(head[0])
        self._ref = float(np.dot(k, head - head.mean()) / np.dot(k, k)) if head.size > 1 else 0.0
        self._merge(head)

    def _merge(self, t: NDArray[np.float64]) -> None:
        m = t.size
        if m == 0:
            return
        kb = self.n + (m - 1) / 2.0
        ub, sku, suu = _line_sums(np.ascontiguousarray(t), float(self.n), self._t0, self._ref)
        n = self.n + m
        w = self.n * m / n
        dk, du = kb - self._kbar, ub - self._ubar
        self._skk += m * (m * m - 1.0) / 12.0 + dk * dk * w
        self._sku += sku + dk * du * w
        self._suu += suu + du * du * w
        self._kbar += dk * m / n
        self._ubar += du * m / n
        self.n = n

    def result(self) -> tuple[float, float]:
        """The sample interval (the slope) [s] and the RMS of the residuals about the line [s] (NaN for
        fewer than 3 values)."""
        if self._pending:
            self._start()
        if self.n < 2:
            return math.nan, math.nan
        slope = self._sku / self._skk
        rss = self._suu - slope * self._sku
        jitter = math.sqrt(max(rss, 0.0) / (self.n - 2)) if self.n > 2 else math.nan
        return self._ref + slope, jitter


def _time_base(path: Path, label: str, head: NDArray[np.float64], values: Iterable[NDArray], n: int,
               where: Callable[[int], str] = _sample_where) -> tuple[float, float]:
    """Sample rate [Hz] of a recording from its whole time axis, and the axis's jitter [s].

    Every reader with a time axis (a CSV time column, a netCDF time coordinate, MDF4 time stamps)
    takes its rate from here: the least-squares slope (:class:`_TimeFit`) of all ``n`` times
    against the sample index, read once in blocks (``values``), as 1 / slope rounded to 1e-6 Hz
    (below the slope's resolution; an exact time base gives the rate it was written with). The
    jitter is the RMS of the times about that line; above 5 % of the sample interval a warning
    says the samples are taken as uniform.

    ``head`` (the first values) is checked here: a time that goes back or is not a number is
    reported where it is. Further on, a step that is not one sample interval (of the head's median
    step) or a count other than ``n`` leaves the rate of the head's median step and a NaN jitter:
    the block reader then says where the axis goes wrong.
    """
    dt0 = _head_interval(path, label, head, where)
    fit = _TimeFit()
    last = 0.0
    for t in values:
        t = np.ascontiguousarray(t, dtype=np.float64)
        if t.size == 0:
            continue
        if not _time_steps_ok(t, last, fit.n > 0, dt0):
            return 1.0 / dt0, math.nan
        fit.add(t)
        last = float(t[-1])
    dt, jitter = fit.result()
    if fit.n != n or not (math.isfinite(dt) and dt > 0):
        return 1.0 / dt0, math.nan
    fs = float(np.round(1.0 / dt, 6))
    if jitter > _JITTER_WARN * dt:
        warnings.warn(f"Recording {str(path)!r}: its {label} has a jitter of {jitter:.3g} s RMS about a uniform "
                      f"time base, {jitter / dt:.0%} of the sample interval ({dt:.6g} s); the samples are "
                      f"taken as uniform at fs = {fs:.9g} Hz (least squares over the whole axis).",
                      UserWarning, stacklevel=5)
    return fs, jitter


def _time_extra(label: str, fs: float, jitter: float) -> dict[str, Any]:
    """What a reader keeps of a time axis: the axis to check as it is read, its jitter (``time_jitter_rms``)."""
    return {"time_axis": (label, 1.0 / fs), "time_jitter_rms": jitter}




def _head(h5: Any, variable: Any, name: str, n_samples: int, count: int = 64) -> NDArray:
    """The first ``count`` values of a 1-D netCDF variable of the root group (see :func:`_values`)."""
    return _values(h5, variable, name, n_samples, 0, count)


def _values(h5: Any, variable: Any, name: str, n_samples: int, start: int, stop: int) -> NDArray:
    """Values ``[start, stop)`` of a 1-D netCDF variable of the root group.

    Read from its HDF5 dataset (``h5``, the open file) when that holds all ``n_samples`` numbers:
    then h5netcdf returns the dataset's values as they are, and reading them through it costs
    fifteen times as much (0.8 ms). Otherwise (a dataset shorter than its dimension, padded
    with fill values; strings) through h5netcdf's ``variable``.
    """
    import h5py

    dset = h5.get(name)
    if isinstance(dset, h5py.Dataset) and dset.shape == (n_samples,) and dset.dtype.kind in "biuf":
        return dset[start:stop]
    return variable[start:stop]


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
