"""Squeal events by industry criteria (SAE J2521 threshold, VDA 303 several frequencies).

A frame's tonal components are the local maxima of its A-weighted power spectrum in the
criteria band (default 1-16 kHz) whose level, summed over the Hann main lobe, reaches the
threshold (default 70 dB(A), SAE J2521). Components are linked across frames by frequency,
so simultaneous squeal frequencies stay separate events (VDA 303); an event lasts at least
the minimum duration (a setting: no standard fixes one).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import maximum_filter1d

from .spectral import P_REF, refine_peak

__all__ = ["SquealEvent", "link_components", "tonal_components"]

#: Components weaker than this many dB below the frame's strongest are ignored
#: (Hann side lobes of a strong tone are at -31 dB).
_DYNAMIC_RANGE_DB = 40.0


@dataclass(frozen=True)
class SquealEvent:
    """One squeal event: a tonal component above the threshold for long enough.

    Attributes
    ----------
    start_s, end_s : float
        Start and end [s] from the start of the recording.
    frequency_hz : float
        Power-weighted mean refined frequency [Hz].
    peak_dba : float
        Highest tonal level [dB(A) re 20 uPa].
    """

    start_s: float
    end_s: float
    frequency_hz: float
    peak_dba: float

    @property
    def duration_s(self) -> float:
        """Length of the event [s]."""
        return self.end_s - self.start_s

    def to_dict(self) -> dict[str, float]:
        """Plain dict for JSON."""
        return {**asdict(self), "duration_s": self.duration_s}


def tonal_components(
    power: NDArray[np.float64], power_a: NDArray[np.float64], lo: int, fs: float, nperseg: int,
    threshold_dba: float,
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

    Returns
    -------
    frame, freq, level_dba : ndarray
        Frame index, refined frequency [Hz] and tonal level [dB(A)] of each component.
    """
    if power_a.shape[0] == 0 or power_a.shape[1] < 5:
        return np.empty(0, np.intp), np.empty(0), np.empty(0)
    thr = P_REF**2 * 10 ** (threshold_dba / 10)
    c = np.cumsum(np.pad(power_a, ((0, 0), (3, 2))), axis=1)
    lobe = c[:, 5:] - c[:, :-5]  # sum over bins k-2..k+2
    is_max = (power_a == maximum_filter1d(power_a, 5, axis=1, mode="constant")) & (lobe >= thr)
    is_max &= power_a >= power_a.max(axis=1, keepdims=True) * 10 ** (-_DYNAMIC_RANGE_DB / 10)
    is_max[:, [0, -1]] = False
    frame, k = np.nonzero(is_max)
    if frame.size:
        kk = np.clip(k, 1, power.shape[1] - 2)
        mag3 = np.sqrt(power[frame[:, None], kk[:, None] + np.array([-1, 0, 1])])
        freq = (np.atleast_1d(refine_peak(mag3, np.ones(kk.size, np.intp))) - 1 + kk + lo) * fs / nperseg
    else:
        freq = np.empty(0)
    level = 10 * np.log10(lobe[frame, k] / P_REF**2)
    return frame, freq, level


def link_components(
    frame: NDArray[np.intp], freq: NDArray[np.float64], level: NDArray[np.float64], power: NDArray[np.float64],
    frame_start_s: NDArray[np.float64], frame_len_s: float, *, freq_tol: float = 100.0, max_gap: int = 1,
    min_duration: float = 0.0,
) -> tuple[list[SquealEvent], list[NDArray[np.intp]]]:
    """Link components of successive frames into events, one per frequency track.

    A component joins the open track nearest in frequency within ``freq_tol`` [Hz]; a track
    closes after ``max_gap`` frames without a component. Returns the events (sorted by
    start) and, for each, the frames it covers.
    """
    order = np.lexsort((freq, frame))
    open_tracks: list[dict] = []
    done: list[dict] = []
    for i in order:
        fr, f = int(frame[i]), float(freq[i])
        still = []
        for tr in open_tracks:
            (done if fr - tr["last"] > max_gap + 1 else still).append(tr)
        open_tracks = still
        best, best_d = None, freq_tol
        for tr in open_tracks:
            d = abs(tr["freq"] - f)
            if d <= best_d and tr["last"] != fr:
                best, best_d = tr, d
        if best is None:
            best = {"first": fr, "last": fr, "wsum": 0.0, "fsum": 0.0, "peak": -np.inf, "frames": []}
            open_tracks.append(best)
        w = float(power[i])
        best["last"] = fr
        best["wsum"] += w
        best["fsum"] += w * f
        best["freq"] = best["fsum"] / best["wsum"] if best["wsum"] > 0 else f
        best["peak"] = max(best["peak"], float(level[i]))
        best["frames"].append(fr)
    done.extend(open_tracks)
    events, frames = [], []
    for tr in sorted(done, key=lambda t: (t["first"], t["freq"])):
        start = float(frame_start_s[tr["first"]])
        end = float(frame_start_s[tr["last"]] + frame_len_s)
        if end - start + 1e-12 < min_duration:
            continue
        events.append(SquealEvent(start, end, tr["freq"], tr["peak"]))
        frames.append(np.asarray(tr["frames"], dtype=np.intp))
    return events, frames
