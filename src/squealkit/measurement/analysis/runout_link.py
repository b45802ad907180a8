"""Run-out step: the probe's run-out split and its incline, tied to the sound per frame, revolution
and angle; the rising fraction, the growth/slope correlation and each event's place on the disc."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..signal.filters import lowpass, lowpass_decimated
from ..squeal.events import SquealEvent
from .framing import _Accumulators, _Plan, _Window
from .kernels import _angle_sums, _running_sums
from .settings import AnalysisSettings


class _Runout(NamedTuple):
    """The window's run-out on its grid: SRO, macro and micro run-out [m], grid times ``t_d``
    [s], the incline under the probe and under the pin (``tan_t``, at the sound's source)."""

    sro: NDArray[np.float64]
    macro: NDArray[np.float64]
    micro: NDArray[np.float64]
    t_d: NDArray[np.float64]
    tan_probe: NDArray[np.float64]
    tan_t: NDArray[np.float64]


def _runout_signals(plan: _Plan, s: AnalysisSettings, win: _Window, q: NDArray, rotation: Any) -> _Runout:
    """Filter step for the probe: run-out on the grid, split into macro and micro, and its incline.

    The zero-phase Butterworth low-pass at ``lowpass_freq`` (paper Fig. 12) runs at
    ``fs / dec`` after linear-phase anti-alias FIRs that pass up to 1.5 ``lowpass_freq`` and
    remove, 80 dB down, whatever would fold below it; so the corner keeps its meaning
    (:func:`~squealkit.measurement.signal.filters.lowpass_decimated`). The incline is
    ``dq / (r dphi)`` (paper eq. 11 with ``v = r dphi/dt`` at the actual speed).

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    q : ndarray
        The window's probe displacement [m].
    rotation : DiscAngle or ConstantSpeed

    Returns
    -------
    _Runout
    """
    fs, dec = plan.fs, plan.dec
    sro = lowpass_decimated(q[win.o:], s.lowpass_freq, fs, dec)
    if s.polarity < 0:
        sro = -sro
    macro = lowpass(sro, plan.f_macro, plan.fs_d, order=2)
    micro = sro - macro
    t_d = (win.g0 + np.arange(sro.size) * dec) / fs
    # (a speed extrapolated past the last tacho mark of a stop is held above 1/1000 of the mean)
    rps = np.maximum(rotation.rev_per_s(t_d), 1e-3 * plan.f_rev)
    tan_probe = np.gradient(sro) * plan.fs_d / (2 * math.pi * s.radius * rps)
    # incline under the pin when the sound heard at t_d left it: emitted at t_d - acoustic_delay,
    # from the surface the probe saw probe_offset earlier in rotation
    if s.acoustic_delay or plan.off_turns:
        t_src = rotation.time_at(rotation.turns(t_d - s.acoustic_delay) - plan.off_turns)
        tan_t = np.interp(t_src, t_d, tan_probe)
    else:
        tan_t = tan_probe
    return _Runout(sro, macro, micro, t_d, tan_probe, tan_t)


def _accumulate_runout(
    plan: _Plan, s: AnalysisSettings, win: _Window, ro: _Runout, ms: NDArray, rotation: Any, acc: _Accumulators
) -> None:
    """Tie the window's sound to its run-out: per frame, per revolution and per disc angle.

    Per frame: the share of the band energy on rising run-out (``e_rise``), the mean incline
    (``slope_f``) and the disc position under the pin when its sound left it
    (``frame_turns``); per revolution: run-out extremes; per angle bin: mean run-out and
    band energy. All in ``acc``.

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    ro : _Runout
        The window's run-out.
    ms : ndarray
        A-weighted band mean square on the same grid (zero-phase: nothing shifted).
    rotation : DiscAngle or ConstantSpeed
    acc : _Accumulators
        Updated in place.
    """
    f0, f1, ci, hop, n, fs, nb = win.f0, win.f1, win.ci, plan.hop, plan.n, plan.fs, plan.nb
    cs_e, cs_r, cs_t = _running_sums(ms, ro.tan_t)
    if f1 > f0:
        a, b = win.a, win.b
        e_int = cs_e[b] - cs_e[a]
        share = np.divide(cs_r[b] - cs_r[a], e_int, out=np.full(e_int.shape, 0.5), where=e_int > 0)
        acc.e_rise[f0:f1] = acc.e_tot[f0:f1] * share
        acc.slope_f[f0:f1] = (cs_t[b] - cs_t[a]) / (b - a)
    # the probe sees disc position turns + probe offset (angle 0: the first mark, under the pin)
    turns = rotation.turns(ro.t_d[ci]) + plan.off_turns
    whole = np.floor(turns)
    rev = whole.astype(np.int64) - plan.rev0
    rev = np.clip(rev, 0, plan.n_rev - 1)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(rev)) + 1])
    r = rev[starts]  # distinct revolutions of this core; the next core may continue the last one
    for j, sig in enumerate((ro.sro[ci], ro.macro[ci], ro.micro[ci])):
        acc.rev_max[j, r] = np.maximum(acc.rev_max[j, r], np.maximum.reduceat(sig, starts))
        acc.rev_min[j, r] = np.minimum(acc.rev_min[j, r], np.minimum.reduceat(sig, starts))
    ang_q, ang_macro, ang_cnt = _angle_sums(turns, ro.sro[ci], ro.macro[ci], nb)
    acc.ang_q += ang_q
    acc.ang_macro += ang_macro
    acc.ang_cnt += ang_cnt
    acc.max_tan = max(acc.max_tan, float(np.max(np.abs(ro.tan_probe[ci]))))
    if f1 > f0:  # the disc position under the pin when the frame's sound left it
        centre = rotation.turns((np.arange(f0, f1) * hop + n / 2) / fs - s.acoustic_delay)
        # the component weights are cross powers of a frame and its predecessor: centred half a hop earlier
        acc.frame_turns[f0:f1] = rotation.turns((np.arange(f0, f1) * hop + (n - hop) / 2) / fs - s.acoustic_delay)
        fb = ((centre % 1.0) * nb).astype(np.int64) % nb
        acc.ang_e += np.bincount(fb, acc.e_tot[f0:f1], nb)
        acc.ang_ecnt += np.bincount(fb, minlength=nb)


