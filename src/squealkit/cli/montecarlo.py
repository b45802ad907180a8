"""``squealkit montecarlo``: probability of squeal against friction, for scattered parameters."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np

from ._options import (
    NumberOrRange,
    build_model_from_options,
    check_output_suffix,
    damping_option,
    emit_json,
    model_options,
    note_damping,
    output_options,
    progress_callback,
    scheduler_option,
)

#: Largest number of mu rows in the text table.
_TABLE_ROWS = 21


@click.command()
@model_options
@click.option("--uncertain", "uncertain_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="TOML file with the [uncertain] table (default: the --config file).")
@click.option("--samples", default=4096, show_default=True, type=int,
              help="Monte Carlo samples (a power of two uses them all for the Sobol' indices).")
@click.option("--mu", "mu_spec", default="0:0.8:81", show_default=True, type=NumberOrRange(),
              help="Friction coefficients: N points from START to STOP (increasing).")
@click.option("--theta", "theta_deg", default=0.0, show_default=True,
              type=NumberOrRange(single=True, needs="one run-out incline"),
              help="Run-out incline in DEGREES.")
@damping_option
@click.option("--seed", default=0, show_default=True, type=int, help="Seed of the draw: same seed, same numbers.")
@click.option("--confidence", default=0.95, show_default=True, type=float,
              help="Level of the confidence band and of the Sobol' intervals.")
@click.option("--no-sensitivity", "no_sensitivity", is_flag=True,
              help="Skip the Sobol' indices (and their extra model evaluations).")
@scheduler_option
@output_options()
def montecarlo(preset, config, sets, uncertain_path, samples, mu_spec, theta_deg, damped, seed, confidence,
               no_sensitivity, scheduler, as_json, out_path, plot_path) -> None:
    """Squeal propensity: probability of instability against mu, for uncertain parameters.

    Parameters described by distributions in an [uncertain] table of the model
    file (normal: mean, std; uniform: lower, upper; lognormal: mean, std of the
    value itself, or median, sigma of its log) are sampled with a seed; every
    sample's stability is computed over the mu grid (paper eqs. 7-8). Reports
    the share of unstable samples at each mu with a Clopper-Pearson confidence
    band, and Sobol' first-order and total indices of the critical friction:
    which parameters drive it.

    \b
    [uncertain]
    k3 = {dist = "normal", mean = 9.452e8, std = 4.7e7}
    kc = {dist = "lognormal", mean = 4.632e7, std = 4.6e6}
    alpha_deg = {dist = "uniform", lower = 1.5, upper = 2.5}

    \b
    Examples:
      squealkit montecarlo --config examples/uncertain_rig.toml --samples 4096 --mu 0:1:51
      squealkit montecarlo --config rig.toml --samples 1024 --mu 0.2:0.8:61 --json
      squealkit montecarlo --preset hoffmann2002 --uncertain spread.toml --plot propensity.png
      squealkit montecarlo --config rig.toml --samples 65536 --scheduler tcp://HOST:8786 --out mc.nc

    \b
    --json keys: mu, probability_unstable, ci_lower, ci_upper, unstable_count,
    nominal_unstable (lists over mu, equal length); samples, seed, confidence,
    ci_method, theta_deg, damped, nominal_mu_critical, nominal_status;
    mu_critical (mean, std over the samples with an onset in the mu range;
    p05, p50, p95 over all, null where a percentile falls among censored
    samples; censored, the count of samples whose onset lies outside the mu
    range, with a warning on stderr; onset_fraction,
    unstable_at_start_fraction, stable_in_range_fraction,
    indeterminate_fraction); parameters (the distributions); sensitivity
    (per parameter: first_order, first_order_ci, total, total_ci, spearman,
    unit; null with --no-sensitivity).
    """
    from .._validation import InputError, parse_range
    from ..io import save_dataset, save_figure
    from ..scale import cluster_client
    from ..uncertainty import load_uncertain, propensity_summary, squeal_propensity

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    model = build_model_from_options(preset, config, sets)
    note_damping(model, damped)
    source = uncertain_path or config
    if source is None:
        raise InputError("montecarlo needs an [uncertain] table: give --config FILE.toml that has one, "
                         "or --uncertain FILE.toml (see examples/uncertain_rig.toml).")
    from ..models import load_rig_model, parse_assignments

    rig = load_rig_model(config, parse_assignments(sets)) if config is not None else None
    uncertain = load_uncertain(source, rig or model)
    mu = parse_range("--mu", mu_spec)
    if not abs(theta_deg) < 90.0:
        raise InputError(f"--theta {theta_deg!r}: the angle must lie strictly between -90 and 90 deg.")
    with cluster_client(scheduler) as client, progress_callback(
        "Monte Carlo", enabled=not as_json and (samples >= 1024 or client is not None)
    ) as cb:
        ds = squeal_propensity(model, uncertain, mu, samples=samples, theta=math.radians(theta_deg), damped=damped,
                               seed=seed, confidence=confidence, sensitivity=not no_sensitivity, client=client,
                               progress=cb, rig=rig)
    if out_path is not None:
        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..plotting.uncertainty import uncertainty_plot

        save_figure(uncertainty_plot(ds), plot_path)
    summary = propensity_summary(ds)
    if as_json:
        emit_json(summary)
        return
    _print_text(model, summary, ds)
    for label, path in (("dataset", out_path), ("figure", plot_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")


def _print_text(model, s: dict, ds) -> None:
    damped = "damped" if s["damped"] else "undamped"
    click.echo(f"model: {model.kind} ({damped}), theta = {s['theta_deg']:g} deg; "
               f"{s['samples']} samples, seed {s['seed']}")
    for p in s["parameters"]:
        args = ", ".join(f"{k}={v:.6g}" for k, v in p.items() if k not in ("name", "dist"))
        click.echo(f"  {p['name']:<10} {p['dist']}({args})")
    nominal = s["nominal_mu_critical"]
    click.echo(f"nominal model: {s['nominal_status']}" + (f" at mu_crit = {nominal:.6f}" if s["nominal_status"] ==
                                                          "onset" else ""))
    n = len(s["mu"])
    rows = np.unique(np.linspace(0, n - 1, min(n, _TABLE_ROWS)).round().astype(int))
    conf = f"{s['confidence']:.0%}"
    click.echo(f"{'mu':>8} {'P(unstable)':>12} {conf + ' band':>18} {'nominal':>9}")
    for i in rows:
        state = "unstable" if s["nominal_unstable"][i] else "stable"
        click.echo(f"{s['mu'][i]:8.4f} {s['probability_unstable'][i]:12.4f}   "
                   f"[{s['ci_lower'][i]:.4f}, {s['ci_upper'][i]:.4f}] {state:>9}")
    if len(rows) < n:
        click.echo(f"  ({len(rows)} of {n} mu points; --json or --out for all)")
    c = s["mu_critical"]
    def q(v) -> str:
        return "censored" if v is None else f"{v:.4f}"

    click.echo(f"mu_crit over the samples: median {q(c['p50'])}, 5-95% {q(c['p05'])} to {q(c['p95'])} "
               f"({c['unstable_at_start_fraction']:.1%} unstable at mu = {s['mu'][0]:g}, "
               f"{c['stable_in_range_fraction']:.1%} stable up to {s['mu'][-1]:g})")
    if s["sensitivity"] is None:
        return
    click.echo(f"what drives mu_crit: Sobol' indices ({int(ds.attrs['sobol_base_samples'])} base samples, "
               f"{conf} bootstrap intervals)")
    click.echo(f"  {'parameter':<10} {'first order':>24} {'total':>24} {'spearman':>9}")

    def fmt(v, ci) -> str:
        if v is None:
            return "n/a"
        lo, hi = ("?" if x is None else f"{x:.3f}" for x in ci)
        return f"{v:.3f} [{lo}, {hi}]"

    for name, r in s["sensitivity"].items():
        rho = "n/a" if r["spearman"] is None else f"{r['spearman']:+.3f}"
        click.echo(f"  {name:<10} {fmt(r['first_order'], r['first_order_ci']):>24} "
                   f"{fmt(r['total'], r['total_ci']):>24} {rho:>9}")
