"""Report step for the paper's §5: a SYNTHETIC rig recording analysed as the paper analyses its own."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .._operating_point import RIG_FS, RIG_RADIUS, RIG_RPM, RIG_SQUEAL_FREQ
from ..io import save_dataset
from ..measurement import analyze_recording, squeal_views, synthetic_recording
from ..models import FrictionModel
from .context import ReportContext, flat_onset
from .document import Comparison, FigureRef, Section, Table
from .steps_stability import _save_fig, onset_said_in_words

# Paper §5: 900 rpm, 10 N, 40 kHz sampling; squeal main frequency about 2388 Hz, once per disc turn on the
# rising SRO. The probe radius is not given; 50 mm is assumed.
RPM, FS, RADIUS, F_PUBLISHED = RIG_RPM, RIG_FS, RIG_RADIUS, RIG_SQUEAL_FREQ

def _captions(res, t_end: float) -> dict[str, str]:
    """Captions of the §5 figures from what they show: the zoom's revolutions at the actual speed,
    the band around the squeal found (or the paper's band without squeal), the filters used."""
    v = squeal_views(res, t_end)
    (t0, t1), (lo, hi), s = v["zoom"], v["band"], res.settings
    fr = res.frames
    rpm = float(np.mean(fr["rpm"].values)) if "rpm" in fr else float(s.rpm)
    revs = (t1 - t0) * rpm / 60.0
    f_sq = res.squeal_frequency_hz
    start = "from the squeal's onset" if f_sq is not None else "from the start (no squeal found)"
    band = (f"the {lo:.0f}-{hi:.0f} Hz band around the squeal found at {f_sq:.0f} Hz" if f_sq is not None else
            f"the paper's {lo:.0f}-{hi:.0f} Hz band (no squeal found)")
    return {
        "time": "Figs. 6-7: sound pressure and disc surface displacement",
        "spectrogram": f"Figs. 8-9: spectrograms of both channels up to {v['freq_max'] / 1000:g} kHz"
                       + (", with the squeal ridge" if f_sq is not None else ""),
        "zoom": f"Figs. 10-11: zoom on {t0:.3g}-{t1:.3g} s, {revs:.3g} revolutions at {rpm:.4g} rpm {start}",
        "runout": f"Fig. 12: low-pass ({s.lowpass_freq:g} Hz) run-out over the same {revs:.3g} revolutions, split "
                  f"into macro (orders <= {s.macro_orders}) and micro run-out",
        "band": f"Fig. 13: {band}, displacement against the sound pressure over the same revolutions",
        "level": f"A-weighted squeal level with the detected events ({s.criteria.describe()})",
        "polar": "Squeal level against disc angle with the run-out, over the revolutions",
    }


def _save_measurement_figures(figs: dict, figures: Path, prefix: str, captions: dict[str, str]
                              ) -> tuple[FigureRef, ...]:
    """Save the §5 figures (PNG and SVG) as ``sec5_NN_name`` and return their references."""
    refs = []
    for i, (name, fig) in enumerate(figs.items()):
        stem = f"sec5_{i:02d}_{name}"
        _save_fig(fig, figures, stem)
        refs.append(FigureRef(stem, prefix + captions.get(name, name.replace("_", " "))))
    return tuple(refs)


def model_frequency(model: FrictionModel, context: ReportContext | None = None) -> tuple[float | None, str]:
    """The frequency a model says a rig squeals at, and where it comes from.

    The damped onset on a flat disc (the mode that loses stability first, eq. 4 with C); a
    model that stays stable damped gives its undamped coalescence (lock-in) frequency
    instead (eq. 7, Fig. 2); None when it never loses stability up to mu = 2.
    """
    with onset_said_in_words():  # the critical-friction section says whether onset is realistic
        return _model_frequency(model, context)


def _model_frequency(model: FrictionModel, context: ReportContext | None) -> tuple[float | None, str]:
    onset = flat_onset(model, context)
    if math.isfinite(onset.frequency_hz):
        return onset.frequency_hz, f"the model's damped onset (mu_crit = {onset.mu_critical:.4f}, flat disc)"
    onset = flat_onset(model, context, damped=False)
    if math.isfinite(onset.frequency_hz):
        return onset.frequency_hz, (f"the model's undamped coalescence (mu_crit = {onset.mu_critical:.4f}, flat "
                                    "disc; damped it stays stable)")
    return None, "the model never loses stability up to mu = 2 (flat disc)"


def recording_step(recording: Path, figures: Path, data: Path, *, mic: str, displacement: str, rpm: float | None,
                   radius: float, fs: float | None = None, model: FrictionModel | None = None,
                   scale: dict[str, float] | None = None, units: dict[str, str] | None = None,
                   options: dict | None = None, context: ReportContext | None = None) -> Section:
    """Figs. 6-13 on the user's own recording; with a model, its onset frequency beside the measured squeal.

    ``scale`` and ``units`` are applied where the channels are read (as ``analyze --scale/--unit``);
    ``options`` are further arguments of :func:`squealkit.measurement.analyze_recording` (a tacho
    channel, the squeal criteria, probe offset, polarity...)."""
    from ..measurement import open_recording
    from ..plotting.measurement import measurement_figures

    read_kw = {"fs": fs, "scale": scale or None, "units": units or None}
    res = analyze_recording(open_recording(recording, **read_kw), mic=mic, displacement=displacement, rpm=rpm,
                            radius=radius, keep_signals=True, **(options or {}))
    save_dataset(res.to_dataset(), data / "recording_analysis.nc")
    captions = _captions(res, float(res.signals["time"].values[-1]))
    refs = _save_measurement_figures(measurement_figures(res), figures, "", captions)
    f_sq, rf = res.squeal_frequency_hz, res.rising_fraction
    comps = (
        Comparison("growth/slope correlation", None, res.growth_slope_correlation, "1", None,
                   "the squeal's growth rate against the run-out slope; positive: squeal grows on rising run-out"),
        Comparison("share of squeal energy on rising run-out", None, rf, "1", None,
                   "above 0.5: squeal favours rising run-out"),
    )
    tacho = (options or {}).get("tacho")
    speed = f"disc speed from tacho channel {tacho!r}" if tacho is not None else f"{rpm:g} rpm"
    scaled = ", ".join(f"{k} x {v:g}" for k, v in (scale or {}).items())
    paragraphs = [
        f"Your recording {recording.name}: microphone channel {mic!r}, displacement channel {displacement!r}, "
        f"{speed}, probe radius {radius * 1e3:g} mm" + (f"; scaled {scaled}" if scaled else "")
        + f". Criteria: {res.settings.criteria.describe()}.",
    ]
    tables = []
    numbers = {"squeal_frequency_hz": f_sq if f_sq is not None else math.nan,
               "rising_fraction": rf if rf is not None else math.nan, "events": float(len(res.events))}
    if model is not None:
        f_model, source = model_frequency(model, context)
        diff = 100.0 * (f_sq / f_model - 1) if f_sq is not None and f_model is not None else None
        tables.append(Table(
            "Model against measurement", ("quantity", "model [Hz]", "measured [Hz]", "difference [%]", "model source"),
            (("squeal frequency", f_model, f_sq, diff, source),),
        ))
        numbers.update(model_frequency_hz=f_model if f_model is not None else math.nan,
                       model_difference_percent=diff if diff is not None else math.nan)
        if diff is not None:
            paragraphs.append(f"The model puts squeal at {f_model:.0f} Hz, {source}; the recording squeals at "
                              f"{f_sq:.0f} Hz, {abs(diff):.1f} % {'above' if diff > 0 else 'below'} it.")
    tables.append(Table(
        "Detected squeal events (first 12)", ("start [s]", "end [s]", "frequency [Hz]", "peak [dB(A)]"),
        tuple((e.start_s, e.end_s, e.frequency_hz, e.peak_dba) for e in res.events[:12]),
    ))
    return Section(
        "measurement", f"§5: analysis of {recording.name} (Figs. 6-13)", tuple(paragraphs), comps, tuple(tables), refs,
        ("recording_analysis.nc",), numbers=numbers,
    )


def measurement_step(model: FrictionModel, figures: Path, data: Path, *, quick: bool = False,
                     seed: int = 2013, published: bool = True, context: ReportContext | None = None) -> Section:
    """Figs. 6-13 on a synthetic recording whose squeal sits at the model's onset frequency.

    The recording is made at the model's frequency, so finding that frequency in it checks the
    analysis, not the model: the text says so. Only the paper's model (``published``) gets the
    comparison of its onset frequency with the paper's measured squeal."""
    from ..plotting.measurement import measurement_figures

    with onset_said_in_words():
        onset = flat_onset(model, context)
    f_model = onset.frequency_hz if math.isfinite(onset.frequency_hz) else F_PUBLISHED
    rec = synthetic_recording(duration=1.0 if quick else 2.0, fs=FS, rpm=RPM, radius=RADIUS, freq=f_model,
                              seed=seed)
    res = analyze_recording(rec, mic="mic", displacement="displacement", rpm=RPM, radius=RADIUS, keep_signals=True)
    save_dataset(rec, data / "synthetic_recording.nc")
    save_dataset(res.to_dataset(), data / "synthetic_recording_analysis.nc")
    refs = _save_measurement_figures(measurement_figures(res), figures, "[SYNTHETIC] ",
                                     _captions(res, float(rec["time"].values[-1])))
    f_sq = res.squeal_frequency_hz
    rf = res.rising_fraction
    truth_rf = float(rec.attrs["truth_rising_fraction"])
    revs = float(rec.sizes["time"] / FS * RPM / 60.0)
    on = res.frames["leq_dba"].values >= res.settings.threshold_dba
    bursts = int(on[0]) + int(np.count_nonzero(np.diff(on.astype(np.int8)) == 1))
    has_onset = math.isfinite(onset.frequency_hz)
    put_in = ("the model's damped onset frequency" if has_onset else
              "the paper's 2388 Hz (the model never loses stability, damped, on a flat disc)")
    freq_comps: tuple[Comparison, ...] = (
        Comparison("squeal frequency recovered from the synthetic recording", None, f_sq, "Hz",
                   f_sq is not None and abs(f_sq / f_model - 1) < 0.01,
                   f"put in: {f_model:.1f} Hz, {put_in}; within 1 %. Circular by construction: this checks the "
                   "analysis, not the model"),
    )
    if published and has_onset:  # the model's own onset frequency against the paper's measured squeal
        freq_comps = (Comparison("squeal main frequency: the model's onset against the paper's measurement",
                                 F_PUBLISHED, f_model, "Hz", abs(f_model / F_PUBLISHED - 1) < 0.01,
                                 "paper: measured on its rig; squealkit: the damped onset frequency (within 1 %)"),
                      *freq_comps)
    paper_says = published  # the paper's findings as notes only for the paper's model
    comps = (
        *freq_comps,
        Comparison("share of squeal energy on rising run-out", None, rf, "1",
                   rf is not None and rf > 0.5,
                   ("paper: squeal on the rising SRO edge; " if paper_says else "")
                   + f"synthetic truth {truth_rf:.3f}"),
        Comparison("growth/slope correlation", None, res.growth_slope_correlation, "1",
                   res.growth_slope_correlation is not None and res.growth_slope_correlation > 0.5,
                   "squeal growth rate against the run-out slope: positive where squeal grows on rising SRO"),
        Comparison("squeal bursts per disc revolution", None, bursts / revs, "1/rev",
                   bursts >= revs * 0.8, ("paper: intermittent, about once per disc turn" if paper_says else
                                          "the synthetic squeal is made once per disc turn")
                   + " (frame levels above the threshold)"),
    )
    found = f"{f_sq:.1f} Hz" if f_sq is not None else "no squeal"
    paragraphs = (
        "SYNTHETIC DATA. No public recording of a pin-on-disc squeal rig exists, so this section analyses a "
        "recording squealkit made itself: squeal at "
        + ("the model's onset frequency" if has_onset else
           "the paper's 2388 Hz (this model never loses stability on a flat disc)")
        + " growing on rising run-out and "
        "decaying on falling run-out, macro and micro run-out on the displacement channel, harmonics and "
        f"measurement noise (seed {seed}). It shows the analysis the paper applies to its measurements; "
        "it is not a measurement.",
        f"The analysis finds {found} in it, against the {f_model:.1f} Hz put in. That agreement is circular: the "
        "recording was made at that frequency, so it checks that the analysis recovers what was put in and says "
        "nothing of whether the model predicts a real rig's squeal"
        + (f"; that comparison is the model's onset, {f_model:.1f} Hz, against the paper's measured "
           f"{F_PUBLISHED:.0f} Hz ({100 * (f_model / F_PUBLISHED - 1):+.1f} %)." if published and has_onset else
           "; a recording of your rig (report --recording) makes that comparison."),
        f"The paper's §5 rig settings: {RPM:g} rpm, {FS / 1000:g} kHz sampling; probe radius {RADIUS * 1e3:g} mm "
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
