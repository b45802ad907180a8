"""End-to-end analysis of a rig recording: squeal, its frequency and level, and the run-out.

:func:`analyze_recording` answers the rig user's questions (paper §5.2): is there squeal,
at what frequency and level, when, and does it grow on the rising run-out? It reads the
recording in blocks (bounded memory for hour-long files), filters each block with a margin
so the zero-phase filters see no artificial edge, and keeps only compact per-frame,
per-revolution and per-angle features.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..._validation import InputError
from ..formats import RecordingSource, recording_dataset
from ..squeal.criteria import squeal_criteria
from .assemble import _assemble
from .components import _band_level, _frame_components, _frame_spectra
from .framing import _Accumulators, _disc_rotation, _open_source, _plan, _read_block, _Window, _windows
from .lines import _in_events, _squeal_events, _squeal_lines
from .result import MeasurementResult
from .runout_link import _accumulate_runout, _runout_link, _runout_signals, _runout_statistics
from .settings import AnalysisSettings, _check_pressure
from .views import measurement_signals

__all__ = ["analyze_recording"]


# -- The analysis in steps ------------------------------------------------------------------------
# analyze_recording reads the recording, fixes the framing (_plan), then streams it in windows
# (a core plus margins both sides). Each window goes through the filter step (the A-weighted band
# level, _band_level; the run-out, _runout_signals), the spectral step (_frame_spectra) and the
# tonal components (_frame_components), and leaves compact per-frame, per-revolution and per-angle
# features in the accumulators (_Accumulators). At the end the components become events
# (_squeal_events), the squeal's lines and statistics are read from them (_squeal_lines,
# _runout_statistics), each event is placed on the disc (_runout_link), and the labelled result is
# assembled (_assemble).


def analyze_recording(
    recording: str | Path | xr.Dataset | RecordingSource,
    *,
    mic: str | int,
    displacement: str | int,
    rpm: float | None = None,
    radius: float,
    tacho: str | int | None = None,
    setup: str | None = None,
    band: tuple[float, float] | None = None,
    threshold_dba: float = 70.0,
    min_duration: float = 0.01,
    time_weighting: str = "fast",
    fs: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    require_runout: bool = True,
    keep_signals: bool = False,
    **options: Any,
) -> MeasurementResult:
    """Analyse a microphone + displacement recording for squeal and its tie to run-out.

    Parameters
    ----------
    recording : path, xarray.Dataset or RecordingSource
        The recording (see :func:`squealkit.measurement.open_recording` for formats).
    mic, displacement : str or int
        Channel name or index of the calibrated microphone [Pa] and the eddy-current
        probe [m].
    rpm : float, optional
        Disc speed [rpm] (paper: 900) when there is no tacho (constant speed).
    radius : float
        Probe (and pin) radius on the disc [m].
    tacho : str or int, optional
        Tacho channel: disc angle and speed from it (:mod:`squealkit.measurement.signal.tacho`;
        options ``tacho_kind`` "pulses" or "angle", ``pulses_per_rev``, ``tacho_level``,
        ``angle_unit``), so a decelerating stop is analysed at its actual speed; revolutions
        and angles count from the first pulse.
    setup : {"component", "corner"}, optional
        SAE J2521 setup whose squeal band applies (default ``"component"``, 2-16 kHz: brakes
        not on a full corner, such as a pin-on-disc rig; ``"corner"``: 1.25-16 kHz).
    band : (float, float), optional
        A user band [Hz] instead of the setup's.
    threshold_dba : float
        Squeal threshold [dB(A)] (SAE J2521: 70).
    min_duration : float
        Shortest event [s] (no standard fixes it).
    time_weighting : {"fast", "slow"}
        IEC 61672-1 time weighting of the level (default Fast, 125 ms).
    fs : float, optional
        Sample rate [Hz] where the recording does not carry one.
    progress : callable, optional
        Called as ``progress(samples_done, samples_total)``.
    require_runout : bool, default True
        Without a disc speed (no ``rpm`` nor ``tacho``, or a tacho that cannot give one, e.g.
        fewer than 3 marks in a short low-speed drag) raise; with False analyse the squeal alone
        (SAE J2521 occurrence needs no speed) and say why in the result's
        ``runout_unavailable`` (the run-out results are then None or NaN).
    keep_signals : bool, default False
        Also return what the figures draw in ``result.signals``
        (:func:`~squealkit.measurement.analysis.views.measurement_signals`: spectrograms, run-out
        split, band-passed displacement over the whole recording); the two channels are then
        held in memory, so leave it off for recordings longer than memory allows.
    **options
        Further :class:`AnalysisSettings` fields (``lowpass_freq``, ``macro_orders``,
        ``nperseg``, ``hop``, ``freq_tol``, ``n_angle_bins``, ``chunk_s``), and the rig's
        geometry: ``probe_offset_deg`` (the probe sits this far upstream of the pin, so it sees
        the surface that much rotation before the pin), ``acoustic_delay`` [s] (pin to
        microphone) and ``polarity`` (-1: the probe reads the run-out reversed); and
        ``min_tnr_db``, the tonality a squeal component needs (tone-to-noise ratio [dB], default
        8 as ECMA-418-1 for a prominent tone; None: none).

    Returns
    -------
    MeasurementResult

    Examples
    --------
    >>> from squealkit.measurement import synthetic_recording
    >>> rec = synthetic_recording(duration=1.0, seed=1)
    >>> res = analyze_recording(rec, mic="mic", displacement="displacement", rpm=900, radius=0.05)
    >>> abs(res.squeal_frequency_hz - 2388.0) < 5 and res.rising_fraction > 0.8
    True
    """
    src, attrs = _open_source(recording, fs)
    crit = squeal_criteria(setup, band=band, threshold_dba=threshold_dba, time_weighting=time_weighting,
                           min_duration=min_duration)
    fs_ = float(src.fs)
    rotation, rpm, unavailable = _disc_rotation(src, tacho, rpm, options, required=require_runout)
    try:
        s = AnalysisSettings(rpm=rpm, radius=radius, criteria=crit, **options)
    except TypeError as e:
        raise InputError(f"Unknown analysis option: {e}") from e
    s = s.validated(fs_)
    mic_n, disp_n = src.resolve(mic), src.resolve(displacement)
    if mic_n == disp_n:
        raise InputError(f"The microphone and displacement channels are the same ({mic_n!r}).")
    plan = _plan(s, fs_, src.n_samples, rotation)
    acc = _Accumulators.empty(plan)
    block = _read_block(src, plan)
    wanted = [mic_n] if rotation is None else [mic_n, disp_n]  # no speed: the probe is not read
    for c0, c1, w0, data in _windows(src, wanted, plan.core, plan.margin, block):
        win = _Window.at(plan, c0, c1, w0)
        _check_pressure(mic_n, data[mic_n])
        p = data[mic_n].astype(np.float32)  # the band level and the frames: single precision
        ms = _band_level(plan, s, win, p, acc)
        if win.f1 > win.f0:
            _frame_components(plan, s, win, _frame_spectra(plan, win, p, acc), acc)
        if rotation is not None:
            _accumulate_runout(plan, s, win, _runout_signals(plan, s, win, data[disp_n], rotation), ms, rotation,
                               acc)
        if progress is not None:
            progress(c1, plan.total)

    events, ev_frames, ev_weights = _squeal_events(plan, s, acc)
    squeal_f: float | None = None
    harmonics: list[dict[str, float]] = []
    rising: float | None = None
    corr: float | None = None
    if events:
        in_ev = _in_events(plan.n_frames, ev_frames)
        squeal_f, harmonics = _squeal_lines(plan, acc, in_ev)
        if rotation is not None:
            rising, corr = _runout_statistics(plan, s, acc, in_ev)
    phase, events = _runout_link(plan, acc, events, ev_frames, ev_weights)
    res = _assemble(plan, s, acc, rotation, src, attrs, events=events, squeal_f=squeal_f, harmonics=harmonics,
                    rising=rising, corr=corr, phase=phase, unavailable=unavailable)
    if keep_signals:
        rec = _in_memory(recording, src, [mic_n, disp_n], attrs)
        res = replace(res, signals=measurement_signals(rec, res, mic=mic_n, displacement=disp_n))
    return res


def _in_memory(recording: Any, src: Any, names: list[str], attrs: dict[str, Any]) -> xr.Dataset:
    """The channels ``names`` of a recording as a Dataset with its ``time`` (the Dataset itself where
    it was given as one with a time coordinate; else read block by block from ``src``)."""
    if isinstance(recording, xr.Dataset) and "time" in recording.coords and "fs" in recording.attrs:
        return recording
    data: dict[str, list] = {n: [] for n in names}
    for _, blk in src.iter_blocks(names):
        for n in names:
            data[n].append(blk[n])
    units = getattr(src, "units", {})
    return recording_dataset({n: np.concatenate(v) for n, v in data.items()}, src.fs,
                             {n: units.get(n, "") for n in names}, {"synthetic": bool(attrs.get("synthetic"))})
