"""``squealkit stability``: complex eigenvalues over a grid of friction and run-out incline."""

from __future__ import annotations

import math
from pathlib import Path

import click

from ._options import (
    NumberOrRange,
    build_model_from_options,
    check_output_suffix,
    damping_option,
    emit_json,
    fe_kwargs_from_options,
    fe_options,
    friction_from_options,
    friction_json,
    friction_options,
    model_options,
    note_damping,
    output_options,
    progress_callback,
    scheduler_option,
    writable,
)


@click.command()
@model_options
@click.option("--mu", "mu_spec", default="0:0.8:81", show_default=True, type=NumberOrRange(),
              help="Friction coefficients: N points from START to STOP, or one number.")
@click.option("--theta", "theta_spec", default="-8:8:81", show_default=True, type=NumberOrRange(),
              help="Run-out incline angles in DEGREES: N points from START to STOP, or one number.")
@damping_option
@friction_options
@click.option("--plot-map", "map_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              callback=writable,
              help="Also write a stability map with the critical-friction curve (.png/.svg/.pdf).")
@fe_options()
@scheduler_option
@output_options()
@click.pass_context
def stability(ctx, preset, config, sets, mu_spec, theta_spec, damped, stribeck_spec, speed, map_path, rpm_spec,
              band_spec, method, n_modes, scheduler, as_json, out_path, plot_path) -> None:
    """Complex eigenvalues over friction mu and SRO incline theta (paper §3, Fig. 2).

    Solves M x'' + C x' + K(mu, tan theta) x = 0 (without C: --undamped) at every grid
    point, tracks the modes across the grid and reports where they lock in and
    grow. Prints a summary; --json for machine-readable output.

    \b
    Examples:
      squealkit stability --plot fig2.png
      squealkit stability --mu 0:0.8:401 --theta -8:8:401 --out map.nc --json
      squealkit stability --preset hoffmann2002 --mu 0:0.5:201 --theta 0
      squealkit stability --set alpha_deg=3 --plot-map map.png
      squealkit stability --mu 0:0.8:20001 --theta -8:8:20001 --out big.zarr --scheduler local
      squealkit stability --stribeck 0.6,0.001 --speed 0.0015 --mu 0:0.8:81 --theta 0

    \b
    With --stribeck the friction falls (or rises) with the sliding speed; the
    model is linearised about steady sliding at --speed: mu is the kinetic
    coefficient, K uses mu(speed), and the slope dmu/dv adds the damping
    dmu/dv N0 D (N0 the static contact force): falling friction is negative
    damping, a second way to squeal beside mode coupling. It is added with or
    with --undamped. Needs a model with one point contact.

    \b
    With --out FILE.zarr the map is written tile by tile (blocks of mu rows), never held
    whole in memory; --scheduler ADDRESS computes the tiles on a Dask cluster (the
    store must be on a file system the workers share) with identical numbers.

    \b
    FE models (model = "fe" in --config): the grid is disc speed --rpm x friction --mu
    (default: the model's mu_ref) at one --theta (default 0; mu_e = mu + tan theta);
    damping is always included. --method dense|sparse|modal|pod (auto: dense up to
    1000 DOFs), --eigen-band LO:HI in Hz (sparse default 1000:16000), --modes N for the
    reduced bases. --plot draws growth rate against frequency of every mode in the
    band per speed (unstable ones marked), --plot-map the speed x friction map.
    --scheduler solves the rpm rows on a Dask cluster (same numbers); the map is
    gathered in memory, then written.
      squealkit stability --config brake.toml --rpm 60:240:10 --mu 0:1:20 --plot g.png --plot-map m.png

    \b
    --json keys: unstable_omega_rad_s and unstable_frequency_hz ([min, max] of the
    most unstable mode's frequency over unstable points, or null),
    unstable_fraction, lock_in_fraction, max_growth_rate [1/s], grid_points,
    mu_range, theta_deg_range, damped; with --stribeck also stribeck
    ({mu_static, v_stribeck}) and speed [m/s]; for FE models also rpm_range,
    method, band_hz, n_dof and untrusted_fraction (share of eigenpairs whose
    backward error exceeds residual_tol).
    """
    from .._validation import InputError, parse_range
    from ..io import save_dataset, save_figure
    from ..scale import cluster_client
    from ..stability import critical_friction_curve, stability_map, stability_summary

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    check_output_suffix(map_path, (".png", ".svg", ".pdf"), "--plot-map")
    model = build_model_from_options(preset, config, sets, allow_fe=True)
    note_damping(model, damped)
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    if fe:
        return _stability_fe(ctx, model, fe, mu_spec, theta_spec, stribeck_spec, scheduler, map_path, as_json,
                             out_path, plot_path)
    fr = friction_from_options(ctx, stribeck_spec, speed)
    mu = parse_range("--mu", mu_spec)
    theta_deg = parse_range("--theta", theta_spec)
    if any(abs(t) >= 90.0 for t in theta_deg):
        raise InputError(f"--theta {theta_spec!r}: angles must lie strictly between -90 and 90 deg.")
    theta = [math.radians(t) for t in theta_deg]
    stream = out_path is not None and out_path.suffix.lower() == ".zarr"
    if scheduler is not None and not stream:
        raise InputError("--scheduler streams the map to zarr: give --out FILE.zarr.")
    with cluster_client(scheduler) as client, \
            progress_callback("eigenvalues", enabled=not as_json and mu.size * len(theta) > 200_000) as cb:
        ds = stability_map(model, mu, theta, damped=damped, progress=cb,
                           store=out_path if stream else None, client=client, **fr)
        summary = {**stability_summary(ds), **friction_json(fr)}
    if out_path is not None and not stream:
        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..plotting.stability import fig2_plot

        save_figure(fig2_plot(ds), plot_path)
    if map_path is not None:
        from ..plotting.stability import stability_map_plot

        crit = critical_friction_curve(model, theta, damped=damped, **fr) if len(theta) <= 2001 else None
        save_figure(stability_map_plot(ds, critical=crit), map_path)
    if as_json:
        emit_json(summary)
        return
    click.echo(f"model: {model.kind} ({'damped' if damped else 'undamped'}), "
               f"{summary['grid_points']} grid points")
    if fr:
        click.echo(f"friction: {fr['friction'].describe()} at sliding speed {fr['speed']:g} m/s")
    click.echo(f"unstable fraction: {summary['unstable_fraction']:.4f}")
    click.echo(f"max growth rate:   {summary['max_growth_rate']:.6g} 1/s")
    if summary["unstable_omega_rad_s"] is None:
        click.echo("no unstable point on this grid")
    else:
        lo, hi = summary["unstable_omega_rad_s"]
        flo, fhi = summary["unstable_frequency_hz"]
        click.echo(f"unstable mode frequency: {lo:.1f}-{hi:.1f} rad/s ({flo:.1f}-{fhi:.1f} Hz)")
    for label, path in (("dataset", out_path), ("figure", plot_path), ("map", map_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")


def _stability_fe(ctx, model, fe, mu_spec, theta_spec, stribeck_spec, scheduler, map_path, as_json, out_path,
                  plot_path) -> None:
    """``squealkit stability`` on an FE model: disc speed x friction."""
    import numpy as np

    from .._validation import InputError, parse_range
    from ..io import save_dataset, save_figure
    from ..scale import cluster_client
    from ..stability import fe_stability_map, stability_summary

    if stribeck_spec is not None:
        raise InputError("--stribeck does not apply to FE models yet.")
    default = click.core.ParameterSource.DEFAULT
    mu = [model.mu_ref] if ctx.get_parameter_source("mu_spec") == default else parse_range("--mu", mu_spec)
    theta_deg = [0.0] if ctx.get_parameter_source("theta_spec") == default else parse_range("--theta", theta_spec)
    if len(theta_deg) != 1 or abs(theta_deg[0]) >= 90.0:
        raise InputError(f"--theta {theta_spec!r}: an FE model takes one angle strictly between -90 and 90 deg.")
    n_pts = len(fe["rpm"]) * len(mu)
    with cluster_client(scheduler) as client, \
            progress_callback("eigenvalues", enabled=not as_json and n_pts > 200) as cb:
        ds = fe_stability_map(model, fe["rpm"], mu, math.radians(float(theta_deg[0])), method=fe["method"],
                              band=fe["band"], n_modes=fe["n_modes"], progress=cb, client=client)
    summary = stability_summary(ds)
    valid = np.isfinite(ds["residual"].values)
    summary.update(rpm_range=[float(ds.rpm.min()), float(ds.rpm.max())], method=ds.attrs["method"],
                   band_hz=ds.attrs["band_hz"], n_dof=model.n_dof,
                   untrusted_fraction=float(np.mean(~ds["trusted"].values[valid])) if valid.any() else 0.0)
    if out_path is not None:
        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..plotting.fe import fe_growth_plot

        save_figure(fe_growth_plot(ds), plot_path)
    if map_path is not None:
        from ..plotting.fe import fe_map_plot

        save_figure(fe_map_plot(ds), map_path)
    if as_json:
        emit_json(summary)
        return
    band = summary["band_hz"]
    click.echo(f"model: fe, {model.n_dof} DOFs ({model.source or 'matrices'}), method {summary['method']}, "
               f"band {'all modes' if band == 'all' else f'{band[0]:g}-{band[1]:g} Hz'}, "
               f"{summary['grid_points']} grid points (rpm x mu)")
    click.echo(f"unstable fraction: {summary['unstable_fraction']:.4f}")
    click.echo(f"max growth rate:   {summary['max_growth_rate']:.6g} 1/s")
    undecided = summary.get("indeterminate_fraction") or 0.0
    if summary["unstable_frequency_hz"] is None:
        click.echo("no point proven unstable on this grid" if undecided else "no unstable point on this grid")
    else:
        flo, fhi = summary["unstable_frequency_hz"]
        click.echo(f"unstable mode frequency: {flo:.6g}-{fhi:.6g} Hz")
    if undecided:
        click.echo(f"indeterminate: {undecided:.1%} of the grid points (an eigenpair that fails the residual "
                   "check could be unstable: use --method sparse, or pod, or a larger --modes)")
    if summary["untrusted_fraction"]:
        click.echo(f"warning: {summary['untrusted_fraction']:.1%} of the eigenpairs fail the residual check")
    for label, path in (("dataset", out_path), ("figure", plot_path), ("map", map_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")
