"""``squealkit simulate``: transient response with disc surface run-out (paper section 4)."""

from __future__ import annotations

from pathlib import Path

import click
import xarray as xr

from .._validation import InputError, parse_range, validate_finite
from ._options import (
    RUNOUT_WAVELENGTH,
    SRO_AMPLITUDE_ONE,
    NumberOrRange,
    build_model_from_options,
    check_output_suffix,
    emit_json,
    friction_options,
    model_options,
    output_options,
    parse_stribeck,
    progress_callback,
    scheduler_option,
)


@click.command()
@model_options
@click.option("--mu", "mu_spec", default="0.4", show_default=True, type=NumberOrRange(),
              help="Friction coefficient; START:STOP:N runs a batch of N runs (needs --out).")
@click.option(
    "--sro", type=click.Choice(["sine", "file", "random", "none"]), default="sine", show_default=True,
    help="Disc surface run-out profile.",
)
@click.option("--sro-amplitude", type=SRO_AMPLITUDE_ONE, default=0.08e-3, show_default=True,
              help="Sine amplitude q0, or RMS of random roughness [m], or with a unit: '80 um'.")
@click.option("--sro-wavelength", type=RUNOUT_WAVELENGTH, default=1e-3, show_default=True,
              help="Sine wavelength lambda, or longest random wavelength [m].")
@click.option("--sro-file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Profile for --sro file: two columns, position [m] and q [m].")
@click.option("--theta", "theta_deg", default=None, type=NumberOrRange(single=True, needs="one run-out incline"),
              help="Hold the run-out incline fixed at this angle in DEGREES on a mean-flat disc (q = 0), the "
                   "frozen slope of the stability map; replaces --sro.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of random roughness and perturbation.")
@click.option("--perturbation", type=float, default=0.0, show_default=True,
              help="RMS of a random initial displacement [m] (a flat disc needs one to leave equilibrium).")
@click.option("--contact", type=click.Choice(["linear", "nonlinear"]), default="linear", show_default=True,
              help="linear: the paper's eqs. 1-4 (with --stribeck: permanent contact, friction mu(w) N); "
              "nonlinear: loss of contact and velocity-sign friction.")
@friction_options
@click.option("--duration", type=float, default=0.15, show_default=True, help="Simulated time [s].")
@click.option("--fs", type=float, default=40_000.0, show_default=True,
              help="Output sample rate [Hz]. The outputs are sampled from the integrator, not filtered: below "
              "twice the model's highest natural frequency a warning says so (the run goes on, for a quick look "
              "at slow content; the integration step does not depend on --fs).")
@click.option("--method", type=click.Choice(["dopri5", "rosenbrock", "rk4"]), default="dopri5", show_default=True,
              help="dopri5: Dormand-Prince 5(4) with error control, located contact and stick/slip events; "
              "rosenbrock: Rodas4 (linearly implicit, analytic Jacobian) for stiff friction (small v_reg), "
              "same events; rk4: fixed-step classical RK4.")
@click.option("--rtol", type=float, default=1e-8, show_default=True,
              help="Relative tolerance of dopri5 and rosenbrock.")
