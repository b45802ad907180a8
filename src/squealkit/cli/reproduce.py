"""``squealkit reproduce`` and ``squealkit report``: the paper, or your rig, as one report."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import emit_json, model_options


def _run(out_dir: Path, *, model=None, rig=None, recording=None, quick: bool = False, as_json: bool,
         force: bool = False, config: Path | None = None) -> None:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from ..io import check_output
    from ..report import reproduce
    from ..report.reproduce import REPORT_FILES

    # before the progress bar: the error stays one line
    check_output(out_dir, directory=True, force=force, names=REPORT_FILES)
    progress = Progress(TextColumn("{task.description:<28}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                        TimeElapsedColumn(), console=Console(stderr=True), disable=as_json)
    with progress:
        task = progress.add_task("starting", total=None)

        def update(done: int, total: int, name: str) -> None:
            progress.update(task, completed=done, total=total, description=name)

        result = reproduce(out_dir, model=model, rig=rig, recording=recording, quick=quick, progress=update,
                           force=force, config=config)
    if as_json:
        emit_json({"out_dir": str(result.out_dir), "report": str(result.report), "seconds": result.seconds,
                   "numbers": result.numbers()})
        return
    click.echo(f"wrote {result.report} ({result.seconds:.1f} s)")
    click.echo(f"figures: {result.out_dir / 'figures'} (PNG and SVG); data: {result.out_dir / 'data'} (netCDF)")


@click.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("squealkit-report"),
              show_default=True, help="Output folder (replaced as a whole when the run succeeds; a folder "
              "holding files squealkit did not write is refused).")
@click.option("--force", is_flag=True, help="Write into a folder that holds other files, leaving them alone (a file of "
              "the same name as one the report writes is refused, never replaced).")
@click.option("--quick", is_flag=True, help="Coarser grids and shorter runs: a preview in seconds.")
@click.option("--json", "as_json", is_flag=True, help="Print the computed numbers as JSON on stdout.")
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
      squealkit reproduce --out paper
      xdg-open paper/report.html

    \b
    --json keys: out_dir, report, seconds, and numbers (by section: the
    computed values, e.g. numbers.fig2.band_low / band_high in rad/s).
    """
    _run(out_dir, quick=quick, as_json=as_json, force=force)


@click.command()
@model_options
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("squealkit-report"),
              show_default=True, help="Output folder (replaced as a whole when the run succeeds; a folder "
              "holding files squealkit did not write is refused).")
@click.option("--force", is_flag=True, help="Write into a folder that holds other files, leaving them alone (a file of "
              "the same name as one the report writes is refused, never replaced).")
@click.option("--recording", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Your rig recording (CSV, WAV, netCDF, TDMS), analysed for §5 instead of a synthetic one.")
@click.option("--mic", default="mic", show_default=True, help="Microphone channel (name or index) in --recording.")
@click.option("--displacement", default="displacement", show_default=True,
              help="Displacement channel (name or index) in --recording.")
@click.option("--rpm", type=float, default=None, help="Disc speed [rpm] of --recording.")
@click.option("--radius", type=float, default=None, help="Probe radius [m] of --recording.")
@click.option("--fs", type=float, default=None, help="Sample rate [Hz] of a CSV --recording without a time column.")
@click.option("--quick", is_flag=True, help="Coarser grids and shorter runs: a preview in seconds.")
@click.option("--json", "as_json", is_flag=True, help="Print the computed numbers as JSON on stdout.")
def report(preset, config, sets, out_dir: Path, force: bool, recording, mic, displacement, rpm, radius, fs,
           quick: bool, as_json: bool) -> None:
    """The paper's analysis for your own rig or model, as one report.

    Takes the model from --config (a TOML model file; with a [rig] table the
    parameters are derived from your rig's geometry, materials and frequencies
    and compared with the paper's), --preset and --set. The paper's published
    numbers stay in the report for reference.

    \b
    Example:
      squealkit report --config myrig.toml --out myrig-report
      squealkit report --set alpha_deg=3 --set kc=3e7 --out stiffer-pin
      squealkit report --config myrig.toml --recording run1.tdms \
          --mic mic --displacement probe --rpm 900 --radius 0.05
    """
    from .._validation import InputError
    from ..models import load_rig
    from ..report import RecordingSpec
    from ._options import build_model_from_options

    model = build_model_from_options(preset, config, sets)
    rig = load_rig(config) if config is not None else None
    spec = None
    if recording is not None:
        if rpm is None or radius is None:
            raise InputError("--recording needs --rpm and --radius (disc speed and probe radius).")
        if not recording.is_file():
            raise InputError(f"Recording {str(recording)!r} does not exist.")
        spec = RecordingSpec(recording, mic, displacement, rpm, radius, fs)
    _run(out_dir, model=model, rig=rig, recording=spec, quick=quick, as_json=as_json, force=force, config=config)
