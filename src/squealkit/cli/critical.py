"""``squealkit critical``: critical friction at a run-out incline, and its sensitivities."""

from __future__ import annotations

import math

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
)


def no_onset_text(status: str, mu_max: float) -> str:
    """What a missing mu_crit means, in words (the table's NaN cells)."""
    if status == "stable_in_range":
        return f"stable for every mu up to {mu_max:g} (no onset)"
    if status == "unstable_at_start":
        return f"unstable already at mu = 0, and at every mu down to -{mu_max:g}"
    if status == "indeterminate":
        return "undecided within rounding (see indeterminate_intervals in --json)"
    return ""


@click.command()
@model_options
@click.option("--theta", "theta_spec", default="0", show_default=True, type=NumberOrRange(),
              help="Run-out incline in DEGREES, or a range for a curve mu_crit(theta).")
@damping_option
@friction_options
@click.option("--mu-max", default=2.0, show_default=True, type=float, help="Search friction up to this value.")
@click.option("--sensitivity", is_flag=True,
              help="Also report d mu_crit / d p and the elasticity for every model parameter "
              "(exact, from the eigenvectors at onset).")
@fe_options()
@output_options()
@click.pass_context
def critical(ctx, preset, config, sets, theta_spec, damped, stribeck_spec, speed, mu_max, sensitivity,
             rpm_spec, band_spec, method, n_modes, as_json, out_path, plot_path) -> None:
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
      squealkit critical --undamped          # the paper's eq. 7 (no damping)
      squealkit critical --stribeck 0.6,0.01 --speed 0.02
      squealkit critical --theta -8:8:17 --out crit.nc --plot crit.png

    \b
    --out writes the curve (critical_friction_curve: mu_critical, mu_e_critical,
    frequency_hz, status and the unstable windows over theta) as netCDF or zarr;
    --plot draws mu_crit(theta) with every unstable friction window. Where no
    onset is found the table says why instead of printing NaN (stable for every
    mu searched, unstable already without friction, or undecided).

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

    \b
    FE models (model = "fe" in --config): mu_crit at each disc speed --rpm (one
    --theta): a scan of 41 friction values in [0, --mu-max], then bisection to 1e-6.
    --json keys: rpm, mu_critical, mu_e_critical, frequency_hz, status (lists over
    rpm), theta_deg, mu_max, method.
      squealkit critical --config brake.toml --rpm 60:240:4 --json
    """
    from .._validation import InputError, parse_range
    from ..stability import critical_friction, critical_friction_curve, critical_friction_sensitivity

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    model = build_model_from_options(preset, config, sets, allow_fe=True)
    note_damping(model, damped)
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    theta_deg = parse_range("--theta", theta_spec)
    if any(abs(t) >= 90.0 for t in theta_deg):
        raise InputError(f"--theta {theta_spec!r}: angles must lie strictly between -90 and 90 deg.")
    if fe:
        if stribeck_spec is not None or sensitivity or not damped or theta_deg.size != 1:
            raise InputError("For FE models critical takes one --theta, and no --stribeck, --sensitivity or "
                             "--undamped (damping is always included).")
        if out_path is not None or plot_path is not None:
            raise InputError("--out and --plot are for the small models; for FE models use 'squealkit stability "
                             "--config ... --out/--plot'.")
        return _critical_fe(model, fe, float(theta_deg[0]), mu_max, as_json)
    fr = friction_from_options(ctx, stribeck_spec, speed)
    thetas = [math.radians(float(t)) for t in theta_deg]
    if theta_deg.size == 1:
        res = critical_friction(model, thetas[0], damped=damped, mu_max=mu_max, **fr)
        if out_path is not None or plot_path is not None:
            import warnings

            with warnings.catch_warnings():  # the same search again, for the file: its warnings were shown
                warnings.simplefilter("ignore")
                _write(critical_friction_curve(model, thetas, damped=damped, mu_max=mu_max, **fr), out_path,
                       plot_path)
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
        if math.isfinite(res.mu_critical):
            click.echo(f"  mu_crit   = {res.mu_critical:.8f}")
            click.echo(f"  mu_e_crit = {res.mu_e_critical:.8f}   ({'mu(speed)' if fr else 'mu_crit'} + tan theta)")
        else:
            click.echo(f"  mu_crit: none, {no_onset_text(res.status, mu_max)}")
        if math.isfinite(res.frequency_hz):
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
        _echo_written(out_path, plot_path)
        return
    if sensitivity:
        raise InputError("--sensitivity needs a single --theta value.")
    ds = critical_friction_curve(model, thetas, damped=damped, mu_max=mu_max, **fr)
    _write(ds, out_path, plot_path)
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
    for t, m, me, f, w, st in zip(out["theta_deg"], out["mu_critical"], out["mu_e_critical"], out["frequency_hz"],
                                  out["unstable_intervals"], out["status"], strict=True):
        windows = " ".join(f"[{a:.4f}, {b:.4f}]" for a, b in w) or "none"
        if not math.isfinite(m):
            windows += f": {no_onset_text(st, mu_max)}"
        click.echo(f"{t:12.4g} {_num(m, 12, 6)} {_num(me, 12, 6)} {_num(f, 10, 2)}  {windows}")
    _echo_written(out_path, plot_path)


def _num(x: float, width: int, decimals: int) -> str:
    """A table cell: the number, or '-' where there is none (the row's words say why)."""
    return f"{x:{width}.{decimals}f}" if math.isfinite(x) else f"{'-':>{width}}"


def _write(ds, out_path, plot_path) -> None:
    """--out and --plot of the critical-friction curve, each written whole or not at all."""
    if out_path is not None:
        from ..io import save_dataset

        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..io import save_figure
        from ..plotting.stability import critical_plot

        save_figure(critical_plot(ds), plot_path)


def _echo_written(out_path, plot_path) -> None:
    for label, path in (("dataset", out_path), ("figure", plot_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")


def _critical_fe(model, fe, theta_deg: float, mu_max: float, as_json: bool) -> None:
    """``squealkit critical`` on an FE model: mu_crit at each disc speed."""
    from ..stability import ONSET_STATUS, fe_critical_friction

    ds = fe_critical_friction(model, fe["rpm"], mu_max=mu_max, theta=math.radians(theta_deg), method=fe["method"],
                              band=fe["band"], n_modes=fe["n_modes"])
    out = {
        "rpm": ds.rpm.values, "mu_critical": ds.mu_critical.values, "mu_e_critical": ds.mu_e_critical.values,
        "frequency_hz": ds.frequency_hz.values, "status": [ONSET_STATUS[int(s)] for s in ds.status.values],
        "theta_deg": theta_deg, "mu_max": mu_max, "method": ds.attrs["method"],
    }
    if as_json:
        emit_json(out)
        return
    click.echo(f"model: fe, {model.n_dof} DOFs, method {out['method']}, theta = {theta_deg:g} deg, "
               f"friction searched 0 to {mu_max:g}")
    click.echo(f"{'rpm':>10} {'mu_crit':>12} {'mu_e_crit':>12} {'f [Hz]':>12}  status")
    for r, m, me, f, st in zip(out["rpm"], out["mu_critical"], out["mu_e_critical"], out["frequency_hz"],
                               out["status"], strict=True):
        words = f": {no_onset_text(st, mu_max)}" if not math.isfinite(m) and no_onset_text(st, mu_max) else ""
        click.echo(f"{r:10.4g} {_num(m, 12, 6)} {_num(me, 12, 6)} {_num(f, 12, 2)}  {st}{words}")
