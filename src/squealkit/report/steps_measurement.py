"""Report step for the paper's §5: a SYNTHETIC rig recording analysed as the paper analyses its own."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..io import save_dataset
from ..measurement import analyze_recording, synthetic_recording
from ..models import FrictionModel
from ..stability import critical_friction
from .document import Comparison, FigureRef, Section, Table
from .steps_stability import _save_fig

# Paper §5: 900 rpm, 10 N, 40 kHz sampling; squeal main frequency about 2388 Hz, once per disc turn on the
# rising SRO. The probe radius is not given; 50 mm is assumed.
RPM, FS, RADIUS, F_PUBLISHED = 900.0, 40_000.0, 0.05, 2388.0

_CAPTIONS = {
    "time": "Figs. 6-7: sound pressure and disc surface displacement",
    "spectrogram": "Figs. 8-9: spectrograms of both channels, with the squeal ridge",
    "zoom": "Figs. 10-11: the 0.1-0.3 s zoom over three revolutions",
    "runout": "Fig. 12: low-pass (1000 Hz) run-out, split into macro and micro run-out",
    "band": "Fig. 13: 1000-2500 Hz band of the displacement against the sound pressure",
    "level": "A-weighted squeal level with the detected events (SAE J2521 threshold)",
    "polar": "Squeal level against disc angle with the run-out, over the revolutions",
}


def _save_measurement_figures(figs: dict, figures: Path, prefix: str) -> tuple[FigureRef, ...]:
    """Save the §5 figures (PNG and SVG) as ``sec5_NN_name`` and return their references."""
    refs = []
    for i, (name, fig) in enumerate(figs.items()):
        stem = f"sec5_{i:02d}_{name}"
        _save_fig(fig, figures, stem)
        refs.append(FigureRef(stem, prefix + _CAPTIONS.get(name, name.replace("_", " "))))
    return tuple(refs)


def recording_step(recording: Path, figures: Path, data: Path, *, mic: str, displacement: str, rpm: float,
                   radius: float, fs: float | None = None, model: FrictionModel | None = None) -> Section:
    """Figs. 6-13 on the user's own recording; with a model, its onset frequency beside the measured squeal."""
    from ..measurement import read_recording
    from ..plotting.measurement import measurement_figures

    res = analyze_recording(recording, mic=mic, displacement=displacement, rpm=rpm, radius=radius, fs=fs)
    save_dataset(res.to_dataset(), data / "recording_analysis.nc")
    kwargs = {"fs": fs} if fs is not None else {}
    rec = read_recording(recording, channels=[mic, displacement], **kwargs)
    mic_name, disp_name = list(rec.data_vars)[:2]
    refs = _save_measurement_figures(measurement_figures(rec, res, mic=mic_name, displacement=disp_name), figures, "")
    f_sq, rf = res.squeal_frequency_hz, res.rising_fraction
    comps = (
        Comparison("squeal main frequency", F_PUBLISHED, f_sq, "Hz", None, "paper: its own rig; yours may differ"),
        Comparison("growth/slope correlation", None, res.growth_slope_correlation, "1", None,
                   "the squeal's growth rate against the run-out slope; positive: squeal grows on rising run-out"),
        Comparison("share of squeal energy on rising run-out", None, rf, "1", None,
                   "above 0.5: squeal favours rising run-out, as the paper finds"),
    )
    if model is not None:
        onset = critical_friction(model, 0.0, damped=True)
        f_model = onset.frequency_hz if math.isfinite(onset.frequency_hz) else None
        comps += (Comparison("squeal frequency: model onset (published column) against measured", f_model, f_sq, "Hz",
                             None if f_model is None or f_sq is None else abs(f_sq / f_model - 1) < 0.05,
                             "the model's frequency where it first loses stability (theta = 0); within 5 % agrees"),)
    paragraphs = (
        f"Your recording {recording.name}: microphone channel {mic!r}, displacement channel {displacement!r}, "
        f"{rpm:g} rpm, probe radius {radius * 1e3:g} mm. Criteria: {res.settings.criteria.describe()}.",
    )
    table = Table(
        "Detected squeal events (first 12)", ("start [s]", "end [s]", "frequency [Hz]", "peak [dB(A)]"),
        tuple((e.start_s, e.end_s, e.frequency_hz, e.peak_dba) for e in res.events[:12]),
    )
    return Section(
        "measurement", f"§5: analysis of {recording.name} (Figs. 6-13)", paragraphs, comps, (table,), refs,
        ("recording_analysis.nc",),
        numbers={"squeal_frequency_hz": f_sq if f_sq is not None else math.nan,
                 "rising_fraction": rf if rf is not None else math.nan, "events": float(len(res.events))},
    )


