"""Squeal criteria as the standards write them: SAE J2521 setups, A-weighting, time weighting.

SAE J2521 calls a brake application noisy when its peak sound level reaches 70 dB(A) within
the squeal band: 1.25-16 kHz for tests on full suspension corners or axles (``"corner"``),
2-16 kHz for brakes not on a full corner (``"component"``, which a pin-on-disc rig is, and the
default here). Occurrence is the percentage of applications whose peak exceeded the threshold.
VDA 303 describes a noisy application by its separate tonal components (several frequencies,
each with its level and duration).

Levels are A-weighted (IEC 61672-1:2013, the analytic weighting of its Annex E) and time
weighted (IEC 61672-1: exponential averaging of the squared pressure with the time constant
of Fast, 125 ms, or Slow, 1 s), so a burst's level is the level a sound level meter shows and
does not depend on any analysis frame length.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import fft as sp_fft
from scipy import signal

from ..._validation import InputError, validate_finite, validate_fs, validate_positive
from ..signal.spectral import P_REF, a_weighting_db

__all__ = [
    "P_REF",
    "SETUPS",
    "TIME_CONSTANTS",
    "SquealCriteria",
    "a_weighting_db",
    "band_weighted_signal",
    "exponential_average",
    "squeal_criteria",
    "time_weighted_level",
]

#: SAE J2521 squeal bands [Hz] by test setup.
SETUPS: dict[str, tuple[float, float]] = {"corner": (1250.0, 16000.0), "component": (2000.0, 16000.0)}
#: IEC 61672-1 exponential time constants [s].
TIME_CONSTANTS: dict[str, float] = {"fast": 0.125, "slow": 1.0}
_SETUP_NAMES = {
    "corner": "SAE J2521 corner (full suspension corner or axle, 1.25-16 kHz)",
    "component": "SAE J2521 component (brake not on a full corner, e.g. pin-on-disc, 2-16 kHz)",
}
#: Width [Hz] of the raised-cosine roll-off just outside each band edge of the level's band
#: filter. The band itself passes at full A-weighted level up to its edges; a steady tone
#: EDGE_HZ or more outside the band is stopped (more than 50 dB down on a 1 s tone, the rest is
#: its own spectral leakage). The filter rings for about ``2 / EDGE_HZ`` = 0.4 s.
EDGE_HZ = 5.0
#: Order of the linear prediction that continues a recording past its ends before the band
#: filter (see :func:`band_weighted_signal`), and how many samples at each end it is fitted on.
_LP_ORDER, _LP_FIT = 32, 4096

@dataclass(frozen=True)
class SquealCriteria:
    """What counts as squeal: setup, band, threshold, weightings and minimum duration.

    Build it with :func:`squeal_criteria`, which validates it.

    Attributes
    ----------
    setup : {"corner", "component", "user"}
        SAE J2521 test setup whose band applies, or ``"user"`` for a band of one's own.
    band : (float, float)
        Squeal band ``(freq_lower, freq_upper)`` [Hz].
    threshold_dba : float
        Peak level [dB(A)] an application must reach (SAE J2521: 70).
    time_weighting : {"fast", "slow"}
        IEC 61672-1 exponential time weighting of the level.
    min_duration : float
        Shortest tonal event [s]; no standard fixes one, so it is a setting.
    """

    setup: str
    band: tuple[float, float]
    threshold_dba: float = 70.0
    time_weighting: str = "fast"
    min_duration: float = 0.01

    @property
    def time_constant_s(self) -> float:
        """Exponential time constant [s] (Fast 0.125, Slow 1)."""
        return TIME_CONSTANTS[self.time_weighting]

    @property
    def name(self) -> str:
        """The criteria's name, e.g. ``SAE J2521 component (...)``."""
        if self.setup in _SETUP_NAMES and self.band == SETUPS[self.setup]:
            return _SETUP_NAMES[self.setup]
        return f"SAE J2521 threshold on a user band ({self.band[0]:g}-{self.band[1]:g} Hz)"

    def describe(self) -> str:
        """One line naming everything that decides squeal."""
        return (f"{self.name}: L_A{self.time_weighting[0].upper()} >= {self.threshold_dba:g} dB(A) "
                f"in {self.band[0]:g}-{self.band[1]:g} Hz, {self.time_weighting.capitalize()} "
                f"({self.time_constant_s * 1000:g} ms), tonal events >= {self.min_duration * 1000:g} ms (VDA 303)")

    def to_dict(self) -> dict[str, object]:
        """Plain dict for JSON (stable keys)."""
        d = asdict(self)
        return {"name": self.name, "setup": self.setup, "band_hz": list(self.band),
                "threshold_dba": d["threshold_dba"], "frequency_weighting": "A (IEC 61672-1)",
                "time_weighting": self.time_weighting.capitalize(), "time_constant_s": self.time_constant_s,
                "min_duration_s": d["min_duration"], "description": self.describe()}


