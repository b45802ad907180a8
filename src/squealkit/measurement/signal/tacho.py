"""Disc angle and speed from a tacho or encoder, order tracking and synchronous averaging.

A dynamometer records the disc's rotation on a tacho channel: a once-per-revolution pulse,
an encoder with ``N`` pulses per revolution, or an angle channel (resolver, encoder counter).
:func:`tacho_angle` turns any of them into a :class:`DiscAngle`: the disc position in
revolutions at any time (a cubic spline through the pulse times, so the speed of a
decelerating stop is smooth), and the speed from its derivative. In the angle domain a
decelerating stop looks like a drag: :func:`angular_resample` samples a signal at equal disc
angles (order tracking), and :func:`synchronous_average` averages it revolution by revolution
(time-synchronous averaging), which keeps the run-out (locked to the disc) and averages out
whatever is not (squeal, noise).

The run-out incline needs no speed at all in the angle domain: ``tan(theta) = dq / (r dphi)``
(paper eq. 11 with ``v = r dphi/dt``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline

from ..._validation import InputError, validate_fs

#: Shortest spacing [s] of the spline knots through the tacho marks.
_KNOT_S = 0.01
#: Blocks of :func:`read_tacho` read from the source at a time: a recording mapped from a file
#: costs half as much per sample in reads of 2**21 samples as in reads of 2**18.
_BLOCKS_PER_READ = 8

__all__ = ["ConstantSpeed", "DiscAngle", "angular_resample", "pulse_times", "read_tacho", "synchronous_average",
           "tacho_angle"]


def pulse_times(x: ArrayLike, fs: float, *, level: float | None = None, t0: float = 0.0) -> NDArray[np.float64]:
    """Times [s] of the rising edges of a pulse train, interpolated between samples.

    Parameters
    ----------
    x : array_like, shape (n,)
        Tacho signal (e.g. 0/5 V TTL pulses).
    fs : float
        Sample rate [Hz].
    level : float, optional
        Trigger level (default: halfway between the signal's extremes).
    t0 : float
        Time [s] of ``x[0]`` (for blocks of a longer recording).

    Returns
    -------
    ndarray, shape (k,)
        Time [s] of each rising edge, where the signal crosses ``level`` (linear interpolation).

    Examples
    --------
    >>> x = np.r_[np.zeros(10), np.ones(5), np.zeros(10), np.ones(5)]
    >>> pulse_times(x, 1000.0)
    array([0.0095, 0.0245])
    """
    fs = validate_fs(fs)
    v = np.asarray(x, dtype=np.float64)
    if v.ndim != 1 or v.size < 2:
        raise InputError(f"A tacho signal must be 1-D with at least 2 samples, got shape {v.shape}.")
    if level is None:
        level = 0.5 * (float(v.min()) + float(v.max()))
    i = np.flatnonzero((v[:-1] < level) & (v[1:] >= level))
    frac = (level - v[i]) / (v[i + 1] - v[i])
    return t0 + (i + frac) / fs


@njit(cache=True, nogil=True)
def _rising_edges(x, before, has_before, level):  # pragma: no cover - compiled
    """Rising crossings of ``level`` in ``[before, *x]`` (without ``has_before``: in ``x`` alone),
    as :func:`pulse_times` finds them: index ``k`` of the sample before each crossing in that
    sequence, and its fraction ``(level - v[k]) / (v[k + 1] - v[k])``.

    One pass over the block, without joining ``before`` to it (a copy of the block) and without
    the temporaries of the array version.
    """
    shift = 1 if has_before else 0
    k = np.empty(x.shape[0], np.int64)
    frac = np.empty(x.shape[0])
    m = 0
    prev = before
    for i in range(x.shape[0]):
        xi = x[i]
        if (i > 0 or has_before) and prev < level and xi >= level:
            k[m] = i - 1 + shift
            frac[m] = (level - prev) / (xi - prev)
            m += 1
        prev = xi
    return k[:m], frac[:m]


@dataclass(frozen=True)
class DiscAngle:
    """Disc position against time, from a tacho (build it with :func:`tacho_angle`).

    Attributes
    ----------
    marks_s : ndarray
        Times [s] of the reference marks (pulses, or samples of an angle channel).
    marks_turns : ndarray
        Disc position [revolutions] at each mark (0 at the first once-per-revolution pulse).
    """

    marks_s: NDArray[np.float64]
    marks_turns: NDArray[np.float64]

    def __post_init__(self) -> None:
        if self.marks_s.size < 3:
            raise InputError(f"A tacho needs at least 3 marks to give angle and speed, got {self.marks_s.size}.")
        if np.any(np.diff(self.marks_s) <= 0) or np.any(np.diff(self.marks_turns) <= 0):
            raise InputError("Tacho marks must advance in time and angle (the disc turns one way).")
        # knots at least _KNOT_S apart: edge times are quantised to a sample, so the speed from marks
        # a millisecond apart (an encoder's) would carry percent-level noise
        keep = np.flatnonzero(np.diff(np.floor((self.marks_s - self.marks_s[0]) / _KNOT_S), prepend=-1) > 0)
        if keep[-1] != self.marks_s.size - 1:  # end on the last mark, a knot spacing from the one before
            if keep.size > 1 and self.marks_s[-1] - self.marks_s[keep[-1]] < 0.5 * _KNOT_S:
                keep = keep[:-1]
            keep = np.append(keep, self.marks_s.size - 1)
        ts, us = self.marks_s[keep], self.marks_turns[keep]
        if ts.size < 4:
            ts, us = self.marks_s, self.marks_turns
        object.__setattr__(self, "_spline", CubicSpline(ts, us, bc_type="not-a-knot"))
        object.__setattr__(self, "_inverse", CubicSpline(us, ts, bc_type="not-a-knot"))

    def turns(self, t: ArrayLike) -> NDArray[np.float64]:
        """Disc position [revolutions] at times ``t`` [s] (extrapolated by one spline piece at the ends).

        Parameters
        ----------
        t : array_like
            Times [s] (on the recording's clock).

        Returns
        -------
        ndarray, the shape of ``t``
            Revolutions from the reference mark.
        """
        return self._spline(np.asarray(t, dtype=np.float64))

    def rev_per_s(self, t: ArrayLike) -> NDArray[np.float64]:
        """Disc speed [rev/s] at times ``t`` [s].

        Parameters
        ----------
        t : array_like
            Times [s] (on the recording's clock).

        Returns
        -------
        ndarray, the shape of ``t``
            Speed [rev/s].
        """
        return self._spline(np.asarray(t, dtype=np.float64), 1)

    def rpm(self, t: ArrayLike) -> NDArray[np.float64]:
        """Disc speed [rpm] at times ``t`` [s].

        Parameters
        ----------
        t : array_like
            Times [s] (on the recording's clock).

        Returns
        -------
        ndarray, the shape of ``t``
            Speed [rev/min].
        """
        return 60.0 * self.rev_per_s(t)

    def rpm_at(self, t: ArrayLike) -> NDArray[np.float64]:
        """Disc speed [rpm] at times ``t`` [s] (as :meth:`rpm`).

        Parameters
        ----------
        t : array_like
            Times [s] (on the recording's clock).

        Returns
        -------
        ndarray, the shape of ``t``
            Speed [rev/min].
        """
        return self.rpm(t)

    def time_at(self, turns: ArrayLike) -> NDArray[np.float64]:
        """Times [s] at which the disc reaches positions ``turns`` [rev] (a spline through the marks reversed).

        Parameters
        ----------
        turns : array_like
            Disc positions [rev] from the reference mark.

        Returns
        -------
        ndarray, the shape of ``turns``
            Times [s].
        """
        return self._inverse(np.asarray(turns, dtype=np.float64))


def tacho_angle(
    x: ArrayLike, fs: float, *, kind: str = "pulses", pulses_per_rev: int = 1, level: float | None = None,
    angle_unit: str = "deg",
) -> DiscAngle:
    """Disc angle and speed from a tacho or encoder channel.

    Parameters
    ----------
    x : array_like, shape (n,)
        The tacho channel.
    fs : float
        Sample rate [Hz].
    kind : {"pulses", "angle"}
        ``"pulses"``: a pulse train, ``pulses_per_rev`` rising edges per revolution (1: a
        once-per-revolution mark, whose first edge is angle 0). ``"angle"``: an angle channel,
        wrapping or not, in ``angle_unit``.
    pulses_per_rev : int
        Pulses per revolution of a pulse train (encoder teeth).
    level : float, optional
        Trigger level of a pulse train (default: halfway between its extremes).
    angle_unit : {"deg", "rad", "rev"}
        Unit of an angle channel.

    Returns
    -------
    DiscAngle

    Examples
    --------
    >>> fs = 10000.0
    >>> t = np.arange(20000) / fs
    >>> turns = 15.0 * t - 2.5 * t**2                 # 900 rpm slowing down at 300 rpm/s
    >>> x = ((turns % 1.0) < 0.05).astype(float) * 5.0
    >>> ang = tacho_angle(x, fs)
    >>> round(float(ang.rpm(1.0)))  # edges to a sample (0.1 ms): 600.2 rpm
    600
    """
    fs = validate_fs(fs)
    v = np.asarray(x, dtype=np.float64)
    if kind == "pulses":
        if not isinstance(pulses_per_rev, int | np.integer) or pulses_per_rev < 1:
            raise InputError(f"Parameter pulses_per_rev={pulses_per_rev!r} must be a whole number >= 1.")
        tp = pulse_times(v, fs, level=level)
        return DiscAngle(tp, np.arange(tp.size) / float(pulses_per_rev))
    if kind == "angle":
        per_rev = {"deg": 360.0, "rad": 2 * np.pi, "rev": 1.0}
        if angle_unit not in per_rev:
            raise InputError(f"Parameter angle_unit={angle_unit!r} must be 'deg', 'rad' or 'rev'.")
        turns = np.unwrap(v / per_rev[angle_unit], period=1.0)
        step = max(1, int(fs / 2000))  # marks every 0.5 ms are plenty for a spline
        idx = np.arange(0, v.size, step)
        turns = turns[idx]
        if turns[-1] < turns[0]:
            raise InputError("The angle channel decreases: give the disc's angle in its sense of rotation.")
        return DiscAngle(idx / fs, turns - turns[0])
    raise InputError(f"Parameter kind={kind!r} must be 'pulses' or 'angle'.")


def angular_resample(
    x: ArrayLike, fs: float, angle: DiscAngle, *, samples_per_rev: int, t0: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Order tracking: ``x`` sampled at equal disc angles (linear interpolation in time).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal sampled at ``fs``; ``x[0]`` at time ``t0``.
    fs : float
        Sample rate [Hz] of ``x``.
    angle : DiscAngle
        Disc position against time (from :func:`tacho_angle`, or a :class:`ConstantSpeed`).
    samples_per_rev : int
        Angular samples per revolution, >= 4; orders up to ``samples_per_rev / 2`` are kept (low-pass
        ``x`` below ``samples_per_rev / 2`` times the lowest speed first, or they fold).
    t0 : float, default 0.0
        Time [s] of ``x[0]`` on the clock of ``angle``.

    Returns
    -------
    turns : ndarray
        Disc positions [rev] of the samples: whole multiples of ``1 / samples_per_rev`` within the
        recording.
    xa : ndarray
        The signal at those positions.
    """
    fs = validate_fs(fs)
    v = np.asarray(x, dtype=np.float64)
    if not isinstance(samples_per_rev, int | np.integer) or samples_per_rev < 4:
        raise InputError(f"Parameter samples_per_rev={samples_per_rev!r} must be a whole number >= 4.")
    t = t0 + np.arange(v.size) / fs
    u = angle.turns(t[[0, -1]])
    grid = np.arange(np.ceil(u[0] * samples_per_rev), np.floor(u[1] * samples_per_rev) + 1) / samples_per_rev
    return grid, np.interp(angle.time_at(grid), t, v)


def synchronous_average(
    x: ArrayLike, fs: float, angle: DiscAngle, *, samples_per_rev: int = 1024, t0: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Time-synchronous average of ``x`` over whole revolutions (run-out per revolution).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal sampled at ``fs`` (e.g. the displacement [m]).
    fs : float
        Sample rate [Hz].
    angle : DiscAngle
        Disc position against time (from :func:`tacho_angle`, or a :class:`ConstantSpeed`).
    samples_per_rev : int, default 1024
        Angular samples per revolution (see :func:`angular_resample`).
    t0 : float, default 0.0
        Time [s] of ``x[0]`` on the clock of ``angle``.

    Returns
    -------
    phase : ndarray, shape (samples_per_rev,)
        Disc angle [rev, 0-1) from the reference mark.
    mean : ndarray, shape (samples_per_rev,)
        The average over revolutions (what is locked to the disc: its run-out).
    per_rev : ndarray, shape (n_revolutions, samples_per_rev)
        Each whole revolution in the angle domain (``per_rev.ptp(axis=1)``: run-out
        peak-to-peak per revolution).
    revolutions : ndarray of int64, shape (n_revolutions,)
        The revolution number of each row of ``per_rev`` (counted from the reference mark).

    Raises
    ------
    InputError
        If the recording holds no whole revolution.

    Examples
    --------
    >>> fs = 20000.0
    >>> t = np.arange(40000) / fs
    >>> turns = 15.0 * t - 2.5 * t**2
    >>> ang = tacho_angle(((turns % 1.0) < 0.05) * 5.0, fs)
    >>> q = 1e-5 * np.sin(2 * np.pi * turns) + 1e-6 * np.random.default_rng(0).standard_normal(t.size)
    >>> phase, mean, per_rev, revs = synchronous_average(q, fs, ang, samples_per_rev=256)
    >>> bool(np.max(np.abs(mean - 1e-5 * np.sin(2 * np.pi * phase))) < 1e-6)
    True
    """
    grid, xa = angular_resample(x, fs, angle, samples_per_rev=samples_per_rev, t0=t0)
    first = int(np.ceil(grid[0] - 1e-9))
    start = round((first - grid[0]) * samples_per_rev)
    n_rev = (grid.size - start) // samples_per_rev
    if n_rev < 1:
        raise InputError("The recording holds no whole revolution to average.")
    per_rev = xa[start:start + n_rev * samples_per_rev].reshape(n_rev, samples_per_rev)
    phase = np.arange(samples_per_rev) / samples_per_rev
    return phase, per_rev.mean(axis=0), per_rev, np.arange(first, first + n_rev, dtype=np.int64)


@dataclass(frozen=True)
class ConstantSpeed:
    """A disc turning at constant speed (no tacho): same interface as :class:`DiscAngle`.

    Attributes
    ----------
    rpm : float
        Disc speed [rev/min].
    """

    rpm: float

    def turns(self, t: ArrayLike) -> NDArray[np.float64]:
        """Disc position [rev] at times ``t`` [s] (0 at t = 0)."""
        return np.asarray(t, dtype=np.float64) * (self.rpm / 60.0)

    def rev_per_s(self, t: ArrayLike) -> NDArray[np.float64]:
        """Disc speed [rev/s]."""
        return np.full(np.shape(t), self.rpm / 60.0)

    def rpm_at(self, t: ArrayLike) -> NDArray[np.float64]:
        return 60.0 * self.rev_per_s(t)

    def time_at(self, turns: ArrayLike) -> NDArray[np.float64]:
        """Times [s] at which the disc reaches positions ``turns`` [rev]."""
        return np.asarray(turns, dtype=np.float64) / (self.rpm / 60.0)


def read_tacho(source, channel: str | int, *, kind: str = "pulses", pulses_per_rev: int = 1,
               level: float | None = None, angle_unit: str = "deg", block: int = 1 << 18) -> DiscAngle:
    """:func:`tacho_angle` of one channel of a recording read block by block (bounded memory).

    ``source`` has the block interface of :class:`~squealkit.measurement.formats.readers.RecordingSource`.
    A pulse train's trigger level defaults to halfway between the first block's extremes. The
    channel is read ``_BLOCKS_PER_READ`` blocks at a time and taken block by block.

    Parameters
    ----------
    source : RecordingSource
        An open recording (:func:`~squealkit.measurement.open_recording`).
    channel : str or int
        The tacho channel, by name or position.
    kind : {"pulses", "angle"}
        ``"pulses"``: a pulse train, ``pulses_per_rev`` rising edges per revolution (1: a
        once-per-revolution mark, whose first edge is angle 0). ``"angle"``: an angle channel,
        wrapping or not, in ``angle_unit``.
    pulses_per_rev : int
        Pulses per revolution of a pulse train (encoder teeth).
    level : float, optional
        Trigger level of a pulse train (default: halfway between the first block's extremes).
    angle_unit : {"deg", "rad", "rev"}
        Unit of an angle channel.
    block : int
        Samples per block read.

    Returns
    -------
    DiscAngle
        The disc angle over time, as :func:`tacho_angle` returns it.
    """
    name = source.resolve(channel)
    fs = float(source.fs)
    if kind not in ("pulses", "angle"):
        raise InputError(f"Parameter kind={kind!r} must be 'pulses' or 'angle'.")
    if kind == "pulses" and (not isinstance(pulses_per_rev, int | np.integer) or pulses_per_rev < 1):
        raise InputError(f"Parameter pulses_per_rev={pulses_per_rev!r} must be a whole number >= 1.")
    per_rev = {"deg": 360.0, "rad": 2 * np.pi, "rev": 1.0}
    if kind == "angle" and angle_unit not in per_rev:
        raise InputError(f"Parameter angle_unit={angle_unit!r} must be 'deg', 'rad' or 'rev'.")
    times: list[NDArray[np.float64]] = []
    marks: list[NDArray[np.float64]] = []
    last: float | None = None  # the sample before this block (edges across blocks)
    step = max(1, int(fs / 2000))
    for start, x in _tacho_blocks(source, name, block):
        if kind == "pulses":
            if level is None:
                lo_, hi_ = float(x.min()), float(x.max())
                if hi_ <= lo_:
                    raise InputError(f"Tacho channel {name!r} is constant in its first block; give the trigger level.")
                level = 0.5 * (lo_ + hi_)
            t0 = start / fs if last is None else (start - 1) / fs
            k, frac = _rising_edges(x, 0.0 if last is None else last, last is not None, float(level))
            times.append(t0 + (k + frac) / fs)  # as pulse_times of the block after the sample before it
            last = float(x[-1])
        else:
            idx = np.arange((-start) % step, x.size, step)
            times.append((start + idx) / fs)
            marks.append(x[idx] / per_rev[angle_unit])
    t = np.concatenate(times) if times else np.empty(0)
    if kind == "pulses":
        return DiscAngle(t, np.arange(t.size) / float(pulses_per_rev))
    turns = np.unwrap(np.concatenate(marks), period=1.0)
    if turns.size and turns[-1] < turns[0]:
        raise InputError("The angle channel decreases: give the disc's angle in its sense of rotation.")
    return DiscAngle(t, turns - turns[0])


def _tacho_blocks(source, name: str, block: int) -> Iterator[tuple[int, NDArray[np.float64]]]:
    """``(start_sample, samples)`` of channel ``name`` in blocks of ``block`` samples (the last one
    shorter), read from ``source`` ``_BLOCKS_PER_READ`` blocks at a time."""
    for start, blk in source.iter_blocks([name], block=block * _BLOCKS_PER_READ):
        x = np.asarray(blk[name], dtype=np.float64)
        for offset in range(0, x.size, block):
            yield start + offset, x[offset:offset + block]
