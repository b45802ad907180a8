"""Events step: tonal components linked into events; the squeal's dominant line and harmonics."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..signal.spectral import P_REF, phase_advance_freq, refine_peak
from ..squeal.events import SquealEvent, link_components
from .components import _LOBE
from .framing import _Accumulators, _Plan
from .settings import AnalysisSettings

#: A harmonic is reported only where the loud frames' summed spectrum has a peak within a bin of
#: h f0 whose bin stands this many dB above the median of the _HARMONIC_FLANK bins either side of
#: its main lobe (a Hann line in noise: its bin holds half its power).
_HARMONIC_SNR_DB = 10.0
_HARMONIC_FLANK = 8


def _squeal_events(
    plan: _Plan, s: AnalysisSettings, acc: _Accumulators
) -> tuple[list[SquealEvent], list[NDArray[np.intp]], list[NDArray[np.float64]]]:
    """Events step: link the tonal components of successive frames into events (VDA 303 tracks).

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    acc : _Accumulators
        After the last window.

    Returns
    -------
    events, frames, weights
        As :func:`~squealkit.measurement.squeal.events.link_components`.
    """
    frame_start = np.arange(plan.n_frames) * plan.hop / plan.fs
    events, frames, weights = link_components(
        np.concatenate(acc.comp_frame), np.concatenate(acc.comp_freq), np.concatenate(acc.comp_level),
        np.concatenate(acc.comp_pow), frame_start + plan.half / plan.fs, plan.hop / plan.fs,
        freq_tol=s.freq_tol, min_duration=s.min_duration,
    )
    # within its first and last frame, an event starts where the Fast level reaches the threshold
    # and ends where it last is at or above it (to dec / fs, not the hop)
    for i, (ev, fr) in enumerate(zip(events, frames, strict=True)):
        rise, fall = acc.rise_s[fr[0]], acc.fall_s[fr[-1]]
        start = float(rise) if np.isfinite(rise) else ev.start_s
        end = float(fall) if np.isfinite(fall) and fall > start else ev.end_s
        events[i] = replace(ev, start_s=start, end_s=end)
    return events, frames, weights


def _squeal_lines(plan: _Plan, acc: _Accumulators, in_ev: NDArray[np.bool_]) -> tuple[float, list[dict[str, float]]]:
    """The dominant squeal frequency and its harmonics 2-5, from the loud frames' spectra.

    The dominant line's phase advance is taken over its own components only: the main lobe of
    another squeal line less than two bins away must not pull it (VDA 303: several
    frequencies). Each harmonic's frequency comes from the two-bin ratio, then its phase
    advance over all loud frames.

    Parameters
    ----------
    plan : _Plan
    acc : _Accumulators
        After the last window (with at least one event).
    in_ev : ndarray of bool, shape (n_frames,)
        Frames inside an event.

    Returns
    -------
    squeal_frequency_hz : float
    harmonics : list of dict
        ``order``, ``frequency_hz``, ``level_db``.
    """
    fs, n, hop, lo, hi = plan.fs, plan.n, plan.hop, plan.lo, plan.hi
    spec_sum = acc.mic_spec_sum
    comp_f, comp_c = np.concatenate(acc.comp_freq), np.concatenate(acc.comp_cross)
    mag = np.sqrt(spec_sum)
    k0 = lo + int(np.argmax(spec_sum[lo:hi] * plan.w_a))
    squeal_f = float(refine_peak(mag, k0)) * fs / n
    c_line = comp_c[np.abs(comp_f - squeal_f) < 0.5 * fs / n].sum()
    if c_line != 0:
        squeal_f = float(phase_advance_freq(c_line, squeal_f, fs, hop))
    n_loud_ev = max(int(in_ev.sum()), 1)
    harmonics: list[dict[str, float]] = []
    for h in range(2, 6):
        kh = round(h * squeal_f * n / fs)
        if kh + 3 + _HARMONIC_FLANK >= hi:
            break
        kk = kh - 2 + int(np.argmax(spec_sum[kh - 2:kh + 3]))
        # a harmonic is there only as a peak standing _HARMONIC_SNR_DB above the floor around it
        flanks = np.concatenate([spec_sum[kk - 2 - _HARMONIC_FLANK:kk - 2], spec_sum[kk + 3:kk + 3 + _HARMONIC_FLANK]])
        if not (spec_sum[kk] >= spec_sum[kk - 1] and spec_sum[kk] >= spec_sum[kk + 1]
                and spec_sum[kk] > 10 ** (_HARMONIC_SNR_DB / 10) * np.median(flanks)):
            continue
        p_h = spec_sum[kk - 2:kk + 3].sum() / n_loud_ev
        f_h = float(refine_peak(mag, kk)) * fs / n  # then its phase advance over all loud frames
        f_h = float(phase_advance_freq(acc.mic_cross_sum[kk - _LOBE:kk + _LOBE + 1].sum(), f_h, fs, hop))
        if abs(f_h - h * squeal_f) > fs / n:  # not at h f0: no harmonic of this line
            continue
        harmonics.append({"order": h, "frequency_hz": f_h,
                          "level_db": float(10 * np.log10(max(p_h, 1e-300) / P_REF**2))})
    return squeal_f, harmonics


def _in_events(n_frames: int, ev_frames: list[NDArray[np.intp]]) -> NDArray[np.bool_]:
    """Whether each frame lies between the first and last frame of some event.

    Parameters
    ----------
    n_frames : int
    ev_frames : list of ndarray
        Each event's frames (ascending).

    Returns
    -------
    ndarray of bool, shape (n_frames,)
    """
    cover = np.zeros(n_frames + 1, np.int64)  # +1 at each event's first frame, -1 after its last
    np.add.at(cover, np.array([fr[0] for fr in ev_frames]), 1)
    np.add.at(cover, np.array([fr[-1] for fr in ev_frames]) + 1, -1)
    return np.cumsum(cover[:-1]) > 0
