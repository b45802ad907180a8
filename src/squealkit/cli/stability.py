"""``squealkit stability``: complex eigenvalues over a grid of friction and run-out incline."""

from __future__ import annotations

import math
from pathlib import Path

import click

from ._options import (
    build_model_from_options,
    check_output_suffix,
    emit_json,
    friction_from_options,
    friction_json,
    friction_options,
    model_options,
    output_options,
    progress_callback,
    scheduler_option,
    writable,
)


@click.command()
@model_options
@click.option("--mu", "mu_spec", default="0:0.8:81", show_default=True, metavar="START:STOP:N",
              help="Friction coefficients: N points from START to STOP, or one number.")
@click.option("--theta", "theta_spec", default="-8:8:81", show_default=True, metavar="START:STOP:N",
              help="Run-out incline angles in DEGREES: N points from START to STOP, or one number.")
@click.option("--damped", is_flag=True, help="Include the damping matrix (the paper's sweep, eq. 7, is undamped).")
@friction_options
@click.option("--plot-map", "map_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              callback=writable,
              help="Also write a stability map with the critical-friction curve (.png/.svg/.pdf).")
@scheduler_option
@output_options()
@click.pass_context
def stability(ctx, preset, config, sets, mu_spec, theta_spec, damped, stribeck_spec, speed, map_path, scheduler,
              as_json, out_path, plot_path) -> None:
    """Complex eigenvalues over friction mu and SRO incline theta (paper §3, Fig. 2).

    Solves M x'' + K(mu, tan theta) x = 0 (or with C, --damped) at every grid
    point, tracks the modes across the grid and reports where they lock in and
    grow. Prints a summary; --json for machine-readable output.

    \b
    Examples:
      squealkit stability --plot fig2.png
      squealkit stability --mu 0:0.8:401 --theta -8:8:401 --out map.nc --json
      squealkit stability --preset hoffmann2002 --mu 0:0.5:201 --theta 0
      squealkit stability --set alpha_deg=3 --damped --plot-map map.png
      squealkit stability --mu 0:0.8:20001 --theta -8:8:20001 --out big.zarr --scheduler local
      squealkit stability --damped --stribeck 0.6,0.001 --speed 0.0015 --mu 0:0.8:81 --theta 0

    \b
    With --stribeck the friction falls (or rises) with the sliding speed; the
    model is linearised about steady sliding at --speed: mu is the kinetic
    coefficient, K uses mu(speed), and the slope dmu/dv adds the damping
    dmu/dv N0 D (N0 the static contact force): falling friction is negative
    damping, a second way to squeal beside mode coupling. It is added with or
    without --damped. Needs a model with one point contact.

    \b
    With --out FILE.zarr the map is written tile by tile (blocks of mu rows), never held
    whole in memory; --scheduler ADDRESS computes the tiles on a Dask cluster (the
    store must be on a file system the workers share) with identical numbers.

    \b
    --json keys: unstable_omega_rad_s and unstable_frequency_hz ([min, max] of the
    most unstable mode's frequency over unstable points, or null),
    unstable_fraction, lock_in_fraction, max_growth_rate [1/s], grid_points,
    mu_range, theta_deg_range, damped; with --stribeck also stribeck
    ({mu_static, v_stribeck}) and speed [m/s].
    """
    from .._validation import InputError, parse_range
    from ..io import save_dataset, save_figure
    from ..scale import cluster_client
    from ..stability import critical_friction_curve, stability_map, stability_summary

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    check_output_suffix(map_path, (".png", ".svg", ".pdf"), "--plot-map")
    model = build_model_from_options(preset, config, sets)
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
