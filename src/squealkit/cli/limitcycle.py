"""``squealkit limitcycle``: squeal limit cycles over friction or run-out slope by harmonic balance."""

from __future__ import annotations

import math
from pathlib import Path

import click

from ._options import (
    NumberOrRange,
    build_model_from_options,
    check_output_suffix,
    emit_json,
    model_options,
    output_options,
)


@click.command()
@model_options
@click.option("--mu", "mu_spec", default=None, type=NumberOrRange(),
              help="Friction range followed by the branch (N sets the nominal step (STOP - START)/(N - 1)); "
                   "one value with a --theta range.  [default: 0.3:0.8:51, or 0.5 with a --theta range]")
@click.option("--theta", "theta_spec", default="0", show_default=True, type=NumberOrRange(),
              help="Run-out incline in DEGREES (a frozen slope tan(theta)); a range START:STOP:N follows the "
                   "branch over theta at the one --mu value instead (mu_e = mu + tan(theta) acts like friction).")
@click.option("--harmonics", type=click.IntRange(min=1, max=200), default=10, show_default=True,
              help="Harmonics H of every cycle (the change of the amplitude at 2H is reported).")
@click.option("--harmonics-tol", type=click.FloatRange(min=0.0, min_open=True), default=None, metavar="TOL",
              help="Adapt H: double it (from --harmonics, up to 80) until the amplitudes change by at most TOL "
                   "(relative, e.g. 0.01) at 2H; a warning if they never do.")
@click.option("--contact", type=click.Choice(["nonlinear"]), default="nonlinear", show_default=True,
              help="Contact law: loss of contact and velocity-sign friction (the transient's law).")
@click.option("--stribeck", "stribeck_spec", default=None, metavar="MU_STATIC,V_STRIBECK",
              help="Stribeck friction mu(w) = mu + (MU_STATIC - mu) exp(-abs(w) / V_STRIBECK), e.g. 0.6,0.01.")
@click.option("--speed", type=float, default=0.02, show_default=True, help="Sliding speed v [m/s].")
@click.option("--stability", type=click.Choice(["monodromy", "hill"]), default="monodromy", show_default=True,
              help="Floquet multipliers of each cycle: monodromy matrix (compiled RK4) or Hill's method "
                   "(eigenvalues of the harmonic-balance Jacobian, symmetry criterion).")
@click.option("--radiation-factor", type=float, default=None, metavar="PA_PER_M_S",
              help="Sound pressure per unit velocity [Pa/(m/s)] at the listener: adds the level in dB SPL "
                   "(re 20 uPa) of each cycle from the velocity of --level-dof.")
@click.option("--transfer", "transfer_path", type=click.Path(path_type=Path, dir_okay=False), default=None,
              metavar="FILE.csv",
              help="Measured transfer, the magnitude of p/v [Pa/(m/s)] against frequency [Hz] (two CSV columns), "
                   "interpolated at each harmonic of the cycle: the level in dB SPL instead of --radiation-factor.")
@click.option("--level-dof", default=None, metavar="NAME",
              help="DOF whose velocity radiates (default the first DOF: the pin's x1).")
