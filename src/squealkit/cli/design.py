"""``squealkit design``: which declared change removes which unstable mode, and at what size of change."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

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
              callback=writable_folder, help="Output folder: design.nc, design.json, report.html, figures/ "
              "(with --doe or --scatter: design.nc and design.json).")
@click.option("--no-report", is_flag=True, help="With --out-dir: skip the HTML report and its figures.")
@click.option("--json", "as_json", is_flag=True, help="Print the study as JSON on stdout.")
@click.option("--doe", "doe_specs", multiple=True, metavar="NAME=START:STOP:N",
              help="Instead of the countermeasure study, a design of experiments: NAME (a parameter of the "
              "[design] table) takes N values from START to STOP; repeat for a full factorial grid (others stay "
              "nominal). FE models, on a reduced model (--method pod or modal; default pod) with every point "
              "checked in the full model. Prints the Pareto points (smallest change for the least growth).")
@click.option("--scatter", "scatter_specs", multiple=True, metavar="NAME=COV[:DIST]",
              help="Instead of the countermeasure study, robust margins: NAME scatters about its nominal value "
              "with coefficient of variation COV (KR=0.05: 5 %), normal unless DIST says uniform or lognormal "
              "(D1=0.3:lognormal keeps a scale > 0); repeat for each. NAME is an FE matrix "
              "part (M, D1, DG, DR, D4, K1, KR, KGeo; its scale, nominal 1) or a small model's parameter (k3, kc). "
              "Prints the probability that some mode in --eigen-band grows, by Monte Carlo (--samples, --seed) "
              "and by the second-order perturbation estimate, each with its interval.")
@click.option("--samples", type=int, default=1000, show_default=True, help="Monte Carlo samples (with --scatter).")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Seed of the random numbers (with --scatter): the same seed, the same samples.")
def design(preset, config, sets, mu, theta_deg, rpm_spec, band_spec, method, n_modes, out_dir, no_report,
           as_json, doe_specs, scatter_specs, samples, seed) -> None:
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

    With --doe, a design-of-experiments sweep of the declared parameters
    instead; with --scatter, the squeal propensity when matrix parts (or a
    small model's parameters) scatter (robust margins).

    \b
    Examples:
      squealkit design --config brake.toml --rpm 500 --mu 0.6 --eigen-band 1000:11000
      squealkit design --config brake.toml --rpm 500 --json --out-dir study
      squealkit design --config brake.toml --rpm 500 --mu 0.6 --doe friction=0.6:1.1:6 --doe damping=1:3:5
      squealkit design --config brake.toml --rpm 500 --mu 0.6 --eigen-band 4000:4800 \\
        --scatter KR=0.2 --scatter D1=0.3:lognormal --samples 400

    \b
    --json keys: rpm, mu, theta_deg, method, basis_size, parameters (name,
    kind, part, nominal, step, unit, n_dofs), modes (the unstable ones:
    frequency_hz, growth_rate, residual, sensitivity = {NAME: {growth_rate,
    frequency_hz}}: derivatives per unit of NAME, in 1/s and Hz), and
    countermeasures (per mode and parameter, best rank first: frequency_hz,
    growth_rate, parameter, unit, nominal, rank, effect [1/s per step],
    dgrowth_rate_dp, predicted_change, confirmed_change, prediction_error,
    confirmed_growth_rate, solves, status).

    \b
    --doe --json keys: rpm, mu, theta_deg, basis_size, parameters, points,
    trusted_points, pareto (per Pareto point, smallest change first: values =
    {NAME: value}, change_size [declared steps], max_growth_rate [1/s],
    frequency_hz, n_unstable). --scatter --json keys: rpm, mu, theta_deg,
    samples, seed, basis, trusted, max_residual, estimators (per estimator:
    name, propensity, ci = [lower, upper], cost_seconds), modes (frequency_hz,
    growth_rate, probability_unstable = {estimator: p}, perturbation_status).
    --out-dir writes design.nc and design.json for each (no HTML report:
    the figures are squealkit.plotting.design's pareto_plot and
    design_robust's robust_margins_plot).
    """
    from .._validation import InputError, validate_finite
    from ..design import countermeasures, load_design

    if config is None:
        raise InputError("squealkit design needs --config: a model file with a [design] table.")
    theta_deg = validate_finite("--theta", theta_deg)
    if abs(theta_deg) >= 90.0:
        raise InputError(f"--theta {theta_deg!r}: the angle must lie strictly between -90 and 90 deg.")
    model = build_model_from_options(preset, config, sets, allow_fe=True)
    if doe_specs and scatter_specs:
        raise InputError("--doe and --scatter are two studies: give one of them.")
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    mu = None if mu is None else validate_finite("--mu", mu)
    if scatter_specs:
        return _robust(model, fe, mu, theta_deg, scatter_specs, samples, seed, out_dir, no_report, as_json)
    for name, value in (("--samples", samples != 1000), ("--seed", seed != 0)):
        if value:
            raise InputError(f"{name} applies with --scatter only.")
    params = load_design(config, model)
    if doe_specs:
        return _doe(model, params, fe, mu, theta_deg, doe_specs, out_dir, no_report, as_json)
    kw = {}
    if fe:
        kw = {"rpm": float(fe["rpm"][0]), "method": fe["method"], "band": fe["band"], "n_modes": fe["n_modes"]}
    elif mu is None:
        raise InputError("A small model needs the friction coefficient: --mu.")
    ds = countermeasures(model, params, mu=mu, theta=math.radians(theta_deg), **kw)
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