def _runout_statistics(
    plan: _Plan, s: AnalysisSettings, acc: _Accumulators, in_ev: NDArray[np.bool_]
) -> tuple[float | None, float | None]:
    """The rising fraction and the growth/run-out-slope correlation of a recording with squeal.

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    acc : _Accumulators
        After the last window.
    in_ev : ndarray of bool, shape (n_frames,)
        Frames inside an event.

    Returns
    -------
    rising_fraction : float or None
        Share of the band energy during events on rising run-out.
    growth_slope_correlation : float or None
        Pearson correlation of the envelope's growth rate with the SRO slope over the frames
        within 20 dB of the threshold (None where either does not vary).
    """
    tot = float(acc.e_tot[in_ev].sum())
    rising = float(acc.e_rise[in_ev].sum() / tot) if tot > 0 else None
    with np.errstate(divide="ignore"):
        ln_e = np.log(np.maximum(acc.e_tot, 1e-300))
    growth = np.gradient(ln_e) * 0.5 * plan.fs / plan.hop
    sel = acc.leq >= s.threshold_dba - 20
    corr = None
    if sel.sum() > 3 and np.std(growth[sel]) > 0 and np.std(acc.slope_f[sel]) > 0:
        corr = float(np.corrcoef(growth[sel], acc.slope_f[sel])[0, 1])
    return rising, corr


def _runout_link(
    plan: _Plan, acc: _Accumulators, events: list[SquealEvent], ev_frames: list[NDArray[np.intp]],
    ev_weights: list[NDArray[np.float64]],
) -> tuple[float | None, list[SquealEvent]]:
    """Run-out link step: where on the disc the squeal sounds, relative to the macro run-out's crest.

    The squeal energy's circular mean disc angle against the macro run-out's crest (both in the
    disc's frame); each event's own place from its component's power per frame at the frame's
    disc angle.

    Parameters
    ----------
    plan : _Plan
    acc : _Accumulators
        After the last window.
    events, ev_frames, ev_weights
        As from :func:`_squeal_events`.

    Returns
    -------
    runout_phase_deg : float or None
        None without events or angle data.
    events : list of SquealEvent
        With ``runout_phase_deg`` set.
    """
    if not (events and acc.ang_ecnt.any() and acc.ang_cnt.any()):
        return None, events
    nb = plan.nb
    angle_c = (np.arange(nb) + 0.5) * 2 * math.pi / nb
    e_mean = np.divide(acc.ang_e, acc.ang_ecnt, out=np.zeros(nb), where=acc.ang_ecnt > 0)
    z = np.sum(e_mean * np.exp(1j * angle_c))
    q_mean = np.divide(acc.ang_macro, acc.ang_cnt, out=np.full(nb, -np.inf), where=acc.ang_cnt > 0)
    crest = angle_c[int(np.argmax(q_mean))]
    phase = float(np.degrees(np.angle(z * np.exp(-1j * crest))))
    rot = np.exp(-1j * crest)
    events = [replace(e, runout_phase_deg=float(np.degrees(np.angle(
                  np.sum(w * np.exp(2j * math.pi * acc.frame_turns[fr])) * rot))))
              for e, fr, w in zip(events, ev_frames, ev_weights, strict=True)]
    return phase, events
