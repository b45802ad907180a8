"""``squealkit modes``: complex mode shapes at one operating point, and the friction work."""

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
    model_options,
    note_damping,
    output_options,
)


@click.command()
@model_options
@click.option("--mu", type=NumberOrRange(single=True, needs="one friction coefficient"), default=None,
              help="Friction coefficient (or use --at-onset).")
@click.option("--theta", "theta_deg", default=0.0, show_default=True,
              type=NumberOrRange(single=True, needs="one run-out incline"), help="Run-out incline in DEGREES.")
@damping_option
@click.option("--at-onset", is_flag=True,
              help="Use the critical friction at this theta instead of --mu, and mark the mode that loses stability.")
@fe_options(rpm_help="Disc speed [rpm] (one value). FE models only.", single_rpm=True)
@click.option("--vtk", "vtk_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="FE models with a mesh: write the unstable mode shapes with the mesh (.vtu: real and imaginary "
              "parts; .pvd: the phase animation as a time series; needs meshio).")
@output_options()
def modes(preset, config, sets, mu, theta_deg, damped, at_onset, rpm_spec, band_spec, method, n_modes, vtk_path,
          as_json, out_path, plot_path) -> None:
    """Mode shapes at one friction and run-out incline: which motion squeals.

    Solves (lambda^2 M + lambda C + K(mu, tan theta)) phi = 0 for every mode's
    eigenvalue, shape (largest amplitude 1) and left eigenvector, and the
    energy per cycle that friction feeds into each mode against what damping
    removes: the net work has the sign of the growth rate sigma.

    \b
    Examples:
      squealkit modes --mu 0.6
      squealkit modes --at-onset --plot onset_mode.png
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

    \b
    FE models (model = "fe" in --config): the modes at one disc speed --rpm and
    --mu (default mu_ref; or --at-onset: mu_crit at that speed) in --eigen-band, with
    their backward errors; the table lists every unstable mode (then the least
    stable others, 12 rows at least) with its dominant component (the body of the
    mesh, or without a mesh the DOF, carrying most kinetic energy) and the
    friction work per cycle. --json keys: rpm, mu, theta_deg, verdict, method,
    n_dof, bodies, modes and unstable_modes (the unstable ones, most unstable
    first), each with eigenvalue [re, im], frequency_hz, growth_rate,
    damping_ratio, unstable, residual, dominant_component, kinetic_share,
    friction_work and net_work [J per cycle at 1 m largest amplitude; null for a
    real root]; the shapes go to --out FILE.nc (shape_real, shape_imag over dof x
    mode) and, with a mesh, --vtk (every unstable mode: real and imaginary parts,
    friction work per node; FILE.pvd: the phase animation as a ParaView time series).
      squealkit modes --config brake.toml --rpm 60 --mu 1.0 --out modes.nc
    """
    from .._validation import InputError, validate_finite
    from ..io import save_dataset, save_figure
    from ..stability import modes as modes_at
    from ..stability import modes_summary, onset_modes

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    if at_onset and mu is not None:
        raise InputError("Use either --mu or --at-onset.")
    theta_deg = validate_finite("--theta", theta_deg)
    if abs(theta_deg) >= 90.0:
        raise InputError(f"--theta {theta_deg!r}: the angle must lie strictly between -90 and 90 deg.")
    model = build_model_from_options(preset, config, sets, allow_fe=True)
    note_damping(model, damped)
    theta = math.radians(theta_deg)
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    if fe:
        return _modes_fe(model, fe, mu, theta, at_onset, vtk_path, as_json, out_path, plot_path)
    if vtk_path is not None:
        raise InputError("--vtk applies to FE models with a mesh only.")
    if not at_onset and mu is None:
        raise InputError("Missing friction: give --mu or --at-onset.")
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


def _modes_fe(model, fe, mu, theta, at_onset, vtk_path, as_json, out_path, plot_path) -> None:
    """``squealkit modes`` on an FE model at one disc speed."""
    import numpy as np

    from .._validation import InputError, validate_finite
    from ..fe.energy import mode_energy
    from ..io import save_dataset
    from ..stability import fe_critical_friction, fe_modes
    from ..stability.fe_sweep import modes_to_vtk

    if plot_path is not None:
        raise InputError("--plot is not available for FE modes yet; use --out FILE.nc or --vtk.")
    check_output_suffix(vtk_path, (".vtu", ".pvd"), "--vtk")
    if vtk_path is not None:  # before the solve, not after it
        from ..fe.surface import dof_places

        dof_places(model)  # no mesh, or DOFs that are not on it: one line
    if len(fe["rpm"]) != 1:
        raise InputError("modes takes one disc speed: --rpm RPM.")
    rpm = float(fe["rpm"][0])
    kw = {"method": fe["method"], "band": fe["band"], "n_modes": fe["n_modes"]}
    if at_onset:
        crit = fe_critical_friction(model, [rpm], theta=theta, **kw)
        status = crit.status.attrs["flag_meanings"].split()[int(crit.status.values[0])]
        if status != "onset":
            raise InputError(f"No onset at {rpm:g} rpm: {status} for mu in [0, 2 mu_ref].")
        mu = float(crit.mu_critical.values[0])
    mu = model.mu_ref if mu is None else validate_finite("--mu", mu)
    ds = fe_modes(model, rpm, mu, theta, **kw)
    energy = mode_energy(model, ds)
    if out_path is not None:
        save_dataset(ds, out_path)
    if vtk_path is not None:
        modes_to_vtk(ds.isel(mode=np.flatnonzero(ds.unstable.values)), model, vtk_path, energy=energy)
    rows = [_fe_row(ds, energy, k, model.mesh is not None) for k in range(ds.sizes["mode"])]
    unstable = sorted((r for r in rows if r["unstable"]), key=lambda r: -r["growth_rate"])
    if as_json:
        emit_json({"rpm": rpm, "mu": mu, "theta_deg": math.degrees(theta), "verdict": ds.attrs["verdict"],
                   "method": ds.attrs["method"], "n_dof": model.n_dof, "bodies": energy.attrs["bodies"],
                   "modes": rows, "unstable_modes": unstable})
        return
    click.echo(f"model: fe, {model.n_dof} DOFs, {rpm:g} rpm, mu = {mu:g}, theta = {math.degrees(theta):g} deg, "
               f"method {ds.attrs['method']}: {ds.attrs['verdict']}, {len(rows)} modes, {len(unstable)} unstable")
    if model.mesh is not None:
        click.echo(f"bodies: {energy.attrs['bodies']}")
    stable = sorted((r for r in rows if not r["unstable"]), key=lambda r: -r["growth_rate"])
    shown = unstable + stable[:max(0, _FE_ROWS - len(unstable))]
    click.echo(f"{'mode':>5} {'f [Hz]':>12} {'sigma [1/s]':>13} {'zeta':>10} {'W_friction [J]':>15} {'residual':>9}"
               "  dominant component (kinetic energy share)")
    for r in shown:
        work = "-" if r["friction_work"] is None else f"{r['friction_work']:.4g}"
        click.echo(f"{r['mode']:5d} {r['frequency_hz']:12.6g} {r['growth_rate']:13.6g} {r['damping_ratio']:10.3g} "
                   f"{work:>15} {r['residual']:9.2g}  {r['dominant_component']} ({_pct(r['kinetic_share'])})"
                   + ("  <- UNSTABLE" if r["unstable"] else ""))
    if len(stable) > len(shown) - len(unstable):
        click.echo(f"(every unstable mode listed; {len(stable) - (len(shown) - len(unstable))} more stable modes in "
                   "--json or --out)")
    for label, path in (("dataset", out_path), ("mode shapes", vtk_path)):
        if path is not None:
            click.echo(f"wrote {label}: {path}")


#: Rows of the FE modes table: every unstable mode, then the least stable others up to this many.
_FE_ROWS = 12


def _fe_row(ds, energy, k: int, meshed: bool) -> dict:
    """One FE mode as plain Python: eigenvalue, residual, dominant component, friction work."""
    def finite(x) -> float | None:
        v = float(x)
        return v if math.isfinite(v) else None

    if meshed:
        component = str(energy.dominant_body.values[k])
        lead = component.split(" + ")[0]
        kinetic = float(energy.kinetic_share.isel(mode=k).sel(body=lead)) if lead else float("nan")
    else:  # no mesh, no bodies: the DOF that moves most
        component, kinetic = str(energy.dominant_dof.values[k]), float(energy.dominant_dof_share.values[k])
    return {"mode": int(k), "eigenvalue": [float(ds.eigenvalue_real[k]), float(ds.eigenvalue_imag[k])],
            "frequency_hz": float(ds.frequency_hz[k]), "growth_rate": float(ds.growth_rate[k]),
            "damping_ratio": float(ds.damping_ratio[k]), "unstable": bool(ds.unstable[k]),
            "residual": float(ds.residual[k]), "dominant_component": component,
            "kinetic_share": kinetic if math.isfinite(kinetic) else None,
            "friction_work": finite(energy.friction_work[k]), "net_work": finite(energy.net_work[k])}


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x:.0%}"