@scheduler_option
@output_options()
def simulate(preset, config, sets, mu_spec, sro, sro_amplitude, sro_wavelength, sro_file, theta_deg, seed,
             perturbation, contact, stribeck_spec, speed, duration, fs, method, rtol, scheduler, as_json, out_path,
             plot_path) -> None:
    """Simulate the time response of a model driven by disc surface run-out.

    \b
    Example (paper Fig. 4: mu = 0.4, q0 = 0.08 mm, lambda = 1 mm, v = 0.02 m/s):
      squealkit simulate --mu 0.4 --sro sine --sro-amplitude 8e-5 \\
          --sro-wavelength 1e-3 --speed 0.02 --duration 0.15 --json --plot fig4.png
    Smooth disc (paper Fig. 3) with a small seeded start perturbation:
      squealkit simulate --sro none --perturbation 1e-9 --plot fig3.png
    A batch of 64 runs over mu, written run block by run block to zarr, on a cluster:
      squealkit simulate --mu 0.2:0.8:64 --out batch.zarr --scheduler local --json
    A fixed incline of 2 deg at mu = 0.35 (the stability map's frozen slope), from a perturbation:
      squealkit simulate --mu 0.35 --theta 2 --perturbation 1e-9 --duration 0.05 --json
    Friction falling with speed (Stribeck) at a low sliding speed, smooth disc:
      squealkit simulate --mu 0.2 --sro none --stribeck 0.6,0.001 --speed 0.0015 \\
          --perturbation 1e-14 --duration 0.01 --json

    \b
    With --out the run is written block by block as it is computed (memory
    bounded whatever --duration); without --out it is held in memory, and a
    run that will not fit is refused before it starts.

    \b
    Batch --json keys: mu, status, max_growth_rate [1/s] (largest frozen-time
    sigma(t)), peak_acceleration_m_s2 (per DOF), tensile_fraction (share of time
    the linear contact pulled), lists with one entry per run. A single run's --json
    also has method, steps, events, tensile_fraction and min_normal_force [N].
    """
    import math

    import numpy as np

    from ..transient import ConstantIncline, Contact, RandomRoughness, SampledProfile, SineRunOut, Smooth
    from ..transient import simulate as run_simulation
    from ..transient.simulate import transient_summary

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    if duration is None or not duration > 0:
        raise InputError(f"Parameter duration={duration!r} s must be > 0.")
    model = build_model_from_options(preset, config, sets)
    law = parse_stribeck(stribeck_spec)
    if law is not None:
        kw = {"mu_static": law.mu_static, "v_stribeck": law.v_stribeck}
        contact = Contact(**kw) if contact == "linear" else Contact.nonlinear(**kw)
    rng = np.random.default_rng(seed)
    if theta_deg is not None:
        if click.get_current_context().get_parameter_source("sro") != click.core.ParameterSource.DEFAULT:
            raise InputError(f"--theta {theta_deg:g} holds a fixed incline on a mean-flat disc: give it without --sro.")
        theta_deg = validate_finite("--theta", theta_deg)
        if abs(theta_deg) >= 90.0:
            raise InputError(f"--theta {theta_deg!r}: the angle must lie strictly between -90 and 90 deg.")
        profile = ConstantIncline.from_theta(math.radians(theta_deg))
    elif sro == "sine":
        profile = SineRunOut(sro_amplitude, sro_wavelength)
    elif sro == "file":
        if sro_file is None:
            raise InputError("--sro file needs --sro-file PATH (two columns: position [m], q [m]).")
        profile = SampledProfile.from_file(sro_file)
    elif sro == "random":
        profile = RandomRoughness.draw(
            rms=sro_amplitude, wavelength_min=sro_wavelength / 10, wavelength_max=sro_wavelength, rng=rng
        )
    else:
        profile = Smooth()

    mu_all = parse_range("--mu", mu_spec)
    if mu_all.size > 1 or scheduler is not None:
        _batch(model, mu_all, profile, speed=speed, duration=duration, fs=fs, contact=contact,
               perturbation=perturbation, rng=rng, scheduler=scheduler, as_json=as_json, out_path=out_path,
               plot_path=plot_path, method=method, rtol=rtol)
        return
    mu = float(mu_all[0])
    kw = dict(mu=mu, profile=profile, speed=speed, duration=duration, fs=fs, contact=contact,
              perturbation=perturbation, rng=rng, method=method, rtol=rtol)
    with progress_callback("simulating", enabled=not as_json and duration * 1e6 > 2e5) as progress:
        if out_path is None:
            ds = run_simulation(model, progress=progress, **kw)
        else:
            # streamed block by block into the staged file: the memory does not grow with --duration
            from ..io import save_blocks
            from ..transient import simulate_blocks

            save_blocks(simulate_blocks(model, progress=progress, **kw), out_path)
    if out_path is not None:
        from ..io import written_path

        ds = _open_lazily(written_path(out_path))  # staged until the run ends
    if plot_path is not None:
        from .._validation import check_memory
        from ..io import save_figure
        from ..plotting.transient import fig3_plot, fig4_plot

        check_memory(8.0 * ds.sizes["time"] * (len(ds.data_vars) + 2) * 3, f"--plot of {ds.sizes['time']} samples",
                     "Plot a shorter --duration.")
        ds = ds.load()
        fig = fig3_plot(ds) if sro == "none" or theta_deg is not None else fig4_plot(ds)
        save_figure(fig, plot_path)
    summary = transient_summary(ds)
    ds.close()
    if as_json:
        emit_json(summary)
        return
    steps = f", {summary['steps']} steps, {summary['events']} events" if summary.get("steps") is not None else ""
    click.echo(f"status: {summary['status']} (t_stop = {summary['t_stop']:g} s, {summary['method']}, "
               f"largest step {summary['dt']:.3g} s{steps})")
    if summary.get("tensile_fraction"):
        click.echo(f"  the normal force was tensile {100 * summary['tensile_fraction']:.1f} % of the time ("
                   f"down to {summary['min_normal_force']:.4g} N): rerun with --contact nonlinear")
    for d, p in summary["peak"].items():  # type: ignore[union-attr]
        click.echo(f"  {d:<4} peak |a| = {p['acceleration_m_s2']:.4g} m/s^2, peak change = "
                   f"{p['displacement_change_m']:.4g} m")
    for st in summary["stages"][:10]:  # type: ignore[index]
        click.echo(f"  {st['stage']:<8} {st['t_start']:.4f}-{st['t_end']:.4f} s: rate {st['rate_per_s']:+.1f} 1/s "
                   f"(mean sigma {st['sigma_mean_per_s']:+.1f} 1/s)")