def squeal_criteria(
    setup: str | None = None, *, band: tuple[float, float] | None = None, threshold_dba: float = 70.0,
    time_weighting: str = "fast", min_duration: float = 0.01,
) -> SquealCriteria:
    """Validated squeal criteria for a J2521 setup, or a user band.

    Parameters
    ----------
    setup : {"component", "corner"}, optional
        SAE J2521 setup (default ``"component"``: brakes not on a full corner, 2-16 kHz;
        ``"corner"``: full corners or axles, 1.25-16 kHz). With ``band`` and no setup, the
        setup is ``"user"``.
    band : (float, float), optional
        Squeal band [Hz] overriding the setup's.
    threshold_dba : float
        Threshold [dB(A)] (SAE J2521: 70).
    time_weighting : {"fast", "slow"}
        IEC 61672-1 exponential time weighting (default Fast, 125 ms).
    min_duration : float
        Shortest tonal event [s].

    Returns
    -------
    SquealCriteria
        The validated criteria.

    Raises
    ------
    InputError
        On an unknown setup or time weighting, ``setup="user"`` without a band, a band that
        is not two positive increasing frequencies, or a negative ``min_duration``.

    Examples
    --------
    >>> squeal_criteria().band
    (2000.0, 16000.0)
    >>> squeal_criteria("corner").name
    'SAE J2521 corner (full suspension corner or axle, 1.25-16 kHz)'
    """
    if setup is not None and setup not in SETUPS and setup != "user":
        raise InputError(f"Parameter setup={setup!r} must be 'component' (2-16 kHz) or 'corner' (1.25-16 kHz).")
    if setup == "user" and band is None:
        raise InputError("Parameter setup='user' needs a band (freq_lower, freq_upper) in Hz.")
    if band is None:
        setup = setup or "component"
        band = SETUPS[setup]
    else:
        try:
            lo, hi = (float(b) for b in band)
        except (TypeError, ValueError) as e:
            raise InputError(f"Parameter band={band!r} must be two frequencies (freq_lower, freq_upper) in Hz.") from e
        lo, hi = validate_positive("band lower", lo), validate_positive("band upper", hi)
        if not lo < hi:
            raise InputError(f"Parameter band={band!r} must satisfy lower < upper.")
        band = (lo, hi)
        if setup is None:
            setup = next((k for k, v in SETUPS.items() if v == band), "user")
        elif band != SETUPS.get(setup):
            setup = "user"
    if time_weighting not in TIME_CONSTANTS:
        raise InputError(f"Parameter time_weighting={time_weighting!r} must be 'fast' or 'slow'.")
    validate_finite("threshold_dba", threshold_dba)
    validate_positive("min_duration", min_duration, allow_zero=True)
    return SquealCriteria(setup, (float(band[0]), float(band[1])), float(threshold_dba), time_weighting,
                          float(min_duration))


