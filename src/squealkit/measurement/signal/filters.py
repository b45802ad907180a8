"""Zero-phase Butterworth filters as used on the rig signals (paper §5.2, Figs. 12-13).

Each filter is designed in second-order sections and applied forwards and backwards
(:func:`scipy.signal.sosfiltfilt`), so it shifts no feature in time: the squeal burst and
the run-out slope stay aligned, which the rising/falling analysis relies on.
:func:`lowpass_decimated` gives the same low-pass on every ``dec``-th sample for a fraction
of the cost (the analysis of long recordings uses it for the run-out).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import signal

from ..._validation import InputError, validate_fs, validate_int, validate_positive

__all__ = ["bandpass", "butter_sos", "highpass", "lowpass", "lowpass_decimated"]

#: Stop-band attenuation [dB] (and pass-band ripple, 1e-4) of the anti-alias FIR of
#: :func:`lowpass_decimated`.
_ANTIALIAS_DB = 80.0


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

    Returns
    -------
    ndarray, shape (n_sections, 6)
        Second-order sections for :func:`scipy.signal.sosfiltfilt`.

    Raises
    ------
    InputError
        If ``kind`` or ``order`` is invalid, or a corner is not in ``(0, fs / 2)``.

    Examples
    --------
    >>> butter_sos("lowpass", 1000.0, 40000.0).shape
    (2, 6)
    """
    fs = validate_fs(fs)
    if kind not in ("lowpass", "highpass", "bandpass"):
        raise InputError(f"Parameter kind={kind!r} must be 'lowpass', 'highpass' or 'bandpass'.")
    order = validate_int("order", order, 1)
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
    return _butter(order, wn, kind, fs).copy()


@lru_cache(maxsize=64)
def _butter(order: int, wn: float | tuple[float, ...], kind: str, fs: float) -> NDArray[np.float64]:
    # chunked analyses design the same few filters over and over
    return signal.butter(order, wn, btype=kind, fs=fs, output="sos")


