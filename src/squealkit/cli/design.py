"""``squealkit design``: which declared change removes which unstable mode, and at what size of change."""

from __future__ import annotations

import math
from pathlib import Path

import click

from ._options import (
    NumberOrRange,
    build_model_from_options,
    emit_json,
    fe_kwargs_from_options,
    fe_options,
    model_options,
    writable_folder,
)


def design_json(ds) -> dict:
    """The stable ``--json`` of a countermeasure study (documented in the command's help)."""
    from ..report.design import countermeasure_table

    a = ds.attrs
    names = [str(p) for p in ds["parameter"].values]
    modes = []
    for i in range(ds.sizes["mode"]):
        modes.append({
            "frequency_hz": float(ds["frequency_hz"].values[i]),
            "growth_rate": float(ds["growth_rate"].values[i]),
            "residual": float(ds["residual"].values[i]),
            "sensitivity": {name: {"growth_rate": float(ds["dgrowth_rate_dp"].values[i, j]),
                                   "frequency_hz": float(ds["dfrequency_hz_dp"].values[i, j])}
                            for j, name in enumerate(names)},
        })
    import json

    out = {k: a[k] for k in ("rpm", "mu", "theta_deg") if k in a}
    out.update(method=a["method"], basis_size=a["basis_size"], parameters=json.loads(a["design"]), modes=modes,
               countermeasures=countermeasure_table(ds))
    return out


@click.command()
@model_options
@click.option("--mu", type=NumberOrRange(single=True, needs="one friction coefficient"), default=None,
              help="Friction coefficient (FE models: default mu_ref).")
@click.option("--theta", "theta_deg", default=0.0, show_default=True,
              type=NumberOrRange(single=True, needs="one run-out incline"), help="Run-out incline in DEGREES.")
@fe_options(rpm_help="Disc speed [rpm] (one value). FE models only.", single_rpm=True)
@click.option("--out-dir", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              callback=writable_folder, help="Output folder: design.nc, design.json, report.html, figures/.")
@click.option("--no-report", is_flag=True, help="With --out-dir: skip the HTML report and its figures.")
@click.option("--json", "as_json", is_flag=True, help="Print the study as JSON on stdout.")
def design(preset, config, sets, mu, theta_deg, rpm_spec, band_spec, method, n_modes, out_dir, no_report,
           as_json) -> None:
    """Design squeal out: the effect of each declared change on each unstable mode.

    The changes are the design parameters of the model file's [design] table:
    NAME = "PART" scales a matrix part (M, D1, DG, DR, D4, K1, KR, KGeo, or C / K
    at the operating point; nominal 1), NAME = {part = "K1", nodes = [...]} (or
    dofs = [...]) scales it among the DOFs of a node set, NAME = {mass = 0.0,
    nodes = [...]} adds a point mass [kg]; a small model names its parameters
    (NAME = "k3"). For each unstable mode: the derivative of its growth rate
    and frequency per unit of each parameter (from its left and right
    eigenvectors, no re-solve), the parameters ranked by their effect per
    declared step, and the smallest change of each that stabilises the mode:
    predicted to first order and confirmed by solves (Newton on sigma = 0).

    \b
    Examples:
      squealkit design --config brake.toml --rpm 500 --mu 0.6 --eigen-band 1000:11000
      squealkit design --config brake.toml --rpm 500 --json --out-dir study

    \b
    --json keys: rpm, mu, theta_deg, method, basis_size, parameters (name,
    kind, part, nominal, step, unit, n_dofs), modes (the unstable ones:
    frequency_hz, growth_rate, residual, sensitivity = {NAME: {growth_rate,
    frequency_hz}}: derivatives per unit of NAME, in 1/s and Hz), and
    countermeasures (per mode and parameter, best rank first: frequency_hz,
    growth_rate, parameter, unit, nominal, rank, effect [1/s per step],
    dgrowth_rate_dp, predicted_change, confirmed_change, prediction_error,
    confirmed_growth_rate, solves, status).
    """
    from .._validation import InputError, validate_finite
    from ..design import countermeasures, load_design

    if config is None:
        raise InputError("squealkit design needs --config: a model file with a [design] table.")
    theta_deg = validate_finite("--theta", theta_deg)
    if abs(theta_deg) >= 90.0:
        raise InputError(f"--theta {theta_deg!r}: the angle must lie strictly between -90 and 90 deg.")
    model = build_model_from_options(preset, config, sets, allow_fe=True)
    params = load_design(config, model)
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    kw = {}
    if fe:
        kw = {"rpm": float(fe["rpm"][0]), "method": fe["method"], "band": fe["band"], "n_modes": fe["n_modes"]}
    elif mu is None:
        raise InputError("A small model needs the friction coefficient: --mu.")
    ds = countermeasures(model, params, mu=None if mu is None else validate_finite("--mu", mu),
                         theta=math.radians(theta_deg), **kw)
    summary = design_json(ds)
    if out_dir is not None:
        import json

        from ..io import output_folder
        from ._options import _jsonable

        with output_folder(out_dir) as stage:
            ds.to_netcdf(stage / "design.nc")
            (stage / "design.json").write_text(json.dumps(_jsonable(summary), indent=2, allow_nan=False))
            if not no_report:
                from ..report.design import write_design_report

                write_design_report(ds, stage)
    elif no_report:
        raise InputError("--no-report applies with --out-dir only.")
    if as_json:
        emit_json(summary)
        return
    from ..report.design import design_sentences

    for sentence in design_sentences(ds):
        click.echo(sentence)
    rows = summary["countermeasures"]
    if rows:
        click.echo(f"{'f [Hz]':>9} {'sigma':>9} {'parameter':>12} {'rank':>4} {'effect/step':>12} {'predicted':>10} "
                   f"{'confirmed':>10}  status")
        for r in rows:
            click.echo(f"{r['frequency_hz']:9.4g} {r['growth_rate']:9.4g} {r['parameter']:>12} {r['rank']:4d} "
                       f"{r['effect']:12.4g} {r['predicted_change']:10.4g} {r['confirmed_change']:10.4g}  "
                       f"{r['status']}")
    if out_dir is not None:
        click.echo(f"wrote {out_dir / 'design.nc'}, {out_dir / 'design.json'}"
                   + ("" if no_report else f", {out_dir / 'report.html'}"))
