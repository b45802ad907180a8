"""``squealkit campaign``: a test matrix of brake applications into a database, summary and report."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import (
    PROBE_RADIUS,
    NumberOrRange,
    criteria_from_options,
    criteria_options,
    deprecated_alias,
    emit_json,
    progress_callback,
    required,
    scheduler_option,
)


@click.command()
@click.argument("matrix", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out-dir", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Output folder (required): campaign.duckdb, summary.json, report.html, figures/.")
@deprecated_alias("--out", "--out-dir", "out_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--mic", required=True, help="Microphone channel [Pa]: name or 0-based index.")
@click.option("--displacement", required=True, help="Eddy-current probe channel [m]: name or index.")
@click.option("--radius", type=PROBE_RADIUS, required=True,
              help="Probe radius on the disc [m], or with a unit: '60 mm'.")
@click.option("--tacho", default=None, help="Tacho channel (name or index); else --rpm or the matrix's rpm column.")
@click.option("--pulses-per-rev", type=int, default=1, show_default=True, help="Tacho pulses per revolution.")
@click.option("--rpm", type=NumberOrRange(single=True, needs="one disc speed"), default=None,
              help="Disc speed [rpm] where there is no tacho nor rpm column.")
@click.option("--probe-offset-deg", type=float, default=0.0, show_default=True,
              help="The probe sits this far upstream of the pin [deg].")
@click.option("--polarity", type=click.Choice(["1", "-1"]), default="1", show_default=True,
              help="-1 when the probe reads the run-out reversed.")
@click.option("--pressure-channel", default=None,
              help="Channel [bar] whose mean gives an application's pressure where the matrix leaves it empty.")
@click.option("--temperature-channel", default=None,
              help="Channel [C] whose mean gives an application's temperature where the matrix leaves it empty.")
@click.option("--no-report", is_flag=True, help="Skip the HTML report and its figures.")
@criteria_options
@scheduler_option
@click.option("--json", "as_json", is_flag=True, help="Print summary.json on stdout.")
def campaign(matrix: Path, out_dir: Path, mic: str, displacement: str, radius: float, tacho: str | None,
             pulses_per_rev: int, rpm: float | None, probe_offset_deg: float, polarity: str,
             pressure_channel: str | None, temperature_channel: str | None, no_report: bool,
             setup: str | None, band: str | None, threshold_dba: float, time_weighting: str, min_duration: float,
             scheduler: str | None, as_json: bool) -> int:
    """Analyse every brake application of a test matrix (SAE J2521 occurrence, VDA 303 events).

    MATRIX is a CSV with one row per application: application, file (relative to the
    matrix), and optionally section, mode (drag|stop), pressure_bar, temperature_c,
    speed_kmh, rpm. Events and applications go into OUT_DIR/campaign.duckdb (query it with SQL:
    the view 'squeal' joins events and conditions); OUT_DIR/summary.json holds the occurrence,
    overall and per 1/3-octave band; OUT_DIR/report.html the figures. Re-running skips the
    applications already analysed with the same criteria (a killed run resumes).

    A recording that cannot be analysed (missing, unreadable, damaged, a bad channel) does
    not stop the campaign: the others are analysed, and the failed ones are listed on
    stderr at the end, in summary.json ('failed': application, file, error), in the
    database (applications.status = 'failed', applications.error) and in the report. A
    re-run retries the failed applications; one taken out of the matrix no longer
    counts. Exit code: 0 when every application was analysed, 1 when some failed (the
    outputs are complete for the others), 2 for bad input (options, the matrix) with
    nothing analysed.

    \b
    Example:
      squealkit synth --campaign 100 --out-dir camp
      squealkit campaign camp/matrix.csv --out-dir camp/out --mic mic --displacement displacement \\
          --tacho tacho --radius 0.05
      duckdb camp/out/campaign.duckdb "SELECT * FROM squeal WHERE peak_dba > 75 AND \\
          frequency_hz BETWEEN 6000 AND 8000 AND temperature_c > 150"
    """
    from ..campaign import run_campaign
    from ..scale import cluster_client

    out_dir = required(out_dir, "--out-dir")

    crit = criteria_from_options(setup, band, threshold_dba, time_weighting, min_duration)
    kw = dict(mic=mic, displacement=displacement, radius=radius, rpm=rpm, setup=crit.setup if crit.setup != "user"
              else None, band=crit.band, threshold_dba=crit.threshold_dba, time_weighting=crit.time_weighting,
              min_duration=crit.min_duration, probe_offset_deg=probe_offset_deg, polarity=int(polarity),
              report=not no_report, pressure_channel=pressure_channel, temperature_channel=temperature_channel)
    if tacho is not None:
        kw.update(tacho=int(tacho) if tacho.isdigit() else tacho, pulses_per_rev=pulses_per_rev)
    with cluster_client(scheduler) as client, progress_callback("applications", enabled=not as_json) as cb:
        summary = run_campaign(matrix, out_dir, client=client, progress=cb, **kw)
    if as_json:
        emit_json(summary)
        return _report_failures(summary)
    click.echo(f"criteria: {summary['criteria']}")
    n_ok, n_failed = summary["applications"], len(summary["failed"])
    if n_ok:
        click.echo(f"{n_ok} applications analysed ({summary['analysed_now']} run now"
                   + (f"; {n_failed} more failed" if n_failed else "") + f"), {summary['applications_with_squeal']} "
                   f"with squeal: occurrence {summary['occurrence_percent']:.1f} %")
    else:
        click.echo(f"no application could be analysed ({n_failed} failed)")
    if summary["runout_unavailable"]:
        click.echo(f"run-out link unavailable for {len(summary['runout_unavailable'])} applications "
                   "(summary.json 'runout_unavailable' says why; give --rpm or --tacho for it)")
    for b in summary["by_band"]:
        if b["occurrence_percent"]:
            click.echo(f"  {b['band_hz'][0]:7.0f}-{b['band_hz'][1]:7.0f} Hz: {b['occurrence_percent']:5.1f} %")
    click.echo(f"wrote {out_dir / 'campaign.duckdb'}, {out_dir / 'summary.json'}"
               + ("" if no_report else f", {out_dir / 'report.html'}"))
    return _report_failures(summary)


def _report_failures(summary: dict) -> int:
    """List the failed applications on stderr, last; the exit code: 1 if any failed, else 0."""
    failed = summary["failed"]
    if not failed:
        return 0
    total = summary["applications"] + len(failed)
    click.echo(f"squealkit campaign: {len(failed)} of {total} applications failed (listed in summary.json "
               "'failed' and the database; a re-run retries them):", err=True)
    for f in failed:
        click.echo(f"{f['application']} ({f['file']}): {f['error']}", err=True)
    return 1
