"""Squeal events by industry criteria (SAE J2521 threshold, VDA 303 several frequencies).

A frame's tonal components are the local maxima of the time-weighted (Fast, 125 ms)
A-weighted power spectrum in the criteria band (SAE J2521 component setup by default:
2-16 kHz) whose level reaches the threshold (default 70 dB(A)). A component's level is the
frame's Fast band level times the component's share of that spectrum (its peak and the bins
down to the valleys either side), so one tone alone reads the level a sound level meter shows.
Components are linked across frames by frequency, so simultaneous squeal frequencies stay
separate events (VDA 303); an event lasts at least the minimum duration (a setting: no standard fixes one).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from ..signal.spectral import P_REF, refine_peak

__all__ = ["DEFAULT_MIN_TNR_DB", "SquealEvent", "critical_bandwidth", "link_components", "tonal_components",
           "tone_to_noise_ratio"]

#: Components weaker than this many dB below the frame's strongest are ignored
#: (Hann side lobes of a strong tone are at -31 dB).
_DYNAMIC_RANGE_DB = 40.0

#: Default smallest tone-to-noise ratio [dB] of a squeal component: the ECMA-418-1 (ECMA-74
#: annex D) criterion for a prominent discrete tone at or above 1 kHz.
DEFAULT_MIN_TNR_DB = 8.0


@dataclass(frozen=True)
class SquealEvent:
    """One squeal event: a tonal component above the threshold for long enough.

    Attributes
    ----------
    start_s, end_s : float
        Start and end [s] from the start of the recording. From
        :func:`~squealkit.measurement.analyze_recording`: the start is where the Fast level
        (IEC 61672-1, as the threshold is read) first reaches the threshold within the event's
        first frame, to the run-out grid's step (``dec / fs``, well under a millisecond), so it
        lags the burst's acoustic onset by the meter's rise,
        ``tau ln(1 / (1 - 10^(-(L - L_thr) / 10)))`` (4.0 ms for 85 dB(A) against 70); the end
        is where the level is last at or above the threshold within the event's last frame.
    frequency_hz : float
        Power-weighted mean refined frequency [Hz].
    peak_dba : float
        Highest tonal level [dB(A) re 20 uPa].
    runout_phase_deg : float or None
        Where on the disc this component sounds: the circular mean disc angle of its power
        minus the angle of the macro run-out's crest [deg, -180 to 180] (None when unknown).
    """

    start_s: float
    end_s: float
    frequency_hz: float
    peak_dba: float
    runout_phase_deg: float | None = None

    @property
    def duration_s(self) -> float:
        """Length of the event [s]."""
        return self.end_s - self.start_s

    def to_dict(self) -> dict[str, float]:
        """Plain dict for JSON."""
        return {**asdict(self), "duration_s": self.duration_s}


@njit(cache=True, nogil=True)
def _lobe_peaks(pa, sc, thr, dyn):  # pragma: no cover - compiled
    """:func:`tonal_components` for a Hann main lobe (half width 2), row by row, in one pass.

    The same operations in the same order (and precision) as the array version: a bin k in
    1..n-2 is a component where it is the largest of k-2..k+2 (within the band), its lobe
    (k-2..k+2) scaled reaches ``thr``, it lies within the dynamic range of its row's largest,
    and its own power (down to the valleys either side, two bins at most) scaled reaches ``thr``.
    The first test (a local maximum above the floor) is taken without branches, so the loop
    mispredicts far less on noise: twice as fast.
    """
    n_rows, n = pa.shape
    frame = np.empty(n_rows * n, np.int64)
    kk = np.empty(n_rows * n, np.int64)
    own = np.empty(n_rows * n)
    m = 0
    for r in range(n_rows):
        row = pa[r]
        floor = row.max() * dyn
        s = sc[r]
        for k in range(1, n - 1):
            c = row[k]
            if not ((c >= row[k - 1]) & (c >= row[k + 1]) & (c >= floor)):
                continue
            if k >= 2 and c < row[k - 2]:
                continue
            if k <= n - 3 and c < row[k + 2]:
                continue
            lobe = row[k]
            lobe += row[k - 1]
            if k >= 2:
                lobe += row[k - 2]
            lobe += row[k + 1]
            if k + 2 < n:
                lobe += row[k + 2]
            if not lobe * s >= thr:
                continue
            p = np.float64(c)
            for side in (1, -1):
                for d in range(1, 3):
                    j = k + side * d
                    if j < 0 or j >= n or not row[j] <= row[j - side]:
                        break
                    p += row[j]
            if p * s >= thr:
                frame[m] = r
                kk[m] = k
                own[m] = p
                m += 1
    return frame[:m], kk[:m], own[:m]


def tonal_components(
    power: NDArray[np.float64], power_a: NDArray[np.float64], lo: int, fs: float, nperseg: int,
    threshold_dba: float, *, scale: NDArray[np.float64] | None = None, half_width: int = 2,
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """Tonal components above the threshold in framed spectra.

    Parameters
    ----------
    power : ndarray, shape (n_frames, n_band)
        Power per bin of the band bins [Pa^2] (Hann frames; for frequency refinement).
    power_a : ndarray, shape (n_frames, n_band)
        A-weighted power per bin [Pa^2] of the same bins.
    lo : int
        Index of the first band bin in the full spectrum.
    fs : float
        Sample rate [Hz] of the framed signal.
    nperseg : int
        Samples per frame (the spectra's length: bin width ``fs / nperseg``).
    threshold_dba : float
        Level [dB(A)] a component must reach.
    scale : ndarray, shape (n_frames,), optional
        Factor from each frame's spectrum power to the component's level: the frame's
        time-weighted band mean square over its A-weighted band power (so a component's level
        is the Fast level times its share of the frame). Default 1 (the frame's own level).
    half_width : int
        Bins either side of a peak that belong to its component (>= 2, the Hann main lobe).
        A burst shorter than the frame spreads over about ``fs / duration`` Hz, wider than the
        main lobe of a long frame, so the analysis passes ``freq_tol / 2`` in bins; a peak
        must be the largest within its component.

    Returns
    -------
    frame, freq, level_dba : ndarray
        Frame index, refined frequency [Hz] and tonal level [dB(A)] of each component.
    """
    if power_a.shape[0] == 0 or power_a.shape[1] < 5:
        return np.empty(0, np.intp), np.empty(0), np.empty(0)
    thr = P_REF**2 * 10 ** (threshold_dba / 10)
    pa = power_a
    sc = np.ones(pa.shape[0]) if scale is None else np.asarray(scale, dtype=np.float64)
    if half_width <= 2:  # the Hann main lobe: one compiled pass over the spectra
        dyn = np.asarray(10 ** (-_DYNAMIC_RANGE_DB / 10), dtype=pa.dtype)[()]
        frame, k, own = _lobe_peaks(np.ascontiguousarray(pa), np.ascontiguousarray(sc), thr, dyn)
        return _refined(power, frame, k, own, sc, lo, fs, nperseg)
    else:
        from scipy.ndimage import maximum_filter1d

        w = 2 * half_width + 1
        cs = np.zeros((pa.shape[0], pa.shape[1] + 1), np.float64)
        np.cumsum(pa, axis=1, out=cs[:, 1:])
        i = np.arange(pa.shape[1])
        lobe = cs[:, np.minimum(i + half_width + 1, pa.shape[1])] - cs[:, np.maximum(i - half_width, 0)]
        c = pa[:, 1:-1]
        peak = maximum_filter1d(pa, w, axis=1, mode="constant", cval=0.0)[:, 1:-1]
        is_max = (c >= peak) & (lobe[:, 1:-1] * sc[:, None] >= thr)
    is_max &= c >= pa.max(axis=1, keepdims=True) * 10 ** (-_DYNAMIC_RANGE_DB / 10)
    frame, k = np.nonzero(is_max)
    k += 1
    # a component's power: its peak bin and the bins either side (up to half_width) down to the valley
    # towards a neighbouring peak, so a side peak never counts the main peak's bins as its own
    own = pa[frame, k].astype(np.float64)
    for side in (1, -1):
        going = np.ones(k.size, bool)
        for d in range(1, max(2, half_width) + 1):
            j = k + side * d
            inside = (j >= 0) & (j < pa.shape[1])
            jj = np.clip(j, 0, pa.shape[1] - 1)
            going &= inside & (pa[frame, jj] <= pa[frame, np.clip(j - side, 0, pa.shape[1] - 1)])
            own += np.where(going, pa[frame, jj], 0.0)
    keep = own * sc[frame] >= thr
    return _refined(power, frame[keep], k[keep], own[keep], sc, lo, fs, nperseg)


def _refined(power, frame, k, own, sc, lo, fs, nperseg):
    """Refined frequency [Hz] and level [dB(A)] of the components at ``(frame, k)`` of power ``own``."""
    if frame.size:
        mag3 = np.sqrt(power[frame[:, None], k[:, None] + np.array([-1, 0, 1])])
        freq = (np.atleast_1d(refine_peak(mag3, np.ones(k.size, np.intp))) - 1 + k + lo) * fs / nperseg
    else:
        freq = np.empty(0)
    level = 10 * np.log10(own * sc[frame] / P_REF**2)
    return frame, freq.astype(np.float64), level


def critical_bandwidth(freq: ArrayLike) -> NDArray[np.float64]:
    """Width [Hz] of the critical band centred on ``freq`` [Hz] (ECMA-418-1, ECMA-74 annex D).

    ``25 + 75 (1 + 1.4 (f / 1000 Hz)^2)^0.69``.

    Parameters
    ----------
    freq : array_like
        Tone frequency [Hz].

    Returns
    -------
    ndarray
        Critical bandwidth [Hz], of the shape of ``freq``.

    Examples
    --------
    >>> round(float(critical_bandwidth(1000.0)), 1)
    162.2
    """
    f = np.asarray(freq, dtype=np.float64)
    return 25.0 + 75.0 * (1.0 + 1.4 * (f / 1000.0) ** 2) ** 0.69


def tone_to_noise_ratio(
    power: NDArray, rows: NDArray[np.intp], k: NDArray[np.intp], freq: NDArray[np.float64], bin_hz: float, *,
    half_width: int = 2,
) -> NDArray[np.float64]:
    """Tone-to-noise ratio [dB] of spectral peaks (ECMA-418-1 TNR, at a frame's resolution).

    The tone's power is the power of its main lobe (bins ``k - half_width`` to
    ``k + half_width``) less the masking noise in those bins; the masking noise is the median
    power per bin of the flanking bins (up to a critical band either side of the lobe, at least
    four bins, within the spectrum), taken over the critical band of the tone
    (:func:`critical_bandwidth`). A median, not a mean, so that another tone in a flank
    does not raise the noise. White noise gives ratios well below 0 dB; ECMA-418-1 calls a tone
    at or above 1 kHz prominent from 8 dB on (:data:`DEFAULT_MIN_TNR_DB`).

    Parameters
    ----------
    power : ndarray, shape (n_rows, n_bins)
        Power per bin (e.g. Hann-windowed frames, time weighted; any consistent unit).
    rows, k : ndarray of int, shape (n_peaks,)
        Row and bin of each peak.
    freq : ndarray, shape (n_peaks,)
        Frequency [Hz] of each peak (for its critical band).
    bin_hz : float
        Bin spacing [Hz].
    half_width : int
        Bins either side of the peak in its main lobe (2: a Hann window's).

    Returns
    -------
    ndarray, shape (n_peaks,)
        ``10 log10(tone power / noise power in the critical band)``; ``-inf`` where the lobe
        holds no more than the noise.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> p = rng.exponential(1.0, (1, 100)).astype(np.float32)  # white noise: 1 per bin
    >>> p[0, 48:53] += [0.0, 25.0, 50.0, 25.0, 0.0]             # a tone of power 100 at bin 50
    >>> tnr = tone_to_noise_ratio(p, np.array([0]), np.array([50]), np.array([5000.0]), 100.0)
    >>> bool(9.5 < tnr[0] < 12.5)  # 10 log10(100 / (critical band 934 Hz x 1 per 100 Hz)) = 10.3 dB
    True
    """
    rows = np.asarray(rows, dtype=np.intp)
    k = np.asarray(k, dtype=np.intp)
    if k.size == 0:
        return np.empty(0)
    n_bins = power.shape[1]
    cb_bins = critical_bandwidth(freq) / bin_hz
    flank = max(4, int(np.ceil(float(np.max(cb_bins)))))
    d = np.arange(half_width + 1, half_width + 1 + flank)
    idx = np.concatenate([k[:, None] - d[::-1], k[:, None] + d], axis=1)
    # a flank bin counts where it lies in the spectrum and within a critical band of the lobe
    ok = (idx >= 0) & (idx < n_bins) & (np.abs(idx - k[:, None]) <= half_width + np.maximum(cb_bins, 4)[:, None])
    vals = np.sort(np.where(ok, power[rows[:, None], np.clip(idx, 0, n_bins - 1)], np.inf), axis=1)
    cnt = ok.sum(axis=1)  # the median of each row's valid values (sorted before the inf padding)
    r = np.arange(k.size)
    lo_, hi_ = np.maximum((cnt - 1) // 2, 0), np.maximum(cnt // 2, 0)
    noise = np.where(cnt > 0, 0.5 * (vals[r, lo_].astype(np.float64) + vals[r, hi_]), np.nan)
    lobe = np.clip(k[:, None] + np.arange(-half_width, half_width + 1), 0, n_bins - 1)
    p_lobe = power[rows[:, None], lobe].sum(axis=1, dtype=np.float64)
    tone = p_lobe - (2 * half_width + 1) * noise
    with np.errstate(divide="ignore", invalid="ignore"):
        tnr = 10 * np.log10(tone / (noise * cb_bins))
    return np.where((tone > 0) & np.isfinite(tnr), tnr, np.where(noise > 0, -np.inf, np.inf))


@njit(cache=True, nogil=True)
def _link_tracks(frame, freq, power, level, freq_tol, wait):  # pragma: no cover - compiled
    """Track of each component (sorted by frame, then frequency), and each track's first and last
    frame, power-weighted mean frequency and peak level. A compiled loop (the analysis' one
    per-component step; nogil, so Dask worker threads run it side by side)."""
    m = frame.size
    track = np.empty(m, np.int64)
    first = np.empty(m, np.int64)
    last = np.empty(m, np.int64)
    wsum = np.empty(m)
    fsum = np.empty(m)
    fmean = np.empty(m)
    peak = np.empty(m)
    open_ = np.empty(m, np.int64)  # open tracks in the order they opened
    n_open = 0
    n_tr = 0
    for i in range(m):
        fr = frame[i]
        f = freq[i]
        stale = False
        for j in range(n_open):
            if fr - last[open_[j]] > wait:
                stale = True
                break
        if stale:  # close the tracks that have waited too long
            kept = 0
            for j in range(n_open):
                if fr - last[open_[j]] <= wait:
                    open_[kept] = open_[j]
                    kept += 1
            n_open = kept
        best = -1
        best_d = freq_tol
        for j in range(n_open):
            t = open_[j]
            d = abs(fmean[t] - f)
            if d <= best_d and last[t] != fr:
                best = t
                best_d = d
        if best < 0:
            best = n_tr
            n_tr += 1
            first[best] = fr
            wsum[best] = 0.0
            fsum[best] = 0.0
            peak[best] = -np.inf
            open_[n_open] = best
            n_open += 1
        last[best] = fr
        wsum[best] += power[i]
        fsum[best] += power[i] * f
        fmean[best] = fsum[best] / wsum[best] if wsum[best] > 0 else f
        if level[i] > peak[best]:
            peak[best] = level[i]
        track[i] = best
    return track, first[:n_tr], last[:n_tr], fmean[:n_tr], peak[:n_tr]


def link_components(
    frame: NDArray[np.intp], freq: NDArray[np.float64], level: NDArray[np.float64], power: NDArray[np.float64],
    frame_start_s: NDArray[np.float64], frame_len_s: float, *, freq_tol: float = 100.0, max_gap: int = 1,
    min_duration: float = 0.0,
) -> tuple[list[SquealEvent], list[NDArray[np.intp]], list[NDArray[np.float64]]]:
    """Link components of successive frames into events, one per frequency track.

    A component joins the open track nearest in frequency within ``freq_tol`` [Hz]; a track
    closes after ``max_gap`` frames without a component. Returns the events (sorted by
    start) and, for each, the frames it covers (ascending) and its power in each of them.

    Parameters
    ----------
    frame : ndarray of int, shape (n,)
        Frame index of each component (as :func:`tonal_components` returns them).
    freq : ndarray, shape (n,)
        Frequency [Hz] of each component.
    level : ndarray, shape (n,)
        Level [dB(A)] of each component; an event's peak level is the highest of its track.
    power : ndarray, shape (n,)
        Power of each component (the weight of its frequency in the event's mean frequency).
    frame_start_s : ndarray, shape (n_frames,)
        Start time [s] of each frame.
    frame_len_s : float
        Length of a frame [s].
    freq_tol : float, default 100.0
        Largest frequency step [Hz] from a track to a component that joins it.
    max_gap : int, default 1
        Frames without a component after which a track closes.
    min_duration : float, default 0.0
        Events shorter than this [s] are dropped.

    Returns
    -------
    events : list of SquealEvent
        One per track, sorted by start time, then frequency.
    frames : list of ndarray of int
        The frames each event covers (ascending).
    weights : list of ndarray
        Each event's component power in each of its frames.
    """
    order = np.lexsort((freq, frame))
    fr_s = np.ascontiguousarray(frame[order], dtype=np.int64)
    w_s = np.ascontiguousarray(power[order], dtype=np.float64)
    track, first, last, f_mean, peak = _link_tracks(
        fr_s, np.ascontiguousarray(freq[order], dtype=np.float64), w_s,
        np.ascontiguousarray(level[order], dtype=np.float64), float(freq_tol), int(max_gap) + 1)
    # each track's components in the order they joined it (ascending frames)
    by_track = np.argsort(track, kind="stable")
    bounds = np.searchsorted(track[by_track], np.arange(first.size + 1))
    events, frames, weights = [], [], []
    for t in np.lexsort((f_mean, first)).tolist():  # by start, then frequency
        start = float(frame_start_s[first[t]])
        end = float(frame_start_s[last[t]] + frame_len_s)
        if end - start + 1e-12 < min_duration:
            continue
        sel = by_track[bounds[t]:bounds[t + 1]]
        events.append(SquealEvent(start, end, float(f_mean[t]), float(peak[t])))
        frames.append(fr_s[sel].astype(np.intp))
        weights.append(w_s[sel])
    return events, frames, weights