def _pairs(option: str, specs: tuple[str, ...], what: str) -> dict[str, str]:
    """``NAME=VALUE`` items of a repeatable option, each name once."""
    from .._validation import InputError

    out: dict[str, str] = {}
    for spec in specs:
        name, sep, value = spec.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise InputError(f"{option} {spec!r} must be NAME={what}.")
        if name in out:
            raise InputError(f"{option}: {name} is given twice.")
        out[name] = value
    return out


def _write(out_dir: Path | None, no_report: bool, ds, summary: dict) -> None:
    from .._validation import InputError

    if out_dir is None:
        if no_report:
            raise InputError("--no-report applies with --out-dir only.")
        return
    import json

    from ..io import output_folder
    from ._options import _jsonable

    with output_folder(out_dir) as stage:
        ds.to_netcdf(stage / "design.nc")
        (stage / "design.json").write_text(json.dumps(_jsonable(summary), indent=2, allow_nan=False))


def _doe(model, params, fe: dict, mu, theta_deg: float, specs: tuple[str, ...], out_dir, no_report: bool,
         as_json: bool) -> None:
    """``--doe``: :func:`squealkit.design.doe_sweep` over the grid the options give."""
    from .._validation import InputError, parse_range
    from ..design import doe_sweep

    if not fe:
        raise InputError("--doe runs on a reduced FE model; a small model has no [design] sweep here.")
    values = {name: parse_range(f"--doe {name}", text) for name, text in _pairs("--doe", specs,
                                                                                 "START:STOP:N").items()}
    method = "pod" if fe["method"] == "auto" else fe["method"]
    ds = doe_sweep(model, params, values, float(fe["rpm"][0]), mu, math.radians(theta_deg), method=method,
                   band=fe["band"], n_modes=fe["n_modes"])
    names = [str(p) for p in ds["parameter"].values]
    order = np.flatnonzero(ds["pareto"].values)
    order = order[np.argsort(ds["change_size"].values[order], kind="stable")]
    pareto = [{"values": dict(zip(names, map(float, ds["value"].values[i]), strict=True)),
               "change_size": float(ds["change_size"].values[i]),
               "max_growth_rate": float(ds["max_growth_rate"].values[i]),
               "frequency_hz": float(ds["frequency_hz"].values[i]), "n_unstable": int(ds["n_unstable"].values[i])}
              for i in order]
    a = ds.attrs
    summary = {k: a[k] for k in ("rpm", "mu", "theta_deg") if k in a}
    summary.update(basis_size=int(a["basis_size"]), parameters=names, points=int(ds.sizes["point"]),
                   trusted_points=int(ds["all_trusted"].values.sum()), pareto=pareto)
    _write(out_dir, no_report, ds, summary)
    if as_json:
        emit_json(summary)
        return
    swept = [n for n in names if n in values]
    others = [n for n in names if n not in values]
    click.echo(f"{summary['points']} design points of {', '.join(swept)}"
               + (f" ({', '.join(others)} nominal)" if others else "")
               + f" on a reduced model of {summary['basis_size']} vectors; {summary['trusted_points']} with every "
               f"mode checked in the full model; {int((ds['n_unstable'].values > 0).sum())} unstable. Pareto points "
               "(no other point is both a smaller change, in declared steps, and less unstable):")
    click.echo("  " + " ".join(f"{n:>10}" for n in swept) + f" {'steps':>7} {'sigma max':>10} {'f [Hz]':>9}")
    for r in pareto:
        click.echo("  " + " ".join(f"{r['values'][n]:10.4g}" for n in swept)
                   + f" {r['change_size']:7.3g} {r['max_growth_rate']:10.4g} {r['frequency_hz']:9.4g}")
    if out_dir is not None:
        click.echo(f"wrote {out_dir / 'design.nc'}, {out_dir / 'design.json'}")


