"""``squealkit reproduce`` and ``squealkit report``: the paper, or your rig, as one report."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import (
    deprecated_alias,
    emit_json,
    model_options,
    recording_kwargs_from_options,
    recording_options,
)


def _out_dir_options(f):
    """``--out-dir`` (and its old name ``--out``) and ``--force``: where a report goes."""
    f = click.option("--force", is_flag=True, help="Write into a folder that holds other files, leaving them alone (a "
                     "file of the same name as one the report writes is refused, never replaced).")(f)
    f = deprecated_alias("--out", "--out-dir", "out_dir", type=click.Path(file_okay=False, path_type=Path))(f)
    return click.option("--out-dir", "out_dir", type=click.Path(file_okay=False, path_type=Path),
                        default=Path("squealkit-report"), show_default=True, help="Output folder (replaced as a whole "
                        "when the run succeeds; a folder holding files squealkit did not write is refused).")(f)


def _run_options(f):
    """``--quick`` and ``--json``."""
    f = click.option("--json", "as_json", is_flag=True, help="Print the computed numbers as JSON on stdout.")(f)
    return click.option("--quick", is_flag=True, help="Coarser grids and shorter runs: a preview in seconds.")(f)


def _given(ctx: click.Context, allowed: tuple[str, ...]) -> list[str]:
    """The options given on the command line other than ``allowed`` (parameter names)."""
    return [p.opts[0] for p in ctx.command.params if p.name not in allowed
            and ctx.get_parameter_source(p.name) == click.core.ParameterSource.COMMANDLINE]


#: What each kind of data file a report writes is called in its closing line.
_DATA_KINDS = {".nc": "netCDF", ".vtu": "VTK"}


def _write(out_dir: Path, force: bool, quick: bool, as_json: bool, write) -> None:
    """Run ``write(progress)`` (a report function) under a progress bar, then print what it wrote.

    The output folder is checked before the bar appears, so an error stays one line.
    """
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from ..io import check_output
    from ..report.runner import REPORT_FILES

    check_output(out_dir, directory=True, force=force, names=REPORT_FILES)
    progress = Progress(TextColumn("{task.description:<28}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                        TimeElapsedColumn(), console=Console(stderr=True), disable=as_json,
                        transient=True)  # gone when the run ends: an error stays one line
    with progress:
        task = progress.add_task("starting", total=None)

        def update(done: int, total: int, name: str) -> None:
            progress.update(task, completed=done, total=total, description=name)

        result = write(update)
    if as_json:
        emit_json({"out_dir": str(result.out_dir), "report": str(result.report), "seconds": result.seconds,
                   "numbers": result.numbers()})
        return
    click.echo(f"wrote {result.report} ({result.seconds:.1f} s)")
    # the kinds the sections list: the folder itself is moved into place when the command ends
    data = {Path(name).suffix for s in result.sections for name in s.data}
    click.echo(f"figures: {result.out_dir / 'figures'} ({'PNG' if quick else 'PNG and SVG'}); data: "
               f"{result.out_dir / 'data'} ({', '.join(k for x, k in _DATA_KINDS.items() if x in data)})")


def _run(out_dir: Path, *, model=None, rig=None, recording=None, quick: bool = False, as_json: bool,
         force: bool = False, config: Path | None = None) -> None:
    from ..report import reproduce

    _write(out_dir, force, quick, as_json, lambda progress: reproduce(
        out_dir, model=model, rig=rig, recording=recording, quick=quick, progress=progress, force=force,
        config=config))


@click.command()
@_out_dir_options
@_run_options
def reproduce(out_dir: Path, force: bool, quick: bool, as_json: bool) -> None:
    """Rebuild every result of the paper, with a report, on the paper's rig.

    Recomputes Table 1 and §3's parameters from the rig, Fig. 2 (eigenvalues over
    mu and theta, the lock-in band), the critical friction and run-out tolerance,
    and writes report.html (self-contained, each published number beside the
    computed one), figures/ (PNG and SVG) and data/ (netCDF behind every figure).
    An interrupted or failed run leaves no half-written file in the folder, and
    squealkit never deletes a file it did not write: a folder holding other files
    is refused unless --force (then they are left alone).

    \b
    Example:
      squealkit reproduce --out-dir paper
      xdg-open paper/report.html

    \b
    --json keys: out_dir, report, seconds, and numbers (by section: the
    computed values, e.g. numbers.fig2.band_low / band_high in rad/s).
    """
    _run(out_dir, quick=quick, as_json=as_json, force=force)


@click.command()
@model_options
@_out_dir_options
@click.option("--recording", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Your rig recording (CSV, WAV, netCDF, TDMS), analysed for §5 instead of a synthetic one.")
@recording_options(required=False)
@_run_options
@click.pass_context
def report(ctx: click.Context, preset, config, sets, out_dir: Path, force: bool, recording, quick: bool,
           as_json: bool, mic: str, displacement: str, rpm: float | None, radius: float | None, fs: float | None,
           scales: tuple[str, ...], units: tuple[str, ...], **analysis) -> None:
    """The paper's analysis for your own rig or model, as one report.

    Takes the model from --config (a TOML model file; with a [rig] table the
    parameters are derived from your rig's geometry, materials and frequencies),
    --preset and --set. Only the paper's model gets the published numbers and
    verdicts against them. The operating point (frictions of the transients and
    the run-out tolerance, the Fig. 4 run-out) comes from the file's [report]
    table, or is placed from your model's own onset. --recording is read and
    analysed with the options of 'squealkit analyze' (--tacho, --scale,
    --unit, the squeal criteria...).

    An FE model (model = "fe" in --config) gets the report of its unstable
    modes instead: every unstable mode per load case (frequency, growth rate,
    damping ratio, dominant body, friction work), each animated on the mesh in
    a 3D view (self-contained, offline), the friction work on the pads, and the
    modes tracked over friction and disc speed; the load cases come from the
    file's [report] table (rpm, mu, eigen_band, method, mu_sweep, rpm_sweep,
    max_views, n_frames; see squealkit.report.fe_modes).

    \b
    Example:
      squealkit report --config myrig.toml --out-dir myrig-report
      squealkit report --set alpha_deg=3 --set kc=3e7 --out-dir stiffer-pin
      squealkit report --config myrig.toml --recording run1.tdms \
          --mic mic --displacement probe --rpm 900 --radius 0.05
      squealkit report --config myrig.toml --recording run1.wav --mic 0 \
          --displacement 1 --scale 0=120 --tacho 2 --radius 0.05
    """
    from .._validation import InputError
    from ..fe.model import FEModel
    from ..models import load_rig, parse_assignments
    from ..models._base import damping_names
    from ..report import RecordingSpec
    from ._options import PENDING_NOTES, build_model_from_options

    model = build_model_from_options(preset, config, sets, allow_fe=True)
    if isinstance(model, FEModel):
        return _fe_report(ctx, model, config, out_dir, force, quick, as_json)
    rig = load_rig(config, parse_assignments(sets)) if config is not None else None
    if damping_names(model):
        PENDING_NOTES.append(f"squealkit: the report's eigenvalue map and critical-friction curve follow the paper "
                             f"(undamped, eq. 7); the model's damping ({damping_names(model)}) enters its damped "
                             "onset, a second run-out tolerance and the transients.")
    spec = None
    if recording is None:  # a recording option without a recording would be silently ignored
        given = _given(ctx, ("preset", "config", "sets", "out_dir", "force", "recording", "quick", "as_json"))
        if given:
            raise InputError(f"{given[0]} applies to --recording; give the recording, or leave {given[0]} out.")
    else:
        if (rpm is None and analysis.get("tacho") is None) or radius is None:
            raise InputError("--recording needs --rpm and --radius (the disc speed, or a --tacho channel, and the "
                             "probe radius).")
        if not recording.is_file():
            raise InputError(f"Recording {str(recording)!r} does not exist.")
        options, scale_map, unit_map = recording_kwargs_from_options(rpm=rpm, scales=scales, units=units, **analysis)
        spec = RecordingSpec(recording, mic, displacement, rpm, radius, fs, scale_map, unit_map, options)
    _run(out_dir, model=model, rig=rig, recording=spec, quick=quick, as_json=as_json, force=force, config=config)


def _fe_report(ctx: click.Context, model, config, out_dir: Path, force: bool, quick: bool, as_json: bool) -> None:
    """``squealkit report`` on an FE model: the report of its unstable modes."""
    from .._validation import InputError
    from ..report.fe_modes import fe_report, load_fe_report_settings

    given = _given(ctx, ("preset", "config", "sets", "out_dir", "force", "quick", "as_json"))
    if given:
        raise InputError(f"{given[0]} applies to the paper's model and its recording, not to an FE model; "
                         "an FE report takes its load cases from the [report] table of --config.")
    settings = load_fe_report_settings(config, model, quick=quick)  # a bad [report] table: one line, before work
    _write(out_dir, force, quick, as_json, lambda progress: fe_report(out_dir, model, settings=settings, config=config,
                                                               quick=quick, force=force, progress=progress))