@lru_cache(maxsize=16)
def _band_gain(nfft: int, fs: float, band: tuple[float, float]) -> NDArray[np.float32]:
    """A-weighting amplitude times the band mask, on the ``rfft`` bins of ``nfft`` samples.

    The mask is 1 on ``[band[0], band[1]]`` (edges included) and falls to 0 over
    :data:`EDGE_HZ` outside each edge (raised cosine).
    """
    f = sp_fft.rfftfreq(nfft, 1 / fs)
    gain = 10 ** (a_weighting_db(f) / 20)
    gain[0] = 0.0
    outside = np.maximum(band[0] - f, f - band[1])  # [Hz] beyond the nearer edge, <= 0 inside
    mask = 0.5 + 0.5 * np.cos(np.pi * np.clip(outside / EDGE_HZ, 0.0, 1.0))
    out = (gain * mask).astype(np.float32)
    out.setflags(write=False)
    return out


def _continued(x: NDArray[np.float32], n_ext: int) -> NDArray[np.float64]:
    """``n_ext`` samples that continue ``x`` past its end by linear prediction, faded out.

    An autoregressive model of order :data:`_LP_ORDER` fitted (least squares) on the last
    :data:`_LP_FIT` samples is run on from them; its poles outside the unit circle are
    reflected in (so the continuation cannot grow), and the continuation is faded out by a
    half-Hann over its length. Tones continue with their phase, noise as noise of its
    spectrum, so cutting the recording out of a longer sound leaves no splatter.
    """
    p = _LP_ORDER
    seg = np.asarray(x[-_LP_FIT:], dtype=np.float64)
    if seg.size < 4 * p or not np.any(seg):
        return np.zeros(n_ext)
    rows = np.lib.stride_tricks.sliding_window_view(seg, p + 1)
    coef = np.linalg.lstsq(rows[:, :-1], rows[:, -1], rcond=None)[0]  # s[n] = coef @ s[n-p:n]
    a = np.concatenate([[1.0], -coef[::-1]])  # s[n] - sum_k a_k s[n-k] = 0
    z = np.roots(a)
    if np.any(np.abs(z) > 1.0):
        z = np.where(np.abs(z) > 1.0, 1.0 / np.conj(z), z)
        a = np.real(np.poly(z))
    zi = signal.lfiltic([1.0], a, seg[::-1][:p])
    ext = signal.lfilter([1.0], a, np.zeros(n_ext), zi=zi)[0]
    return ext * (0.5 + 0.5 * np.cos(np.pi * (np.arange(n_ext) + 0.5) / n_ext))


def band_weighted_signal(x: ArrayLike, fs: float, band: tuple[float, float], *,
                         recording_ends: tuple[bool, bool] = (True, True), workers: int | None = None
                         ) -> NDArray[np.float32]:
    """A-weighted signal limited to ``band`` (zero-phase, by FFT; single precision).

    The gain is the IEC 61672-1 A-weighting on the band, edges included (SAE J2521: a tone in
    the band counts at its full level), falling to zero over :data:`EDGE_HZ` outside each edge
    (raised cosine), so a steady tone 5 Hz or more outside the band does not count. Where ``x``
    starts or ends where the recording does, it is continued past that end by linear
    prediction (:func:`_continued`, faded out over ``2 / EDGE_HZ``): a recording cut out of a
    tone just outside the band would otherwise splatter into it at its ends. Beyond that the
    signal is zero-padded, so nothing wraps around.

    Parameters
    ----------
    x : array_like, shape (n,)
        Sound pressure [Pa].
    fs : float
        Sample rate [Hz].
    band : (float, float)
        ``(freq_lower, freq_upper)`` [Hz], upper below ``fs / 2``.
    recording_ends : (bool, bool)
        Whether ``x`` starts and ends where the recording does (continue it there); a block
        of a longer recording with margins either side needs no continuation.
    workers : int, optional
        FFT threads (default: squealkit's thread limit, see ``SQUEALKIT_THREADS``).

    Returns
    -------
    ndarray of float32, shape (n,)
        The A-weighted, band-limited sound pressure [Pa].
    """
    if workers is None:
        from ..._threads import thread_limit

        workers = thread_limit()
    arr = np.asarray(x, dtype=np.float32)
    n_ext = int(2.0 / EDGE_HZ * fs)
    before = _continued(arr[::-1], n_ext)[::-1] if recording_ends[0] else np.zeros(0)
    after = _continued(arr, n_ext) if recording_ends[1] else np.zeros(0)
    if before.size or after.size:
        arr = np.concatenate([before.astype(np.float32), arr, after.astype(np.float32)])
    pad = max(2048, n_ext)
    nfft = sp_fft.next_fast_len(arr.size + pad, real=True)
    spec = sp_fft.rfft(arr, nfft, workers=workers)
    spec *= _band_gain(nfft, float(fs), (float(band[0]), float(band[1])))
    return sp_fft.irfft(spec, nfft, workers=workers)[before.size: arr.size - after.size]