def _open_lazily(path: Path) -> xr.Dataset:
    """The written run, read piece by piece when summarised (bounded memory for any duration)."""
    if path.suffix.lower() == ".zarr":  # no index over time: it would load the whole time axis
        return xr.open_zarr(path, consolidated=False, create_default_indexes=False)
    return xr.open_dataset(path, engine="h5netcdf", chunks={"time": 1 << 16}, create_default_indexes=False)


def _batch(model, mu, profile, *, scheduler, as_json, out_path, plot_path, **kw) -> None:
    """Runs over a grid of mu, streamed to the --out store (on a Dask cluster with --scheduler)."""
    from ..scale import cluster_client
    from ..transient import simulate_batch

    if out_path is None:
        raise InputError("A batch (--mu START:STOP:N or --scheduler) needs --out FILE.zarr (or .nc without "
                         "--scheduler).")
    if plot_path is not None:
        raise InputError("--plot draws one run; leave it out for a batch.")
    stream = out_path.suffix.lower() == ".zarr"
    if scheduler is not None and not stream:
        raise InputError("--scheduler streams the batch to zarr: give --out FILE.zarr.")
    with cluster_client(scheduler) as client, progress_callback("runs", enabled=not as_json) as progress:
        ds = simulate_batch(model, mu=mu, profiles=profile, progress=progress, client=client,
                            store=out_path if stream else None, **kw)
        dofs = list(model.dof_names)
        red = {"max_growth_rate": ds["growth_rate"].max("time")}
        red.update({d: abs(ds[f"{d}_ddot"]).max("time") for d in dofs})
        r = xr.Dataset(red).compute()
        status = [str(x) for x in ds["status"].values]
    if not stream:
        from ..io import save_dataset

        save_dataset(ds, out_path)
    summary = {"mu": mu.tolist(), "status": status, "max_growth_rate": r["max_growth_rate"].values.tolist(),
               "peak_acceleration_m_s2": {d: r[d].values.tolist() for d in dofs},
               "tensile_fraction": [float(x) for x in ds["tensile_fraction"].values]}
    if as_json:
        emit_json(summary)
        return
    click.echo(f"{len(status)} runs, {status.count('diverged')} diverged; wrote {out_path}")
    click.echo("      mu  status     max sigma [1/s]  " + "  ".join(f"peak |{d}_ddot| [m/s^2]" for d in dofs))
    for i, m in enumerate(summary["mu"]):
        accel = "  ".join(f"{summary['peak_acceleration_m_s2'][d][i]:>20.4g}" for d in dofs)
        click.echo(f"  {m:6.3f}  {status[i]:<9}  {summary['max_growth_rate'][i]:>15.4g}  {accel}")
