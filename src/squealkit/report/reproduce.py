"""``reproduce``: rebuild the paper's results, figures and a report in one call.

Everything is written into a staging folder beside the output folder and moved into place
only when the whole report is done, so an interrupted or failed run leaves no half-written
file behind: either ``DIR`` holds a complete report or it is as it was.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..io import check_output, output_folder
from ..models import FrictionModel, PinOnDiscRig, get_preset
from .document import Section
from .html import render_html

__all__ = ["RecordingSpec", "ReproduceResult", "reproduce"]

#: What a report writes in its folder: with ``force``, a file of the user's among them is refused up front.
REPORT_FILES = ("report.html", "figures", "data")

Step = Callable[[Path, Path], Section]


@dataclass(frozen=True)
class ReproduceResult:
    """What a reproduce run wrote and computed.

    Attributes
    ----------
    out_dir : Path
        The output folder: ``report.html``, ``figures/`` (PNG and SVG), ``data/`` (netCDF).
    sections : tuple of Section
        The report's content, with the computed numbers of each section in ``numbers``.
    seconds : float
        Wall time of the run.
    """

    out_dir: Path
    sections: tuple[Section, ...]
    seconds: float

    @property
    def report(self) -> Path:
        return self.out_dir / "report.html"

    def numbers(self) -> dict[str, dict[str, float]]:
        """The computed numbers by section key."""
        return {s.key: dict(s.numbers) for s in self.sections}


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
    """

    path: Path
    mic: str
    displacement: str
    rpm: float
    radius: float
    fs: float | None = None


def _paper_steps(
    model: FrictionModel, rig: PinOnDiscRig | None, published: bool, quick: bool,
    recording: RecordingSpec | None = None,
) -> list[tuple[str, Step]]:
    from .steps_measurement import measurement_step, recording_step
    from .steps_stability import critical_step, fig2_step, parameters_step
    from .steps_transient import transient_step

    n = 41 if quick else 161
    steps: list[tuple[str, Step]] = [
        ("parameters", lambda fig, dat: parameters_step(model, rig, fig, dat)),
        ("Fig. 2 eigenvalues", lambda fig, dat: fig2_step(model, fig, dat, n_mu=n, n_theta=n, published=published)),
        ("critical friction", lambda fig, dat: critical_step(model, fig, dat)),
        ("Figs. 3-4 transients", lambda fig, dat: transient_step(model, fig, dat, quick=quick)),
    ]
    if "kinematics" in model.parameter_info():
        from .steps_beyond import beyond_step

        steps.append(("beyond the paper", lambda fig, dat: beyond_step(model, fig, dat)))
        from .steps_nonlinear import nonlinear_step

        steps.append(("how loud", lambda fig, dat: nonlinear_step(model, fig, dat, quick=quick)))
    if recording is None:
        steps.append(("Figs. 6-13 measurement", lambda fig, dat: measurement_step(model, fig, dat, quick=quick)))
    else:
        r = recording
        steps.append(("Figs. 6-13 your recording", lambda fig, dat: recording_step(
            r.path, fig, dat, mic=r.mic, displacement=r.displacement, rpm=r.rpm, radius=r.radius, fs=r.fs,
            model=model)))
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
        The model (default: the paper's rig, preset ``lv2013``). With a model of your own
        the published numbers are still shown for reference.
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
        The model file the model and rig were read from; named in the report's header.
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
    steps = _paper_steps(model, rig, published=paper_model, quick=quick, recording=recording)
    start = time.perf_counter()
    # staged and moved into place only when complete; never deletes what squealkit did not write
    with output_folder(out, force=force) as stage:
        figures, data = stage / "figures", stage / "data"
        figures.mkdir(parents=True)
        data.mkdir()
        sections = []
        for i, (name, step) in enumerate(steps):
            if progress is not None:
                progress(i, len(steps), name)
            sections.append(step(figures, data))
        from .steps_conclusions import conclusions_step

        sections.append(conclusions_step(sections))
        if progress is not None:
            progress(len(steps), len(steps), "report")
        title = title or ("Lv, Zhang & Yu (2013), reproduced by squealkit" if default else "squealkit report")
        subtitle = ("Influence of surface run-out on disc brake squeal, J. Vibroeng. 15(2) 2013"
                    if default else f"model: {model.kind}"
                    + (f", from {Path(config).name}" if config is not None else ""))
        (stage / "report.html").write_text(render_html(sections, figures, title=title, subtitle=subtitle),
                                           encoding="utf-8")
    return ReproduceResult(out, tuple(sections), time.perf_counter() - start)