def exponential_average(
    x: ArrayLike, dt: float, tau: float, *, initial: float = 0.0
) -> NDArray[np.float64]:
    """Exponential time weighting of a mean-square sequence (IEC 61672-1).

    ``y_n = a y_(n-1) + (1 - a) x_n`` with ``a = exp(-dt / tau)``: exact for the response of
    ``tau dy/dt = x - y`` when ``x`` is constant over each step of ``dt`` seconds.

    Parameters
    ----------
    x : array_like, shape (n,)
        Mean square per step [unit^2].
    dt : float
        Step [s].
    tau : float
        Time constant [s] (Fast 0.125, Slow 1).
    initial : float
        ``y`` before the first step (to carry the state from one block to the next).

    Returns
    -------
    ndarray of float64, shape (n,)
        The time-weighted mean square [unit^2], one value per step.
    """
    a = math.exp(-dt / tau)
    y, _ = signal.lfilter([1.0 - a], [1.0, -a], np.asarray(x, dtype=np.float64), zi=[a * initial])
    return y


def time_weighted_level(x: ArrayLike, fs: float, criteria: SquealCriteria) -> NDArray[np.float64]:
    """Time-weighted A-weighted sound level L_AF(t) [dB(A)] in the criteria band, per sample.

    Parameters
    ----------
    x : array_like, shape (n,)
        Sound pressure [Pa] sampled at ``fs``.
    fs : float
        Sample rate [Hz]; the band's upper edge must lie below ``fs / 2``.
    criteria : SquealCriteria
        Band and time weighting (Fast or Slow), from :func:`squeal_criteria`.

    Returns
    -------
    ndarray of float64, shape (n,)
        The level [dB(A) re 20 uPa], starting from silence at the first sample.

    Examples
    --------
    >>> fs = 40000.0
    >>> t = np.arange(40000) / fs
    >>> x = np.sqrt(2) * 20e-6 * 10 ** (80 / 20) * np.sin(2 * np.pi * 1000.0 * t)  # 80 dB at 1 kHz
    >>> lev = time_weighted_level(x, fs, squeal_criteria(band=(500.0, 16000.0)))
    >>> round(float(lev[36000]), 2)  # after 0.9 s (7 time constants)
    80.0
    """
    fs = validate_fs(fs)
    if criteria.band[1] >= fs / 2:
        raise InputError(f"Band {criteria.band} Hz: upper edge must lie below fs/2 = {fs / 2:g} Hz.")
    w = band_weighted_signal(x, fs, criteria.band).astype(np.float64)
    y = exponential_average(w * w, 1.0 / fs, criteria.time_constant_s)
    with np.errstate(divide="ignore"):
        return 10 * np.log10(np.maximum(y, 1e-300) / P_REF**2)
