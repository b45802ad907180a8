"""``squealkit critical``: critical friction at a run-out incline, and its sensitivities."""

from __future__ import annotations

import math

import click

from ._options import (
    build_model_from_options,
    emit_json,
    friction_from_options,
    friction_json,
    friction_options,
    model_options,
)


@click.command()
@model_options
@click.option("--theta", "theta_spec", default="0", show_default=True, metavar="DEG|START:STOP:N",
              help="Run-out incline in DEGREES, or a range for a curve mu_crit(theta).")
@click.option("--damped", is_flag=True, help="Include the damping matrix.")
@friction_options
@click.option("--mu-max", default=2.0, show_default=True, type=float, help="Search friction up to this value.")
@click.option("--sensitivity", is_flag=True,
              help="Also report d mu_crit / d p and the elasticity for every model parameter "
              "(exact, from the eigenvectors at onset).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
@click.pass_context
def critical(ctx, preset, config, sets, theta_spec, damped, stribeck_spec, speed, mu_max, sensitivity,
             as_json) -> None:
    """Critical friction: where the brake first loses stability (paper §3, eq. 6).

    Finds every friction window in [0, --mu-max] where the brake is unstable (a
    scan, a search of every point where two modes come close in frequency or a
    growth rate peaks, so that windows much narrower than the scan are found,
    then bisection of each boundary to rounding level). mu_crit is the start of
    the first window; re-stabilisation at higher friction shows as a window
    that ends before --mu-max. Also the critical equivalent friction mu_e =
    mu_crit + tan(theta), which the paper predicts is nearly independent of
    theta.

    \b
    Examples:
      squealkit critical --theta 0 --json
      squealkit critical --theta -8:8:17
      squealkit critical --theta 0 --sensitivity
      squealkit critical --preset hoffmann2002
      squealkit critical --damped --stribeck 0.6,0.01 --speed 0.02

    \b
    With --stribeck MU_STATIC,V_STRIBECK friction depends on the sliding speed
    (--speed, m/s) and mu_crit is the kinetic coefficient at onset; see
    'squealkit stability --help'.

    \b
    --json keys (one theta): mu_critical, mu_e_critical, omega_rad_s,
    frequency_hz (of the mode that loses stability, at onset), theta_deg,
    status (onset | unstable_at_start | stable_in_range | indeterminate;
    unstable_at_start = unstable without friction, mu_crit then negative),
    unstable_intervals (list of [start, end]; a window open at --mu-max ends
    there), indeterminate_intervals (windows no verdict could be reached in,
    within rounding; usually empty), mu_max, damped;
    with --sensitivity a list "sensitivity" of {parameter, value, unit, dmu_dp,
    elasticity}; with --stribeck also stribeck ({mu_static, v_stribeck}) and
    speed [m/s]. A range of theta gives the same keys, each a list over theta.
    """
    from .._validation import InputError, parse_range
    from ..stability import critical_friction, critical_friction_curve, critical_friction_sensitivity

    model = build_model_from_options(preset, config, sets)
    fr = friction_from_options(ctx, stribeck_spec, speed)
    theta_deg = parse_range("--theta", theta_spec)
    if any(abs(t) >= 90.0 for t in theta_deg):
        raise InputError(f"--theta {theta_spec!r}: angles must lie strictly between -90 and 90 deg.")
    if theta_deg.size == 1:
        res = critical_friction(model, math.radians(float(theta_deg[0])), damped=damped, mu_max=mu_max, **fr)
        out = {**res.to_dict(), **friction_json(fr)}
        out.pop("theta")
        if sensitivity:
            out["sensitivity"] = critical_friction_sensitivity(model, res.theta, damped=damped, **fr)
        if as_json:
            emit_json(out)
            return
        click.echo(f"theta = {res.theta_deg:g} deg ({'damped' if damped else 'undamped'}): {res.status}")
        if fr:
            click.echo(f"  friction: {fr['friction'].describe()} at sliding speed {fr['speed']:g} m/s")
        click.echo(f"  mu_crit   = {res.mu_critical:.8f}")
        click.echo(f"  mu_e_crit = {res.mu_e_critical:.8f}   ({'mu(speed)' if fr else 'mu_crit'} + tan theta)")
        click.echo(f"  frequency = {res.omega_rad_s:.2f} rad/s = {res.frequency_hz:.2f} Hz at onset")
        windows = ", ".join(f"[{a:.6f}, {b:.6f}]" for a, b in res.unstable_intervals) or "none"
        click.echo(f"  unstable for mu in {windows}   (searched 0 to {mu_max:g})")
        if res.indeterminate_intervals:
            und = ", ".join(f"[{a:.6f}, {b:.6f}]" for a, b in res.indeterminate_intervals)
            click.echo(f"  undecided within rounding for mu in {und}")
        if sensitivity:
            click.echo("  sensitivity of mu_crit (elasticity = % change of mu_crit per % change of p):")
            for row in out["sensitivity"]:
                click.echo(f"    {row['parameter']:<8} {row['elasticity']:+9.4f}   d mu/dp = {row['dmu_dp']:+.4g} "
                           f"per {row['unit']}")
        return
    if sensitivity:
        raise InputError("--sensitivity needs a single --theta value.")
    ds = critical_friction_curve(model, [math.radians(t) for t in theta_deg], damped=damped, mu_max=mu_max, **fr)
    from ..stability import ONSET_STATUS

    def pairs(a):
        return [[float(lo), float(hi)] for lo, hi in a if math.isfinite(lo)]

    out = {
        "theta_deg": ds.theta_deg.values,
        "mu_critical": ds.mu_critical.values,
        "mu_e_critical": ds.mu_e_critical.values,
        "omega_rad_s": ds.omega_rad_s.values,
        "frequency_hz": ds.frequency_hz.values,
        "status": [ONSET_STATUS[int(s)] for s in ds.status.values],
        "unstable_intervals": [pairs(w) for w in ds.unstable_intervals.values],
        "indeterminate_intervals": [pairs(w) for w in ds.indeterminate_intervals.values],
        "mu_max": mu_max,
        "damped": damped,
        **friction_json(fr),
    }
    if as_json:
        emit_json(out)
        return
    click.echo(f"{'theta [deg]':>12} {'mu_crit':>12} {'mu_e_crit':>12} {'f [Hz]':>10}  unstable windows")
    for t, m, me, f, w in zip(out["theta_deg"], out["mu_critical"], out["mu_e_critical"], out["frequency_hz"],
                              out["unstable_intervals"], strict=True):
        windows = " ".join(f"[{a:.4f}, {b:.4f}]" for a, b in w) or "-"
        click.echo(f"{t:12.4g} {m:12.6f} {me:12.6f} {f:10.2f}  {windows}")
