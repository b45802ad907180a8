"""``squealkit limitcycle``: squeal limit cycles over friction by harmonic balance and continuation."""

from __future__ import annotations

import math

import click

from ._options import build_model_from_options, check_output_suffix, emit_json, model_options, output_options


@click.command()
@model_options
@click.option("--mu", "mu_spec", default="0.3:0.8:51", show_default=True, metavar="START:STOP:N",
              help="Friction range followed by the branch; N sets the nominal step (STOP - START)/(N - 1).")
@click.option("--harmonics", type=click.IntRange(min=1, max=200), default=10, show_default=True,
              help="Harmonics H of every cycle (the change of the amplitude at 2H is reported).")
@click.option("--contact", type=click.Choice(["nonlinear"]), default="nonlinear", show_default=True,
              help="Contact law: loss of contact and velocity-sign friction (the transient's law).")
@click.option("--theta", "theta_deg", type=float, default=0.0, show_default=True,
              help="Run-out incline in DEGREES (a frozen slope tan(theta)).")
@click.option("--stribeck", "stribeck_spec", default=None, metavar="MU_STATIC,V_STRIBECK",
              help="Stribeck friction mu(w) = mu + (MU_STATIC - mu) exp(-abs(w) / V_STRIBECK), e.g. 0.6,0.01.")
@click.option("--speed", type=float, default=0.02, show_default=True, help="Sliding speed v [m/s].")
@output_options()
def limitcycle(preset, config, sets, mu_spec, harmonics, contact, theta_deg, stribeck_spec, speed, as_json, out_path,
               plot_path) -> None:
    """How loud: squeal limit cycles over friction (harmonic balance + continuation).

    Starts at the Hopf point (the damped critical friction, onset frequency
    and mode shape), follows the branch of limit cycles in mu by
    pseudo-arclength continuation with the transient's nonlinear contact
    (loss of contact, velocity-sign friction), and reports per point the
    amplitude of every DOF (half the peak-to-peak over one period), the
    frequency, the fraction of the period without contact and the stability
    (Floquet multipliers). Also the first Lyapunov coefficient at onset
    (supercritical: soft onset; subcritical: hard onset with hysteresis),
    folds and the hysteresis range.

    \b
    Examples:
      squealkit limitcycle --mu 0.3:0.8:51 --json
      squealkit limitcycle --mu 0.3:0.8:51 --harmonics 15 --plot branch.png --out branch.nc
      squealkit limitcycle --mu 0.3:0.8:26 --theta 2

    \b
    --json keys: mu, frequency_hz, amplitude (DOF name -> list [m]), stable,
    contact_loss_fraction, hopf (mu, frequency_hz, lyapunov_coefficient, kind,
    kind_from), folds (list of mu), hysteresis_mu ([start, end] or []),
    harmonics, harmonics_change, stop_reason, theta_deg, contact.
    """
    from .._validation import InputError, parse_range
    from ..nonlinear import limit_cycle_branch, limit_cycle_summary
    from ..transient import Contact
    from ._options import parse_stribeck

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    model = build_model_from_options(preset, config, sets)
    mu = parse_range("--mu", mu_spec)
    if mu.size < 2:
        raise InputError(f"--mu {mu_spec!r} must be a range START:STOP:N with N >= 2.")
    if not abs(theta_deg) < 90.0:
        raise InputError(f"--theta {theta_deg!r} must lie strictly between -90 and 90 deg.")
    law = parse_stribeck(stribeck_spec)
    ct = Contact.nonlinear() if law is None else Contact.nonlinear(mu_static=law.mu_static,
                                                                   v_stribeck=law.v_stribeck)
    ds = limit_cycle_branch(model, (float(mu.min()), float(mu.max())), theta=math.radians(theta_deg), contact=ct,
                            speed=speed, harmonics=harmonics, n_points=mu.size)
    if out_path is not None:
        from ..io import save_dataset

        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..io import save_figure
        from ..plotting.limitcycle import limitcycle_plot

        save_figure(limitcycle_plot(ds), plot_path)
    out = limit_cycle_summary(ds)
    if as_json:
        emit_json(out)
        return
    h = out["hopf"]
    click.echo(f"Hopf point: mu = {h['mu']:.6f}, {h['frequency_hz']:.2f} Hz, l1 = {h['lyapunov_coefficient']:.4g} "
               f"-> {h['kind']} (from {h['kind_from']})")
    click.echo(f"contact: {out['contact']}; theta = {out['theta_deg']:g} deg; H = {out['harmonics']} "
               f"(amplitude change at 2H: {out['harmonics_change']:.2g})")
    dofs = list(out["amplitude"])
    click.echo(f"{'mu':>9} {'f [Hz]':>9} " + " ".join(f"{d + ' [m]':>11}" for d in dofs) + "  loss  stable")
    for i, m in enumerate(out["mu"]):
        amps = " ".join(f"{out['amplitude'][d][i]:11.4g}" for d in dofs)
        click.echo(f"{m:9.5f} {out['frequency_hz'][i]:9.2f} {amps} {out['contact_loss_fraction'][i]:5.2f}  "
                   f"{'yes' if out['stable'][i] else 'no'}")
    click.echo(f"folds at mu = {out['folds'] or 'none'}; hysteresis: {out['hysteresis_mu'] or 'none'}")
