"""``squealkit floquet``: the exact growth rate of a periodic run-out against the frozen-time average."""

from __future__ import annotations

from pathlib import Path

import click

from .._validation import InputError
from ._options import (
    RUNOUT_WAVELENGTH,
    SRO_AMPLITUDE,
    NumberOrRange,
    build_model_from_options,
    check_output_suffix,
    damping_option,
    emit_json,
    model_options,
    note_damping,
)


@click.command()
@model_options
@click.option("--mu", "mu_spec", default="0.4", show_default=True, type=NumberOrRange(),
              help="Friction coefficient(s).")
@click.option("--sro-amplitude", "amp_spec", default="8e-5", show_default=True, type=SRO_AMPLITUDE,
              help="Sine run-out amplitude q0 [m], or with a unit: '80 um' (a range START:STOP:N makes a map).")
@click.option("--sro-wavelength", type=RUNOUT_WAVELENGTH, default=1e-3, show_default=True,
              help="Run-out wavelength [m].")
@click.option("--speed", type=float, default=0.02, show_default=True, help="Sliding speed v [m/s].")
@damping_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the map to a .nc or .zarr file.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Figure of the Floquet exponent over mu and amplitude (.png, .svg, .pdf).")
def floquet(preset, config, sets, mu_spec, amp_spec, sro_wavelength, speed, damped, as_json, out_path,
            plot_path) -> None:
    """Floquet exponent of a sine run-out: the exact growth rate of the periodic system.

    The monodromy matrix over one run-out period T = lambda / v gives the growth
    rate rho = ln|Lambda_max| / T; it is compared with the period average of the
    frozen-time growth rate sigma(t) the paper uses (§4).

    \b
    Examples:
      squealkit floquet --mu 0.4 --sro-amplitude 8e-5 --sro-wavelength 1e-3 --speed 0.02
      squealkit floquet --mu 0.3:0.5:11 --sro-amplitude 0:1e-4:11 --plot floquet.png --json

    \b
    --json keys (one point): mu, amplitude [m], wavelength [m], speed [m/s], period [s],
    floquet_exponent [1/s], frozen_mean [1/s], frozen_max [1/s], relative_difference,
    multipliers ([re, im] pairs), steps, damped. A map: mu, amplitude (lists),
    floquet_exponent and frozen_mean (lists of rows over amplitude), period, steps.
    """
    from .._validation import parse_range
    from ..transient.floquet import floquet as floquet_point
    from ..transient.floquet import floquet_map

    check_output_suffix(out_path, (".nc", ".zarr"), "--out")
    check_output_suffix(plot_path, (".png", ".svg", ".pdf"), "--plot")
    model = build_model_from_options(preset, config, sets)
    note_damping(model, damped)
    mu = parse_range("--mu", mu_spec)
    amp = parse_range("--sro-amplitude", amp_spec)
    if mu.size == 1 and amp.size == 1 and out_path is None and plot_path is None:
        r = floquet_point(model, mu=float(mu[0]), amplitude=float(amp[0]), wavelength=sro_wavelength, speed=speed,
                          damped=damped)
        if as_json:
            emit_json(r.to_dict())
            return
        click.echo(f"mu = {r.mu:g}, q0 = {r.amplitude:g} m, lambda = {r.wavelength:g} m, v = {r.speed:g} m/s "
                   f"(period {r.period:g} s, {r.steps} RK4 steps)")
        click.echo(f"  Floquet exponent            {r.floquet_exponent:+.6g} 1/s")
        click.echo(f"  frozen-time sigma, mean     {r.frozen_mean:+.6g} 1/s ({100 * r.relative_difference:+.2f} %)")
        click.echo(f"  frozen-time sigma, largest  {r.frozen_max:+.6g} 1/s")
        return
    if (mu.size < 2 or amp.size < 2) and plot_path is not None:
        raise InputError("--plot draws a map: give ranges for both --mu and --sro-amplitude.")
    ds = floquet_map(model, mu=mu, amplitude=amp, wavelength=sro_wavelength, speed=speed, damped=damped)
    if out_path is not None:
        from ..io import save_dataset

        save_dataset(ds, out_path)
    if plot_path is not None:
        from ..io import save_figure
        from ..plotting.transient import floquet_plot

        save_figure(floquet_plot(ds), plot_path)
    out = {"mu": ds.mu.values, "amplitude": ds.amplitude.values, "floquet_exponent": ds.floquet_exponent.values,
           "frozen_mean": ds.frozen_mean.values, "period": ds.attrs["period"], "steps": ds.attrs["steps_per_period"]}
    if as_json:
        emit_json(out)
        return
    click.echo(f"{'mu':>8} {'q0 [um]':>10} {'Floquet [1/s]':>14} {'frozen mean [1/s]':>18}")
    for i, m in enumerate(ds.mu.values):
        for j, q in enumerate(ds.amplitude.values):
            click.echo(f"{m:8.4f} {q * 1e6:10.3f} {ds.floquet_exponent.values[i, j]:14.6g} "
                       f"{ds.frozen_mean.values[i, j]:18.6g}")
