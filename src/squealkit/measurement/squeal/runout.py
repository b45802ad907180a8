"""Disc surface run-out (SRO) from the eddy-current displacement channel (paper §5.2, eq. 11).

The displacement is low-passed (Butterworth, 1000 Hz in the paper, Fig. 12) to keep the
surface shape; its low revolution orders are the macro run-out, the rest the micro run-out.
The incline of the surface under the pin is ``tan(theta) = (dq/dt) / v`` with the sliding
speed ``v = 2 pi r n / 60`` at probe radius ``r`` and disc speed ``n`` [rpm]; the SRO is
*rising* where ``tan(theta) > 0``, where the paper observes the squeal to grow.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validation import InputError, validate_fs, validate_int, validate_positive
from ..signal.filters import lowpass

__all__ = ["incline", "revolution_frequency", "split_runout", "surface_speed"]


def revolution_frequency(rpm: float) -> float:
    """Disc revolutions per second [Hz] for a speed in rpm (900 rpm -> 15 Hz).

    Parameters
    ----------
    rpm : float
        Disc speed [rev/min], > 0.

    Returns
    -------
    float
        ``rpm / 60`` [Hz].
    """
    return validate_positive("rpm", rpm) / 60.0


def surface_speed(rpm: float, radius: float) -> float:
    """Sliding speed ``v = 2 pi r n / 60`` [m/s] at probe radius ``radius`` [m].

    Parameters
    ----------
    rpm : float
        Disc speed ``n`` [rev/min], > 0.
    radius : float
        Radius ``r`` of the sliding track [m], > 0.

    Returns
    -------
    float
        The sliding speed [m/s].

    Examples
    --------
    >>> round(surface_speed(900.0, 0.1), 4)
    9.4248
    """
    return 2.0 * math.pi * validate_positive("radius", radius) * validate_positive("rpm", rpm) / 60.0


def split_runout(
    q: ArrayLike, fs: float, rpm: float, *, lowpass_freq: float = 1000.0, macro_orders: int = 10
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Split a displacement signal into surface run-out, macro and micro parts (paper Fig. 12).

    Parameters
    ----------
    q : array_like, shape (n,)
        Disc surface displacement [m].
    fs : float
        Sample rate [Hz].
    rpm : float
        Disc speed [rpm].
    lowpass_freq : float
        Corner of the zero-phase Butterworth low-pass that keeps the surface [Hz].
    macro_orders : int
        Highest revolution order counted as macro run-out; the low-pass that separates
        macro from micro has its corner at ``(macro_orders + 0.5)`` revolution orders.

    Returns
    -------
    sro, macro, micro : ndarray, shape (n,)
        ``sro = macro + micro`` [m].
    """
    fs = validate_fs(fs)
    macro_orders = validate_int("macro_orders", macro_orders, 1)
    sro = lowpass(q, lowpass_freq, fs)
    f_macro = (macro_orders + 0.5) * revolution_frequency(rpm)
    if f_macro >= lowpass_freq:
        raise InputError(
            f"macro_orders={macro_orders} at {rpm} rpm puts the macro corner ({f_macro:g} Hz) above "
            f"lowpass_freq={lowpass_freq:g} Hz."
        )
    macro = lowpass(sro, f_macro, fs, order=2)
    return sro, macro, sro - macro


def incline(sro: ArrayLike, fs: float, rpm: float, radius: float) -> NDArray[np.float64]:
    """Run-out slope ``tan(theta) = (dq/dt) / v`` along the sliding direction (paper eq. 11).

    Parameters
    ----------
    sro : array_like, shape (n,)
        Surface run-out ``q`` [m] sampled at ``fs`` (e.g. the first output of :func:`split_runout`).
    fs : float
        Sample rate [Hz].
    rpm : float
        Disc speed [rev/min].
    radius : float
        Radius of the sliding track [m].

    Returns
    -------
    ndarray, shape (n,)
        ``tan(theta)`` [1] (dimensionless; ``arctan`` gives theta in rad), positive where the
        surface rises under the pin. ``dq/dt`` is the central difference of :func:`numpy.gradient`.
    """
    return np.gradient(np.asarray(sro, dtype=np.float64)) * validate_fs(fs) / surface_speed(rpm, radius)
