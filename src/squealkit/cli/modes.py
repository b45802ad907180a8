"""``squealkit modes``: complex mode shapes at one operating point, and the friction work."""

from __future__ import annotations

import math

import click

from ._options import build_model_from_options, check_output_suffix, emit_json, model_options, output_options


@click.command()
@model_options
@click.option("--mu", type=float, default=None, help="Friction coefficient (or use --at-onset).")
@click.option("--theta", "theta_deg", default=0.0, show_default=True, type=float, metavar="DEG",
              help="Run-out incline in DEGREES.")
@click.option("--damped", is_flag=True, help="Include the damping matrix (the paper's sweep, eq. 7, is undamped).")
@click.option("--at-onset", is_flag=True,
              help="Use the critical friction at this theta instead of --mu, and mark the mode that loses stability.")
@output_options()
def modes(preset, config, sets, mu, theta_deg, damped, at_onset, as_json, out_path, plot_path) -> None:
    """Mode shapes at one friction and run-out incline: which motion squeals.

    Solves (lambda^2 M + lambda C + K(mu, tan theta)) phi = 0 for every mode's
    eigenvalue, shape (largest amplitude 1) and left eigenvector, and the
    energy per cycle that friction feeds into each mode against what damping
    removes: the net work has the sign of the growth rate sigma.

    \b
    Examples:
      squealkit modes --mu 0.6
      squealkit modes --at-onset --damped --plot onset_mode.png
      squealkit modes --mu 0.3 --theta 4 --json
      squealkit modes --preset hoffmann2002 --mu 0.3 --out modes.nc

    \b
    --json keys: mu, theta_deg, tan_theta, damped, verdict, model, dof_names,
    mu_critical (with --at-onset) and modes, a list with per mode: eigenvalue
    [re, im] [1/s], frequency_hz, omega_rad_s, growth_rate [1/s], damping_ratio,
    unstable, real_root, dof_names, shape and left_shape ([re, im] per DOF,
    largest amplitude 1), participation (kinetic-energy share per DOF),
    modal_mass [kg], friction_work, damping_work, net_work [J per cycle at 1 m
    largest amplitude; null for a real root], loses_stability (--at-onset).
    --out FILE.nc stores the shapes as real and imaginary parts.
    """
    from .._validation import InputError, validate_finite
    from ..io import save_dataset, save_figure
    from ..stability import modes as modes_at
    from ..stability import modes_summary, onset_modes

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    if at_onset == (mu is not None):
        raise InputError("Use either --mu or --at-onset." if at_onset else "Missing friction: give --mu or --at-onset.")
    theta_deg = validate_finite("--theta", theta_deg)
    if abs(theta_deg) >= 90.0:
        raise InputError(f"--theta {theta_deg!r}: the angle must lie strictly between -90 and 90 deg.")
    model = build_model_from_options(preset, config, sets)
    theta = math.radians(theta_deg)
    if at_onset:
        ds = onset_modes(model, theta, damped=damped)
    else:
        ds = modes_at(model, validate_finite("--mu", mu), theta, damped=damped)
    if out_path is not None:
        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..plotting.modes import modes_plot

        save_figure(modes_plot(ds), plot_path)
    summary = modes_summary(ds)
    if as_json:
        emit_json(summary)
        return
    _print_table(model, summary)
    for label, path in (("dataset", out_path), ("figure", plot_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")


def _print_table(model, s: dict) -> None:
    where = f"mu_crit = {s['mu']:.6f} (onset)" if "mu_critical" in s else f"mu = {s['mu']:g}"
    click.echo(f"model: {model.kind} ({'damped' if s['damped'] else 'undamped'}), {where}, "
               f"theta = {s['theta_deg']:g} deg: {s['verdict']}")
    click.echo(f"{'mode':>4} {'f [Hz]':>10} {'sigma [1/s]':>12} {'zeta':>9} {'W_friction [J]':>15} {'W_net [J]':>10}"
               "  shape: amplitude@phase [deg]")
    for m in s["modes"]:
        amp = [math.hypot(*z) for z in m["shape"]]
        phase = [math.degrees(math.atan2(z[1], z[0])) for z in m["shape"]]
        phase = [180.0 if p <= -180.0 + 1e-6 else p for p in phase]  # (-180, 180]
        top = sorted(range(len(amp)), key=lambda i: -amp[i])[:3]
        dofs = ", ".join(f"{m['dof_names'][i]} {amp[i]:.3g}@{round(phase[i]):+d}" for i in top if amp[i] >= 1e-3)
        mark = "  <- UNSTABLE" if m["unstable"] else ("  <- loses stability" if m.get("loses_stability") else "")
        work = (f"{'-':>15} {'-':>10}" if m["real_root"] else f"{m['friction_work']:15.4g} {m['net_work']:10.4g}")
        click.echo(f"{m['mode']:4d} {m['frequency_hz']:10.2f} {m['growth_rate']:12.5g} {m['damping_ratio']:9.3g} "
                   f"{work}  {dofs}{mark}")
    click.echo("W: energy per cycle for the shape scaled to 1 m largest amplitude (scales with amplitude^2); "
               "W_net = friction - damping has the sign of sigma.")