def _robust(model, fe: dict, mu, theta_deg: float, specs: tuple[str, ...], samples: int, seed: int, out_dir,
            no_report: bool, as_json: bool) -> None:
    """``--scatter``: :func:`squealkit.design.robust_margins` with normal scatter of the named quantities."""
    from .._validation import InputError, validate_finite
    from ..design import PERTURBATION_STATUS, robust_margins
    from ..uncertainty import DISTRIBUTIONS

    scatter: dict = {}
    for name, text in _pairs("--scatter", specs, "COV[:DIST]").items():
        cov, _, dist = text.partition(":")
        dist = dist.strip() or "normal"
        if dist not in DISTRIBUTIONS:
            raise InputError(f"--scatter {name}={text}: unknown distribution {dist!r}; known: "
                             f"{', '.join(DISTRIBUTIONS)}.")
        scatter[name] = {"dist": dist, "cov": validate_finite(f"--scatter {name}", cov)}
    kw: dict = {}
    if fe:
        if fe["method"] != "auto" or fe["n_modes"] is not None:
            raise InputError("--method and --modes do not apply with --scatter: it reduces the model itself (a POD "
                             "basis at the operating point, the whole model up to 200 DOFs).")
        kw = {"rpm": float(fe["rpm"][0]), "band": fe["band"]}
    elif mu is None:
        raise InputError("A small model needs the friction coefficient: --mu.")
    ds = robust_margins(model, mu=mu, theta=math.radians(theta_deg), scatter=scatter, samples=samples, seed=seed,
                        **kw)
    a = ds.attrs
    estimators = [str(e) for e in ds["estimator"].values]
    summary = {k: a[k] for k in ("rpm", "mu", "theta_deg") if k in a and np.isfinite(a[k])}
    summary.update(samples=int(a["samples"]), seed=int(a["seed"]), basis=a["basis"], trusted=int(a["trusted"]),
                   max_residual=float(a["max_residual"]), estimators=[
                       {"name": e, "propensity": float(ds["propensity"].values[i]),
                        "ci": [float(ds["propensity_ci_lower"].values[i]), float(ds["propensity_ci_upper"].values[i])],
                        "cost_seconds": float(ds["cost_seconds"].values[i])} for i, e in enumerate(estimators)],
                   modes=[{"frequency_hz": float(ds["frequency_hz"].values[k]),
                           "growth_rate": float(ds["growth_rate"].values[k]),
                           "probability_unstable": {e: float(ds["probability_unstable"].values[i, k])
                                                    for i, e in enumerate(estimators)},
                           **({"perturbation_status": PERTURBATION_STATUS[int(ds["perturbation_status"].values[k])]}
                              if "perturbation_status" in ds else {})}
                          for k in range(ds.sizes["mode"])])
    _write(out_dir, no_report, ds, summary)
    if as_json:
        emit_json(summary)
        return
    where = f"{a['rpm']:g} rpm, " if np.isfinite(a["rpm"]) else ""
    what = ", ".join(f"{n} ({s['dist']} {s['cov']:g})" for n, s in scatter.items())
    click.echo(f"Squeal propensity at {where}mu = {a['mu']:g} when {what} scatter (coefficient of variation), "
               f"{ds.sizes['mode']} mode{'' if ds.sizes['mode'] == 1 else 's'} in the band:")
    for e in summary["estimators"]:
        p, (lo, hi) = e["propensity"], e["ci"]
        click.echo(f"  {e['name']:>12}: {p:.3g} [{lo:.3g}, {hi:.3g}] in {e['cost_seconds']:.3g} s")
    for m in summary["modes"]:
        probs = ", ".join(f"{k} {v:.3g}" for k, v in m["probability_unstable"].items())
        click.echo(f"  mode at {m['frequency_hz']:.6g} Hz (growth rate {m['growth_rate']:.3g} 1/s): P(grows) {probs}"
                   + (f"; perturbation {m['perturbation_status']}" if "perturbation_status" in m else ""))
    if not summary["trusted"]:
        click.echo(f"  the reduced basis does not hold every sample (largest full-model residual "
                   f"{summary['max_residual']:.3g}): the Monte Carlo numbers are not the brake's")
    if out_dir is not None:
        click.echo(f"wrote {out_dir / 'design.nc'}, {out_dir / 'design.json'}")
