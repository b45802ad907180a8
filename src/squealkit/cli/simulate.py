"""``squealkit simulate``: transient response with disc surface run-out (paper section 4)."""

from __future__ import annotations

from pathlib import Path

import click

from .._validation import InputError
from ._options import (
    build_model_from_options,
    check_output_suffix,
    emit_json,
    model_options,
    output_options,
    progress_callback,
)


@click.command()
@model_options
@click.option("--mu", type=float, default=0.4, show_default=True, help="Friction coefficient.")
@click.option(
    "--sro", type=click.Choice(["sine", "file", "random", "none"]), default="sine", show_default=True,
    help="Disc surface run-out profile.",
)
@click.option("--sro-amplitude", type=float, default=0.08e-3, show_default=True,
              help="Sine amplitude q0, or RMS of random roughness [m].")
@click.option("--sro-wavelength", type=float, default=1e-3, show_default=True,
              help="Sine wavelength lambda, or longest random wavelength [m].")
@click.option("--sro-file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Profile for --sro file: two columns, position [m] and q [m].")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of random roughness and perturbation.")
@click.option("--perturbation", type=float, default=0.0, show_default=True,
              help="RMS of a random initial displacement [m] (a flat disc needs one to leave equilibrium).")
@click.option("--contact", type=click.Choice(["linear", "nonlinear"]), default="linear", show_default=True,
              help="linear: the paper's eqs. 1-4; nonlinear: loss of contact and velocity-sign friction.")
@click.option("--speed", type=float, default=0.02, show_default=True, help="Sliding speed v [m/s].")
@click.option("--duration", type=float, default=0.15, show_default=True, help="Simulated time [s].")
@click.option("--fs", type=float, default=40_000.0, show_default=True, help="Output sample rate [Hz].")
@output_options()
def simulate(preset, config, sets, mu, sro, sro_amplitude, sro_wavelength, sro_file, seed, perturbation, contact,
             speed, duration, fs, as_json, out_path, plot_path) -> None:
    """Simulate the time response of a model driven by disc surface run-out.

    \b
    Example (paper Fig. 4: mu = 0.4, q0 = 0.08 mm, lambda = 1 mm, v = 0.02 m/s):
      squealkit simulate --mu 0.4 --sro sine --sro-amplitude 8e-5 \\
          --sro-wavelength 1e-3 --speed 0.02 --duration 0.15 --json --plot fig4.png
    Smooth disc (paper Fig. 3) with a small seeded start perturbation:
      squealkit simulate --sro none --perturbation 1e-9 --plot fig3.png
    """
    import numpy as np

    from ..transient import RandomRoughness, SampledProfile, SineRunOut, Smooth
    from ..transient import simulate as run_simulation
    from ..transient.simulate import transient_summary

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    if duration is None or not duration > 0:
        raise InputError(f"Parameter duration={duration!r} s must be > 0.")
    model = build_model_from_options(preset, config, sets)
    rng = np.random.default_rng(seed)
    if sro == "sine":
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

    with progress_callback("simulating", enabled=not as_json and duration * 1e6 > 2e5) as progress:
        ds = run_simulation(
            model, mu=mu, profile=profile, speed=speed, duration=duration, fs=fs, contact=contact,
            perturbation=perturbation, rng=rng, progress=progress,
        )
    if out_path is not None:
        from ..io import save_dataset

        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..io import save_figure
        from ..plotting.transient import fig3_plot, fig4_plot

        fig = fig3_plot(ds) if sro == "none" else fig4_plot(ds)
        save_figure(fig, plot_path)
    summary = transient_summary(ds)
    if as_json:
        emit_json(summary)
        return
    click.echo(f"status: {summary['status']} (t_stop = {summary['t_stop']:g} s, dt = {summary['dt']:.3g} s)")
    for d, p in summary["peak"].items():  # type: ignore[union-attr]
        click.echo(f"  {d:<4} peak |a| = {p['acceleration_m_s2']:.4g} m/s^2, peak change = "
                   f"{p['displacement_change_m']:.4g} m")
    for st in summary["stages"][:10]:  # type: ignore[index]
        click.echo(f"  {st['stage']:<8} {st['t_start']:.4f}-{st['t_end']:.4f} s: rate {st['rate_per_s']:+.1f} 1/s "
                   f"(mean sigma {st['sigma_mean_per_s']:+.1f} 1/s)")

