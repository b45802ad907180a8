"""``reproduce``: rebuild the paper's results, figures and a report in one call.

Its steps run through :func:`squealkit.report.runner.run_report`: written into a staging folder
beside the output folder and moved into place only when the whole report is done, so an
interrupted or failed run leaves no half-written file behind: either ``DIR`` holds a complete
report or it is as it was.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..io import check_output
from ..models import FrictionModel, PinOnDiscRig, get_preset
from .context import ReportContext
from .runner import REPORT_FILES, ReportStep, ReproduceResult, run_report
from .settings import ReportSettings, load_report_settings

__all__ = ["RecordingSpec", "ReportSettings", "ReproduceResult", "reproduce"]

#: The compiled kernels compiled in the background while the first steps run (see :mod:`squealkit._warmup`);
#: a step waits for those beyond the stability ones it needs (its ``kernels``).
_KERNELS = ("transient", "stability", "nonlinear", "measurement")


@dataclass(frozen=True)
class RecordingSpec:
    """A user's rig recording for the report's §5 (see :func:`squealkit.measurement.analyze_recording`).

    Attributes
    ----------
    path : Path
        The recording file.
    mic, displacement : str
        Channel names (or indices as text) of the microphone [Pa] and the displacement probe [m].
    rpm : float
        Disc speed [rev/min].
    radius : float
        Probe (and pin) radius [m].
    fs : float or None, default None
        Sample rate [Hz] where the file does not carry one.
    scale, units : dict of str, optional
        Per-channel factor from file value to physical unit, and unit names (as ``analyze``'s
        ``--scale`` and ``--unit``; see :func:`squealkit.measurement.open_recording`).
    options : dict, optional
        Further keyword arguments of :func:`squealkit.measurement.analyze_recording` (tacho,
        criteria, probe offset, polarity...). With a ``tacho``, ``rpm`` may be None.
    """

    path: Path
    mic: str
    displacement: str
    rpm: float | None
    radius: float
    fs: float | None = None
    scale: dict[str, float] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)


def _paper_steps(
    model: FrictionModel, rig: PinOnDiscRig | None, published: bool, quick: bool,
    recording: RecordingSpec | None = None, settings: ReportSettings | None = None,
    context: ReportContext | None = None,
) -> list[ReportStep]:
    from .steps_measurement import measurement_step, recording_step
    from .steps_stability import critical_step, fig2_step, parameters_step
    from .steps_transient import transient_step

    n = 41 if quick else 161
    op = settings or ReportSettings.paper()
    ctx = context or ReportContext()  # the flat-disc onset, computed once for every step that reads it
    steps = [
        ReportStep("parameters", lambda fig, dat: parameters_step(model, rig, fig, dat, settings=op)),
        ReportStep("Fig. 2 eigenvalues", lambda fig, dat: fig2_step(model, fig, dat, n_mu=n, n_theta=n,
                                                                    published=published, context=ctx)),
        ReportStep("critical friction", lambda fig, dat: critical_step(model, fig, dat, settings=op, context=ctx)),
        ReportStep("Figs. 3-4 transients", lambda fig, dat: transient_step(model, fig, dat, quick=quick, settings=op,
                                                                           published=published),
                   kernels=("transient",)),
    ]
    if "kinematics" in model.parameter_info():
        from .steps_beyond import beyond_step

        steps.append(ReportStep("beyond the paper", lambda fig, dat: beyond_step(model, fig, dat, settings=op)))
        from .steps_nonlinear import nonlinear_step

        steps.append(ReportStep("how loud", lambda fig, dat: nonlinear_step(model, fig, dat, quick=quick,
                                                                            settings=op, context=ctx),
                                kernels=("transient", "nonlinear")))
    if recording is None:
        steps.append(ReportStep("Figs. 6-13 measurement", lambda fig, dat: measurement_step(
            model, fig, dat, quick=quick, published=published, context=ctx), kernels=("measurement",)))
    else:
        r = recording
        steps.append(ReportStep("Figs. 6-13 your recording", lambda fig, dat: recording_step(
            r.path, fig, dat, mic=r.mic, displacement=r.displacement, rpm=r.rpm, radius=r.radius, fs=r.fs,
            model=model, scale=r.scale, units=r.units, options=r.options, context=ctx), kernels=("measurement",)))
    return steps


def reproduce(
    out_dir: str | Path,
    *,
    model: FrictionModel | None = None,
    rig: PinOnDiscRig | None = None,
    title: str | None = None,
    quick: bool = False,
    recording: RecordingSpec | None = None,
    progress: Callable[[int, int, str], None] | None = None,
    force: bool = False,
    config: str | Path | None = None,
    settings: ReportSettings | None = None,
) -> ReproduceResult:
    """Recompute the paper's figures and numbers and write a self-contained report.

    Parameters
    ----------
    out_dir : path-like
        Output folder; created, or replaced as a whole when the run succeeds. A folder
        holding files squealkit did not write is refused, unless ``force``.
    force : bool
        Write into a folder that holds other files: the report's files are moved in one
        by one, complete, and the other files are left alone.
    model : FrictionModel, optional
        The model (default: the paper's rig, preset ``lv2013``). Only the paper's model gets
        the published numbers and verdicts against them; a model of your own gets its own.
    rig : PinOnDiscRig, optional
        The rig the parameters are derived from (default: the paper's, when ``model`` is
        the default).
    title : str, optional
        Report title.
    quick : bool
        Coarser grids and shorter runs: a preview in seconds, not the published figures.
    recording : RecordingSpec, optional
        Your rig recording, analysed for §5 instead of the synthetic one.
    config : path-like, optional
        The model file the model and rig were read from; named in the report's header. Its
        ``[report]`` table, if any, sets the operating point (see :class:`ReportSettings`).
    settings : ReportSettings, optional
        The operating point (frictions, the Fig. 4 run-out, the sliding speed); overrides the
        ``[report]`` table. Default: the paper's for the paper's model, otherwise placed from
        the model's own onset (:meth:`ReportSettings.for_model`).
    progress : callable, optional
        ``progress(done, total, step_name)`` before each step and at the end.

    Returns
    -------
    ReproduceResult
    """
    out = Path(out_dir)
    check_output(out, directory=True, force=force, names=REPORT_FILES)  # before the work, not after
    default = model is None
    model = get_preset("lv2013") if model is None else model
    if rig is None and default:
        rig = PinOnDiscRig.paper()
    paper = get_preset("lv2013")
    # verdicts against the published numbers only for the paper's rig; other models show them for reference
    paper_model = type(model) is type(paper) and model == paper
    context = ReportContext()  # what several steps read (the flat-disc onset), computed once
    if settings is None:
        settings = load_report_settings(config, model, paper=paper_model, context=context)
    steps = _paper_steps(model, rig, published=paper_model, quick=quick, recording=recording, settings=settings,
                         context=context)
    from .steps_conclusions import conclusions_step

    title = title or ("Lv, Zhang & Yu (2013), reproduced by squealkit" if default else "squealkit report")
    subtitle = ("Influence of surface run-out on disc brake squeal, J. Vibroeng. 15(2) 2013"
                if default else f"model: {model.kind}" + (f", from {Path(config).name}" if config is not None else ""))
    # a first run compiles the later steps' kernels on the other core while the first steps run;
    # a preview draws each figure once (PNG)
    return run_report(out, steps, title=title, subtitle=subtitle, quick=quick, force=force, progress=progress,
                      compile_kernels=_KERNELS,
                      closing=lambda sections: conclusions_step(sections, settings=settings, published=paper_model))