def measurement_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool = False,
                     seed: int = 2013) -> Section:
    """Figs. 6-13 on a synthetic recording whose squeal sits at the model's onset frequency."""
    from ..plotting.measurement import measurement_figures

    onset = critical_friction(model, 0.0, damped=True)
    f_model = onset.frequency_hz if math.isfinite(onset.frequency_hz) else F_PUBLISHED
    rec = synthetic_recording(duration=1.0 if quick else 2.0, fs=FS, rpm=RPM, radius=RADIUS, freq=f_model,
                              seed=seed)
    res = analyze_recording(rec, mic="mic", displacement="displacement", rpm=RPM, radius=RADIUS)
    save_dataset(rec, data / "synthetic_recording.nc")
    save_dataset(res.to_dataset(), data / "synthetic_recording_analysis.nc")
    refs = _save_measurement_figures(measurement_figures(rec, res), figures, "[SYNTHETIC] ")
    f_sq = res.squeal_frequency_hz
    rf = res.rising_fraction
    truth_rf = float(rec.attrs["truth_rising_fraction"])
    revs = float(rec.sizes["time"] / FS * RPM / 60.0)
    on = res.frames["leq_dba"].values >= res.settings.threshold_dba
    bursts = int(on[0]) + int(np.count_nonzero(np.diff(on.astype(np.int8)) == 1))
    has_onset = math.isfinite(onset.frequency_hz)
    near_paper = has_onset and abs(f_model / F_PUBLISHED - 1) < 0.01
    if near_paper:
        freq_comps = (Comparison("squeal main frequency", F_PUBLISHED, f_sq, "Hz",
                                 f_sq is not None and abs(f_sq / F_PUBLISHED - 1) < 0.01,
                                 f"paper: measured; squealkit: the model's onset frequency {f_model:.1f} Hz, recovered "
                                 "from a synthetic recording (within 1 %)"),)
    else:  # another model: the synthetic squeal is checked against the model's own onset frequency
        freq_comps = (
            Comparison("squeal main frequency", F_PUBLISHED, f_sq, "Hz", None,
                       "published: measured on the paper's rig, for reference"),
            Comparison("squeal frequency recovered against the frequency put in (published column)", f_model, f_sq,
                       "Hz", f_sq is not None and abs(f_sq / f_model - 1) < 0.01,
                       ("the model's damped onset frequency" if has_onset else
                        "the model never loses stability (damped, flat disc): the paper's 2388 Hz is used") +
                       "; within 1 %"),
        )
    comps = (
        *freq_comps,
        Comparison("share of squeal energy on rising run-out", None, rf, "1",
                   rf is not None and rf > 0.5,
                   f"paper: squeal on the rising SRO edge; synthetic truth {truth_rf:.3f}"),
        Comparison("growth/slope correlation", None, res.growth_slope_correlation, "1",
                   res.growth_slope_correlation is not None and res.growth_slope_correlation > 0.5,
                   "squeal growth rate against the run-out slope: positive where squeal grows on rising SRO"),
        Comparison("squeal bursts per disc revolution", None, bursts / revs, "1/rev",
                   bursts >= revs * 0.8, "paper: intermittent, about once per disc turn (frame levels above "
                   "the threshold)"),
    )
    paragraphs = (
        "SYNTHETIC DATA. No public recording of a pin-on-disc squeal rig exists, so this section analyses a "
        "recording squealkit made itself: squeal at "
        + ("the model's onset frequency" if has_onset else
           "the paper's 2388 Hz (this model never loses stability on a flat disc)")
        + " growing on rising run-out and "
        "decaying on falling run-out, macro and micro run-out on the displacement channel, harmonics and "
        f"measurement noise (seed {seed}). It shows the analysis the paper applies to its measurements; "
        "it is not a measurement.",
        f"Rig settings as in §5: {RPM:g} rpm, {FS / 1000:g} kHz sampling; probe radius {RADIUS * 1e3:g} mm "
        f"(assumed). Criteria: {res.settings.criteria.describe()}. On Fast (125 ms) the bursts of each "
        "revolution make one continuous noise event; the bursts are counted on the frames' own level.",
    )
    table = Table(
        "Detected squeal events (first 12)",
        ("start [s]", "end [s]", "frequency [Hz]", "peak [dB(A)]"),
        tuple((e.start_s, e.end_s, e.frequency_hz, e.peak_dba) for e in res.events[:12]),
    )
    return Section(
        "measurement", "§5: rig measurement analysis (Figs. 6-13) on a SYNTHETIC recording", paragraphs, comps,
        (table,), refs, ("synthetic_recording.nc", "synthetic_recording_analysis.nc"),
        numbers={"squeal_frequency_hz": f_sq if f_sq is not None else math.nan,
                 "rising_fraction": rf if rf is not None else math.nan, "truth_rising_fraction": truth_rf,
                 "events": float(len(res.events)), "model_frequency_hz": f_model},
    )