def _apply(x: ArrayLike, sos: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    arr = np.asarray(x, dtype=np.float64)
    n = arr.shape[axis]
    padlen = min(3 * (2 * sos.shape[0] + 1), n - 1)
    if n < 2:
        raise InputError(f"Signal of {n} sample(s) is too short to filter.")
    return signal.sosfiltfilt(sos, arr, axis=axis, padlen=padlen)


def _decimation_stages(dec: int) -> tuple[int, ...]:
    # two stages when dec is even and >= 4 (e.g. 8 = 4 x 2): the first FIR may have a wide
    # transition band, so the two together need fewer taps than one FIR (fewer operations)
    return (dec // 2, 2) if dec >= 4 and dec % 2 == 0 else (dec,)


@lru_cache(maxsize=32)
def _decimation_design(
    freq: float, fs: float, dec: int, order: int
) -> tuple[tuple[NDArray[np.float64], ...], NDArray[np.float64]]:
    """Anti-alias FIRs (one per stage) and Butterworth SOS at ``fs / dec`` of :func:`lowpass_decimated`."""
    firs = []
    rate = fs
    for d in _decimation_stages(dec):
        f_pass, f_stop = 1.5 * freq, rate / d - 1.5 * freq
        numtaps, beta = signal.kaiserord(_ANTIALIAS_DB, (f_stop - f_pass) / (rate / 2))
        fir = signal.firwin(numtaps | 1, (f_pass + f_stop) / 2, window=("kaiser", beta), fs=rate)  # odd: linear phase
        fir.setflags(write=False)
        firs.append(fir)
        rate /= d
    return tuple(firs), butter_sos("lowpass", freq, rate, order=order)


def lowpass_decimated(
    x: ArrayLike, freq: float, fs: float, dec: int, *, order: int = 4, axis: int = -1
) -> NDArray[np.float64]:
    """Zero-phase Butterworth low-pass of ``x`` at ``freq`` [Hz], returned at ``fs / dec``.

    Stands for ``lowpass(x, freq, fs, order=order)[::dec]`` (sample ``m`` of the result
    is at sample ``m * dec`` of ``x``) at a fraction of the cost: linear-phase anti-alias
    FIRs decimate by ``dec`` (:func:`scipy.signal.resample_poly`, which removes their
    delay, so they shift nothing; odd extension at the ends as in
    :func:`scipy.signal.sosfiltfilt`), and the Butterworth low-pass then runs forwards and
    backwards at ``fs / dec``.

    Why ``freq`` keeps its meaning: each anti-alias FIR (Kaiser window, 80 dB) passes up
    to ``1.5 freq`` with a ripple below 1e-4, where the zero-phase Butterworth already
    attenuates by 19 dB (order 4); and it stops from ``rate / d - 1.5 freq`` on (``rate``
    its input rate, ``d`` its decimation), so whatever the decimation folds into
    ``[0, 1.5 freq]`` is first attenuated by 80 dB. What lies between is folded above
    ``1.5 freq`` and removed by the Butterworth, as at the full rate. The corner stays at
    ``freq`` (-6 dB after both passes); the bilinear transform's frequency warping at the
    lower rate makes the pass band a little flatter below the corner: for
    ``fs / dec = 5 freq`` the gain exceeds the full-rate filter's by < 0.02 % up to
    ``0.3 freq``, 1 % at ``0.6 freq`` and 5 % at ``0.8 freq``.

    Parameters
    ----------
    x : array_like
        Signal sampled at ``fs`` [Hz].
    freq : float
        Corner frequency [Hz] of the Butterworth low-pass (paper Fig. 12: 1000 Hz).
    fs : float
        Sample rate [Hz] of ``x``.
    dec : int
        Decimation factor, with ``fs / dec >= 4 freq``.
    order : int
        Butterworth order per pass.
    axis : int, default -1
        Axis of ``x`` along which time runs.

    Returns
    -------
    ndarray, ``ceil(n / dec)`` samples along ``axis``
        The filtered signal at ``fs / dec``.

    Examples
    --------
    >>> t = np.arange(40000) / 40000.0
    >>> x = np.sin(2 * np.pi * 15.0 * t) + 0.1 * np.sin(2 * np.pi * 5000.0 * t)
    >>> y = lowpass_decimated(x, 1000.0, 40000.0, 8)
    >>> err = np.abs(y - np.sin(2 * np.pi * 15.0 * t[::8]))
    >>> y.shape, bool(err.max() < 2e-3), bool(err[10:-10].max() < 1e-4)  # ends: odd extension
    ((5000,), True, True)
    """
    fs = validate_fs(fs)
    validate_positive("freq", freq)
    if not isinstance(dec, int | np.integer) or isinstance(dec, bool) or dec < 1:
        raise InputError(f"Parameter dec={dec!r} must be a whole number >= 1.")
    if fs / dec < 4 * freq:
        raise InputError(f"Parameter dec={dec!r}: fs / dec = {fs / dec:g} Hz must be >= 4 freq = {4 * freq:g} Hz.")
    if dec == 1:
        return lowpass(x, freq, fs, order=order, axis=axis)
    y = np.asarray(x, dtype=np.float64)
    if y.shape[axis] < 2 * dec:
        raise InputError(f"Signal of {y.shape[axis]} sample(s) is too short to decimate by {dec}.")
    firs, sos = _decimation_design(float(freq), float(fs), int(dec), order)
    for d, fir in zip(_decimation_stages(int(dec)), firs, strict=True):
        y = signal.resample_poly(y, 1, d, axis=axis, window=fir, padtype="antireflect")
    return _apply(y, sos, axis)


def lowpass(x: ArrayLike, freq: float, fs: float, *, order: int = 4, axis: int = -1) -> NDArray[np.float64]:
    """Zero-phase Butterworth low-pass of ``x`` at ``freq`` [Hz] (paper Fig. 12: 1000 Hz).

    Parameters
    ----------
    x : array_like
        Signal sampled at ``fs``, filtered along ``axis`` (at least 2 samples).
    freq : float
        Corner frequency [Hz].
    fs : float
        Sample rate [Hz] of ``x``; the corner(s) must lie below ``fs / 2``.
    order : int, default 4
        Butterworth order per pass (the zero-phase filter doubles the attenuation; the
        corner is where the gain is -6 dB after both passes).
    axis : int, default -1
        Axis of ``x`` along which time runs.

    Returns
    -------
    ndarray of float64
        The filtered signal, the shape of ``x``.
    """
    return _apply(x, butter_sos("lowpass", freq, fs, order=order), axis)


def highpass(x: ArrayLike, freq: float, fs: float, *, order: int = 4, axis: int = -1) -> NDArray[np.float64]:
    """Zero-phase Butterworth high-pass of ``x`` at ``freq`` [Hz].

    Parameters
    ----------
    x : array_like
        Signal sampled at ``fs``, filtered along ``axis`` (at least 2 samples).
    freq : float
        Corner frequency [Hz].
    fs : float
        Sample rate [Hz] of ``x``; the corner(s) must lie below ``fs / 2``.
    order : int, default 4
        Butterworth order per pass (the zero-phase filter doubles the attenuation; the
        corner is where the gain is -6 dB after both passes).
    axis : int, default -1
        Axis of ``x`` along which time runs.

    Returns
    -------
    ndarray of float64
        The filtered signal, the shape of ``x``.
    """
    return _apply(x, butter_sos("highpass", freq, fs, order=order), axis)


def bandpass(
    x: ArrayLike, freq_lower: float, freq_upper: float, fs: float, *, order: int = 4, axis: int = -1
) -> NDArray[np.float64]:
    """Zero-phase Butterworth band-pass of ``x`` (paper Fig. 13: 1000-2500 Hz).

    Parameters
    ----------
    x : array_like
        Signal sampled at ``fs``, filtered along ``axis`` (at least 2 samples).
    freq_lower, freq_upper : float
        Lower and upper corner frequencies [Hz], ``freq_lower < freq_upper``.
    fs : float
        Sample rate [Hz] of ``x``; the corner(s) must lie below ``fs / 2``.
    order : int, default 4
        Butterworth order per pass (the zero-phase filter doubles the attenuation; the
        corner is where the gain is -6 dB after both passes).
    axis : int, default -1
        Axis of ``x`` along which time runs.

    Returns
    -------
    ndarray of float64
        The filtered signal, the shape of ``x``.
    """
    return _apply(x, butter_sos("bandpass", (freq_lower, freq_upper), fs, order=order), axis)