@output_options()
def limitcycle(preset, config, sets, mu_spec, theta_spec, harmonics, harmonics_tol, contact, stribeck_spec, speed,
               stability, radiation_factor, transfer_path, level_dof, as_json, out_path, plot_path) -> None:
    """How loud: squeal limit cycles over friction or run-out slope (harmonic balance + continuation).

    Starts at the Hopf point (the damped critical friction, onset frequency
    and mode shape), follows the branch of limit cycles in mu by
    pseudo-arclength continuation with the transient's nonlinear contact
    (loss of contact, velocity-sign friction), and reports per point the
    amplitude of every DOF (half the peak-to-peak over one period), the
    frequency, the fraction of the period without contact and the stability
    (Floquet multipliers). Also the first Lyapunov coefficient at onset
    (supercritical: soft onset; subcritical: hard onset with hysteresis),
    folds and the hysteresis range. With a --theta range the branch is
    followed over the run-out incline at one friction value instead, from the
    incline where squeal sets in. With --radiation-factor or --transfer each
    cycle gets its sound pressure level.

    \b
    Examples:
      squealkit limitcycle --mu 0.3:0.8:51 --json
      squealkit limitcycle --mu 0.3:0.8:51 --harmonics 15 --plot branch.png --out branch.nc
      squealkit limitcycle --mu 0.3:0.8:26 --theta 2
      squealkit limitcycle --mu 0.35 --theta -8:8:33 --stability hill
      squealkit limitcycle --mu 0.3:0.8:51 --radiation-factor 400 --level-dof x1 --json

    \b
    --json keys: parameter (mu or theta), mu (list; one value over theta),
    theta_deg (one value; the list over theta), frequency_hz, amplitude (DOF
    name -> list [m]), stable, contact_loss_fraction, hopf (mu, frequency_hz,
    lyapunov_coefficient, kind, kind_from; theta_deg over theta), folds (list of
    mu, or of theta_deg), hysteresis_mu (or hysteresis_theta_deg: [start, end]
    or []), harmonics, harmonics_change, stability_method, stop_reason,
    contact; with a level: level_db (list, dB SPL re 20 uPa), level_dof,
    level_from.
    """
    from .._validation import InputError, parse_range
    from ..nonlinear import (
        limit_cycle_branch,
        limit_cycle_branch_slope,
        limit_cycle_summary,
        read_transfer_csv,
        sound_level,
    )
    from ..transient import Contact
    from ._options import parse_stribeck

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    if radiation_factor is not None and transfer_path is not None:
        raise InputError("Give --radiation-factor or --transfer, not both.")
    if level_dof is not None and radiation_factor is None and transfer_path is None:
        raise InputError("--level-dof needs --radiation-factor or --transfer.")
    model = build_model_from_options(preset, config, sets)
    theta = parse_range("--theta", theta_spec)
    over_theta = theta.size > 1
    mu = parse_range("--mu", mu_spec if mu_spec is not None else ("0.5" if over_theta else "0.3:0.8:51"))
    if over_theta and mu.size != 1:
        raise InputError(f"--theta {theta_spec!r} is a range: give one friction value with --mu (got {mu_spec!r}).")
    if not over_theta and mu.size < 2:
        raise InputError(f"--mu {mu_spec!r} must be a range START:STOP:N with N >= 2 (or give --theta as a range).")
    if not (abs(theta) < 90.0).all():
        raise InputError(f"--theta {theta_spec!r} must lie strictly between -90 and 90 deg.")
    transfer = read_transfer_csv(transfer_path) if transfer_path is not None else None
    if level_dof is not None and level_dof not in model.dof_names:
        raise InputError(f"--level-dof {level_dof!r} is not a DOF of this model; choose one of "
                         f"{', '.join(model.dof_names)}.")
    law = parse_stribeck(stribeck_spec)
    ct = Contact.nonlinear() if law is None else Contact.nonlinear(mu_static=law.mu_static,
                                                                   v_stribeck=law.v_stribeck)
    if over_theta:
        t = [math.tan(math.radians(float(v))) for v in (theta.min(), theta.max())]
        ds = limit_cycle_branch_slope(model, t, mu=float(mu[0]), contact=ct, speed=speed, harmonics=harmonics,
                                      n_points=theta.size, stability=stability, harmonics_tol=harmonics_tol)
    else:
        ds = limit_cycle_branch(model, (float(mu.min()), float(mu.max())), theta=math.radians(float(theta[0])),
                                contact=ct, speed=speed, harmonics=harmonics, n_points=mu.size, stability=stability,
                                harmonics_tol=harmonics_tol)
    if radiation_factor is not None or transfer is not None:
        ds = sound_level(ds, radiation_factor=radiation_factor, transfer=transfer, dof=level_dof)
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
    where = (f"theta = {h['theta_deg']:.4f} deg at mu = {h['mu']:g}" if over_theta else f"mu = {h['mu']:.6f}")
    click.echo(f"Hopf point: {where}, {h['frequency_hz']:.2f} Hz, l1 = {h['lyapunov_coefficient']:.4g} "
               f"-> {h['kind']} (from {h['kind_from']})")
    fixed = f"mu = {out['mu']:g}" if over_theta else f"theta = {out['theta_deg']:g} deg"
    adaptive = ""
    if "harmonics_tol" in out:
        adaptive = (f", adapted to tol {out['harmonics_tol']:g}: "
                    + ("converged" if out["harmonics_converged"] else "NOT converged"))
    click.echo(f"contact: {out['contact']}; {fixed}; H = {out['harmonics']} "
               f"(amplitude change at 2H: {out['harmonics_change']:.2g}{adaptive}); "
               f"stability: {out['stability_method']}")
    dofs = list(out["amplitude"])
    xs = out["theta_deg"] if over_theta else out["mu"]
    level = "level_db" in out
    click.echo(f"{'theta' if over_theta else 'mu':>9} {'f [Hz]':>9} " + " ".join(f"{d + ' [m]':>11}" for d in dofs)
               + "  loss  stable" + ("  L [dB]" if level else ""))
    for i, x in enumerate(xs):
        amps = " ".join(f"{out['amplitude'][d][i]:11.4g}" for d in dofs)
        click.echo(f"{x:9.5f} {out['frequency_hz'][i]:9.2f} {amps} {out['contact_loss_fraction'][i]:5.2f}  "
                   f"{'yes' if out['stable'][i] else ' no'}" + (f"  {out['level_db'][i]:7.1f}" if level else ""))
    hyst = out.get("hysteresis_theta_deg" if over_theta else "hysteresis_mu")
    click.echo(f"folds at {'theta' if over_theta else 'mu'} = {out['folds'] or 'none'}; hysteresis: {hyst or 'none'}")
    if level:
        click.echo(f"level: dB SPL re 20 uPa from the velocity of {out['level_dof']} with the {out['level_from']}")
