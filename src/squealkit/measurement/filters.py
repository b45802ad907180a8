"""Zero-phase Butterworth filters as used on the rig signals (paper §5.2, Figs. 12-13).

Each filter is designed in second-order sections and applied forwards and backwards
(:func:`scipy.signal.sosfiltfilt`), so it shifts no feature in time: the squeal burst and
the run-out slope stay aligned, which the rising/falling analysis relies on.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from .._validation import InputError, validate_fs, validate_positive

__all__ = ["bandpass", "butter_sos", "highpass", "lowpass"]


def butter_sos(kind: str, freq: float | tuple[float, float], fs: float, *, order: int = 4) -> NDArray[np.float64]:
    """Butterworth design in SOS form, with the corner frequencies checked.

    Parameters
    ----------
    kind : {"lowpass", "highpass", "bandpass"}
    freq : float or (float, float)
        Corner frequency [Hz], or ``(freq_lower, freq_upper)`` for a band-pass.
    fs : float
        Sample rate [Hz].
    order : int
        Filter order (per pass; the zero-phase filter doubles the attenuation).

    Examples
    --------
    >>> butter_sos("lowpass", 1000.0, 40000.0).shape
    (2, 6)
    """
    fs = validate_fs(fs)
    if kind not in ("lowpass", "highpass", "bandpass"):
        raise InputError(f"Parameter kind={kind!r} must be 'lowpass', 'highpass' or 'bandpass'.")
    if not isinstance(order, int) or order < 1:
        raise InputError(f"Parameter order={order!r} must be a whole number >= 1.")
    nyq = fs / 2
    corners = tuple(freq) if kind == "bandpass" else (freq,)  # type: ignore[arg-type]
    if kind == "bandpass" and len(corners) != 2:
        raise InputError(f"Parameter freq={freq!r} of a band-pass needs two corners (freq_lower, freq_upper).")
    for c in corners:
        validate_positive("freq", c)
        if c >= nyq:
            raise InputError(f"Corner frequency {c!r} Hz must lie below the Nyquist frequency {nyq!r} Hz (fs={fs!r}).")
    if kind == "bandpass" and not corners[0] < corners[1]:
        raise InputError(f"Band-pass corners {freq!r} must satisfy freq_lower < freq_upper.")
    wn = corners if kind == "bandpass" else corners[0]
    return signal.butter(order, wn, btype=kind, fs=fs, output="sos")


def _apply(x: ArrayLike, sos: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=np.float64)
    n = arr.shape[axis]
    padlen = min(3 * (2 * sos.shape[0] + 1), n - 1)
    if n < 2:
        raise InputError(f"Signal of {n} sample(s) is too short to filter.")
    return signal.sosfiltfilt(sos, arr, axis=axis, padlen=padlen)


def lowpass(x: ArrayLike, freq: float, fs: float, *, order: int = 4, axis: int = -1) -> NDArray[np.float64]:
    """Zero-phase Butterworth low-pass of ``x`` at ``freq`` [Hz] (paper Fig. 12: 1000 Hz)."""
    return _apply(x, butter_sos("lowpass", freq, fs, order=order), axis)


def highpass(x: ArrayLike, freq: float, fs: float, *, order: int = 4, axis: int = -1) -> NDArray[np.float64]:
    """Zero-phase Butterworth high-pass of ``x`` at ``freq`` [Hz]."""
    return _apply(x, butter_sos("highpass", freq, fs, order=order), axis)


def bandpass(
    x: ArrayLike, freq_lower: float, freq_upper: float, fs: float, *, order: int = 4, axis: int = -1
) -> NDArray[np.float64]:
    """Zero-phase Butterworth band-pass of ``x`` (paper Fig. 13: 1000-2500 Hz)."""
    return _apply(x, butter_sos("bandpass", (freq_lower, freq_upper), fs, order=order), axis)
