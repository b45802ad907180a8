"""``squealkit correlate``: a campaign's measured squeal against a model's predicted unstable modes."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import (
    build_model_from_options,
    damping_option,
    emit_json,
    model_options,
    note_damping,
    scheduler_option,
    writable_folder,
)


def correlation_json(ds) -> dict:
    """The stable ``--json`` of a correlation (documented in the command's help)."""
    import json
    import math

    import numpy as np

    def hz(row) -> list[float]:
        return [float(x) for x in np.sort(row[np.isfinite(row)])]

    out = {k: ds.attrs[k] for k in ("applications", "hits", "misses", "over_predictions", "quiet")}
    out["tolerance_percent"] = float(ds.attrs["tolerance_percent"])
    out["per_application"] = [
        {"application": str(a), "mu": float(mu), "predicted_hz": hz(p), "measured_hz": hz(m), "outcome": str(o)}
        for a, mu, p, m, o in zip(ds["application"].values, ds["mu"].values, ds["predicted_hz"].values,
                                  ds["measured_hz"].values, ds["outcome"].values, strict=True)]
    out["distinct_points"] = int(ds.attrs.get("distinct_points", 0))
    if ds.attrs.get("friction_law"):
        out["friction_law"] = ds.attrs["friction_law"]
    if "calibration" in ds.attrs:
        cal = json.loads(ds.attrs["calibration"])
        out["calibration"] = {k: {"value": q["value"], "interval": q["interval"], "identifiable": q["identifiable"]}
                              for k, q in cal["quantities"].items()}
        out["calibration_objective"] = cal["objective"]
        out["before"], out["after"] = cal["before"], cal["after"]
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}


@click.command()
@click.argument("campaign_dir", type=click.Path(path_type=Path))
@model_options
@damping_option
@click.option("--fit", "fits", multiple=True, metavar="NAME=LO:HI",
              help="Calibrate a quantity within bounds: mu_offset (model mu = measured mu + offset), mu_scale, "
              "damping_scale, NAME_scale of a parameter, or a parameter NAME. Repeatable.")
@click.option("--tolerance", type=float, default=3.0, show_default=True, metavar="PCT",
              help="Frequency tolerance of a match between a measured squeal and an unstable mode [%].")
@click.option("--method", type=click.Choice(["pod", "modal", "dense", "sparse"]), default="pod", show_default=True,
              help="FE models: the solver; pod and modal build one reduced basis for the whole campaign.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              callback=writable_folder, help="Output folder: correlation.nc, correlation.json, report.html, figures/.")
@click.option("--no-report", is_flag=True, help="With --out: skip the HTML report and its figures.")
@scheduler_option
@click.option("--json", "as_json", is_flag=True, help="Print the correlation summary as JSON on stdout.")
def correlate(campaign_dir: Path, preset: str | None, config: Path | None, sets: tuple[str, ...], damped: bool,
              fits: tuple[str, ...], tolerance: float, method: str, out_dir: Path | None, no_report: bool,
              scheduler: str | None, as_json: bool) -> None:
    """Compare a campaign's measured squeal with a model's predicted unstable modes.

    CAMPAIGN_DIR is what 'squealkit campaign --out' wrote. The model file (--config) may hold a
    [correlate] table saying how conditions map onto the model: mu = "measured" (the matrix's
    mu column, the default), "law" (a friction law mu(p, T, v) fitted to it, or given as
    mu_law = {...}) or "torque"; mu_offset, mu_scale, theta_deg, disc speed from rpm or
    vehicle speed and rolling_radius, and parameter laws [correlate.laws].

    Per application the outcome is hit (squeal measured and an unstable mode within the
    tolerance), miss (squeal not predicted), over_prediction (predicted, quiet) or quiet.
    --json prints applications, hits, misses, over_predictions, quiet, tolerance_percent,
    per_application (application, mu, predicted_hz, measured_hz, outcome) and, with --fit,
    calibration (NAME: value, interval: the values with as few wrong applications).

    \b
    Example:
      squealkit correlate camp/out --config brake.toml --fit mu_offset=-0.2:0.2 --out corr
    """
    from .._validation import InputError
    from ..correlate import ConditionMap, load_correlation_model, parse_fit
    from ..correlate import correlate as run
    from ..scale import cluster_client

    if not 0 < tolerance <= 50:
        raise InputError(f"--tolerance {tolerance:g} must be > 0 and <= 50 (percent).")
    bounds = parse_fit(fits) if fits else None
    if not campaign_dir.is_dir():
        raise InputError(f"CAMPAIGN_DIR {str(campaign_dir)!r} is not a folder (give what 'squealkit campaign --out' "
                         "wrote).")
    if config is not None:
        if preset is not None:
            raise InputError("Give either --preset or --config, not both.")
        from ..models import parse_assignments

        model, cmap = load_correlation_model(config, parse_assignments(sets))
    else:
        model, cmap = build_model_from_options(preset, None, sets, allow_fe=True), ConditionMap()
    note_damping(model, damped)
    with cluster_client(scheduler) as client:
        ds = run(campaign_dir, model, cmap, damped=damped, tolerance=tolerance / 100, fit=bounds, client=client,
                 method=method)
    summary = correlation_json(ds)
    if out_dir is not None:
        import json

        from ..io import output_folder

        with output_folder(out_dir) as stage:
            ds.to_netcdf(stage / "correlation.nc")
            (stage / "correlation.json").write_text(json.dumps(summary, indent=2, allow_nan=False))
            if not no_report:
                from ..report.correlate import write_correlation_report

                write_correlation_report(ds, stage, synthetic=bool(ds.attrs.get("synthetic")))
    if as_json:
        emit_json(summary)
        return
    n = summary["applications"]
    click.echo(f"{n} applications, tolerance {summary['tolerance_percent']:g} %: {summary['hits']} hits, "
               f"{summary['misses']} misses, {summary['over_predictions']} over-predictions, {summary['quiet']} quiet "
               f"({summary['distinct_points']} distinct operating points solved)")
    for name, q in summary.get("calibration", {}).items():
        click.echo(f"  {name} = {q['value']:.4g}, the data allow {q['interval'][0]:.4g} to {q['interval'][1]:.4g}"
                   + ("" if q["identifiable"] else " (not identifiable: the whole bounds)"))
    if out_dir is not None:
        click.echo(f"wrote {out_dir / 'correlation.nc'}, {out_dir / 'correlation.json'}"
                   + ("" if no_report else f", {out_dir / 'report.html'}"))
