"""Level and components step: the A-weighted band level, the frame spectra and the tonal components of loud frames."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy import fft as sp_fft

from ..signal.spectral import P_REF, phase_advance_freq
from ..squeal.criteria import band_weighted_signal, exponential_average
from ..squeal.events import tonal_components, tone_to_noise_ratio
from .framing import _Accumulators, _Plan, _Window
from .kernels import _bin_powers, _mean_squares, _refine_rows, _time_weight_rows
from .settings import AnalysisSettings

#: Bins either side of a line's peak bin summed in the phase-advance estimate: the Hann main
#: lobe's core, which holds nearly all of a tone's energy (see phase_advance_freq).
_LOBE = 2
#: How far [Hz] outside a band edge a component's refined frequency may lie and still count as
#: in the band: the phase-advance refinement's accuracy on a steady tone (a few mHz).
_EDGE_TOL_HZ = 0.01


def _band_level(plan: _Plan, s: AnalysisSettings, win: _Window, p: NDArray, acc: _Accumulators) -> NDArray:
    """Filter step for the microphone: A-weighted band mean square on the run-out grid, and the level.

    The IEC 61672-1 time weighting runs from the previous core's state through this core and
    on into the margin (for the frames ending there); each frame's level is the maximum over
    its interval (``acc.level``, mean square), the recording's peak is kept in ``acc.laf_max``.

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    p : ndarray of float32
        The window's sound pressure [Pa].
    acc : _Accumulators
        Updated in place.

    Returns
    -------
    ndarray
        A-weighted band mean square [Pa^2] on the window's run-out grid.
    """
    dec, ci = plan.dec, win.ci
    ends = (win.w0 + win.o == 0, win.w0 + p.size == plan.total)  # the recording's own ends: continued
    pw = band_weighted_signal(p[win.o:], plan.fs, s.band, recording_ends=ends, workers=plan.n_threads)
    m_full = pw.size // dec
    ms = np.zeros(-(-(p.size - win.o) // dec))
    ms[:m_full] = _mean_squares(pw, dec)
    laf = exponential_average(ms[ci.start:], dec / plan.fs, s.criteria.time_constant_s, initial=acc.laf_state)
    if ci.stop > ci.start:
        acc.laf_state = float(laf[ci.stop - ci.start - 1])
        acc.laf_max = max(acc.laf_max, float(laf[:ci.stop - ci.start].max()))
    if win.f1 > win.f0:
        acc.level[win.f0:win.f1] = np.maximum.reduceat(laf[:win.b[-1] - ci.start], win.a - ci.start)
        # where in each frame's interval the level crosses the threshold (to one grid step, dec / fs)
        loud = laf[:win.b[-1] - ci.start] >= plan.thr_power
        j = np.arange(loud.size)
        a, b = win.a - ci.start, win.b - ci.start
        first = np.minimum.reduceat(np.where(loud, j, loud.size), a)
        last = np.maximum.reduceat(np.where(loud, j, -1), a)
        t_grid = (win.g0 + (np.arange(loud.size) + ci.start) * dec) / plan.fs
        ok = (first < b) & (last >= 0)
        acc.rise_s[win.f0:win.f1] = np.where(ok, t_grid[np.minimum(first, loud.size - 1)], np.nan)
        acc.fall_s[win.f0:win.f1] = np.where(ok, t_grid[np.maximum(last, 0)] + dec / plan.fs, np.nan)
    return ms


class _Spectra(NamedTuple):
    """Band bins of the Hann frames of one window (single precision).

    ``spec_p`` holds frames ``[fp, f1)`` (one before the core's first, for the phase advance);
    ``spec``, ``pb`` (power per bin [Pa^2]), ``pa`` (A-weighted) and ``pa_tw`` (``pa`` time
    weighted over frames) hold frames ``[f0, f1)``.
    """

    fp: int
    spec_p: NDArray[np.complex64]
    spec: NDArray[np.complex64]
    pb: NDArray[np.float32]
    pa: NDArray[np.float32]
    pa_tw: NDArray


def _frame_spectra(plan: _Plan, win: _Window, p: NDArray, acc: _Accumulators) -> _Spectra:
    """Spectral step: Hann frames of the frames starting in the core, band bins only.

    Single precision (7 digits) is enough for levels, peaks and their refinement. Writes each
    frame's A-weighted level (``leq``), strongest line (``ridge_f``) and band power
    (``e_tot``) into ``acc``, and the A-weighted spectrum time weighted like the level
    (exponential over frames, same time constant; state carried in ``acc.spec_state``).

    Parameters
    ----------
    plan : _Plan
    win : _Window
        Must hold at least one frame (``f1 > f0``).
    p : ndarray of float32
        The window's sound pressure [Pa].
    acc : _Accumulators
        Updated in place.

    Returns
    -------
    _Spectra
    """
    n, hop, w0, f0, f1 = plan.n, plan.hop, win.w0, win.f0, win.f1
    # frames [fp, f1): one before the core's first (its samples lie in the margin), so
    # every frame but the recording's first has its predecessor for the phase advance
    fp = max(f0 - 1, 0)
    seg = p[fp * hop - w0: (f1 - 1) * hop + n - w0]
    frames_ = np.lib.stride_tricks.sliding_window_view(seg, n)[::hop]
    spec_p = sp_fft.rfft(frames_ * plan.win32, axis=-1, workers=plan.n_threads)[:, plan.lo:plan.hi]
    spec = spec_p[f0 - fp:]  # frames [f0, f1)
    pb, pa = _bin_powers(spec, np.float32(plan.pscale), plan.w_a32)  # [Pa^2] per bin
    bb = plan.band_bins
    lev = pa[:, bb].sum(axis=1, dtype=np.float64)
    acc.leq[f0:f1] = 10 * np.log10(np.maximum(lev, 1e-300) / P_REF**2)
    acc.ridge_f[f0:f1] = (_refine_rows(pb, np.argmax(pa[:, bb], axis=1) + bb.start) + plan.lo) * plan.fs / n
    # a component's level is the frame's Fast level times its share of the time-weighted spectrum,
    # so each tone's level is what the meter shows, split by what the meter has heard
    pa_tw, acc.spec_state = _time_weight_rows(pa, plan.a_frames, acc.spec_state)
    # band mean square per frame (Hann frames at 50 % overlap sum to the signal energy)
    acc.e_tot[f0:f1] = pb[:, bb].sum(axis=1, dtype=np.float64)
    return _Spectra(fp, spec_p, spec, pb, pa, pa_tw)


def _rows(index: NDArray[np.intp]) -> slice | NDArray[np.intp]:
    """Row numbers as a slice where they are consecutive (a view, not a copy, of the rows they select:
    all frames of a squealing window are loud), else as they are."""
    if index.size and int(index[-1]) - int(index[0]) + 1 == index.size and bool(np.all(index[1:] > index[:-1])):
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _frame_components(plan: _Plan, s: AnalysisSettings, win: _Window, sp: _Spectra, acc: _Accumulators) -> None:
    """Tonal components of the loud frames (level at or above the threshold), with their frequencies.

    Components (and their coarse frequency) come from the time-weighted spectrum
    (:func:`~squealkit.measurement.squeal.events.tonal_components`). Each component's frequency is
    then refined from its phase advance over the main lobe (unbiased for growing and decaying
    squeal, where the two-bin ratio is not), where the tone is in the frame itself (a quarter of
    its time-weighted power), not only remembered. A component counts only when it is tonal:
    its tone-to-noise ratio in the time-weighted spectrum reaches ``s.min_tnr_db``
    (:func:`~squealkit.measurement.squeal.events.tone_to_noise_ratio`). Appends to ``acc.comp_*`` and sums the loud
    frames' spectra and cross spectra (``acc.mic_spec_sum``, ``acc.mic_cross_sum``).

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    sp : _Spectra
        The window's frame spectra.
    acc : _Accumulators
        Updated in place.
    """
    f0, f1, lo, hi, n, fs = win.f0, win.f1, plan.lo, plan.hi, plan.n, plan.fs
    loud = np.flatnonzero(acc.level[f0:f1] >= plan.thr_power)
    if not loud.size:
        return
    pa, pa_tw, pb = sp.pa, sp.pa_tw, sp.pb
    rows = _rows(loud)
    # phase advance of every band bin from the previous frame (zero for frame 0)
    prev = loud + (f0 - sp.fp - 1)
    before = np.conjugate(sp.spec_p[_rows(np.maximum(prev, 0))])
    cross = np.multiply(sp.spec[rows], before, out=before)  # X_m conj(X_m-1): one fresh array per window
    cross[prev < 0] = 0
    acc.mic_cross_sum[lo:hi] += cross.sum(axis=0, dtype=np.complex128)
    ptw = pa_tw[rows]
    # every peak of the band and its guard bins (power ``own``), then its refined frequency
    fr, ff, fl = tonal_components(ptw, ptw, lo, fs, n, -np.inf, half_width=plan.half_width)
    own = P_REF**2 * 10 ** (fl / 10)
    kc = np.clip(np.rint(ff * (n / fs)).astype(np.intp) - lo, _LOBE, hi - lo - 1 - _LOBE)
    lobe = kc[:, None] + np.arange(-_LOBE, _LOBE + 1)
    c = cross[fr[:, None], lobe].sum(axis=1, dtype=np.complex128)
    now = pa[loud[fr][:, None], lobe].sum(axis=1) >= 0.25 * pa_tw[loud[fr][:, None], lobe].sum(axis=1)
    ff_bins, ff = ff, np.where((prev[fr] >= 0) & now, phase_advance_freq(c, ff, fs, plan.hop), ff)
    # SAE J2521's band: a component counts where its frequency lies in it, edges included. The
    # level the meter shows (band-limited to the same edges) is split among the components by
    # their share of the frame's spectrum less the components outside the band (capped at 1:
    # a tone at an edge has part of its lobe in the guard bins). Edges are taken to the refined
    # frequency's accuracy on a steady tone (_EDGE_TOL_HZ).
    inside = (ff >= s.band[0] - _EDGE_TOL_HZ) & (ff <= s.band[1] + _EDGE_TOL_HZ)
    heard = ptw.sum(axis=1, dtype=np.float64) - np.bincount(fr[~inside], own[~inside], minlength=loud.size)
    share = np.minimum(own / np.maximum(heard[fr], 1e-300), 1.0)
    fl = 10 * np.log10(np.maximum(share * acc.level[f0:f1][loud[fr]], 1e-300) / P_REF**2)
    keep = inside & (fl >= s.threshold_dba)
    if s.min_tnr_db is not None and keep.any():  # tonality: a peak in broadband noise is no squeal
        # over the band's bins where the lobe lies in them, else (at an edge) with the guard bins too
        bb, sel = plan.band_bins, np.flatnonzero(keep)
        kb = kc[sel] - bb.start
        edge = (kb < _LOBE) | (kb > bb.stop - bb.start - 1 - _LOBE)
        tnr = np.empty(sel.size)
        tnr[~edge] = tone_to_noise_ratio(ptw[:, bb], fr[sel[~edge]], kb[~edge], ff_bins[sel[~edge]], fs / n,
                                         half_width=_LOBE)
        tnr[edge] = tone_to_noise_ratio(ptw, fr[sel[edge]], kc[sel[edge]], ff_bins[sel[edge]], fs / n,
                                        half_width=_LOBE)
        keep[sel] = tnr >= s.min_tnr_db
    fr, ff, fl, kc, c, lobe = fr[keep], ff[keep], fl[keep], kc[keep], c[keep], lobe[keep]
    # weights of the event's mean frequency: |c| (the cross power of the frame pair), so
    # a pair whose earlier frame is still in the noise (squeal onset) counts little
    wc = np.where(prev[fr] >= 0, np.abs(c) * plan.pscale, pb[loud[fr][:, None], lobe].sum(axis=1))
    acc.comp_frame.append(loud[fr] + f0)
    acc.comp_freq.append(ff)
    acc.comp_level.append(fl)
    acc.comp_pow.append(wc)
    acc.comp_cross.append(np.where(prev[fr] >= 0, c, 0))
    acc.mic_spec_sum[lo:hi] += pb[rows].sum(axis=0, dtype=np.float64)
