"""``squealkit tolerance``: the run-out a disc may have and stay quiet."""

from __future__ import annotations

import click

from ._options import build_model_from_options, emit_json, fe_kwargs_from_options, fe_options, model_options


@click.command()
@model_options
@click.option("--mu", "mu_spec", required=True, metavar="MU|START:STOP:N", help="Friction coefficient(s).")
@click.option("--wavelength", type=float, default=None,
              help="Run-out wavelength lambda in METRES; gives the amplitude tolerance q0 (eq. 11).")
@click.option("--damped", is_flag=True, help="Include the damping matrix.")
@fe_options()
@click.option("--mu-max", default=2.0, show_default=True, type=float, help="FE models: search friction up to this.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
def tolerance(preset, config, sets, mu_spec, wavelength, damped, rpm_spec, band_spec, method, n_modes, mu_max,
              as_json) -> None:
    """Run-out tolerance: the largest SRO slope and amplitude that stay stable.

    The disc's run-out slope tan(theta) adds to friction (mu_e = mu + tan theta,
    eq. 6). For a given mu this finds the largest slope s such that every slope
    in [-s, s] is stable, and with --wavelength the largest amplitude of a sine
    run-out q0 = s * lambda / (2 pi) (eq. 11): a number for the drawing.

    \b
    Examples:
      squealkit tolerance --mu 0.3 --wavelength 1e-3
      squealkit tolerance --mu 0:0.44:12 --wavelength 0.05 --json

    \b
    --json keys (one mu): mu, tan_theta_max, theta_max_deg, limiting_side
    (rising | falling | flat), wavelength [m], q0_max [m], stable_on_flat_disc,
    damped. A range of mu gives a list "tolerances" of those objects.

    \b
    FE models (model = "fe" in --config), one --mu, at each disc speed --rpm:
    tan_theta_max = mu_crit(rpm) - mu (rising slope; mu_e = mu + tan theta), and
    with --wavelength q0_max. --json keys: rpm, mu, mu_critical, tan_theta_max,
    theta_max_deg, q0_max (or null), method.
      squealkit tolerance --config brake.toml --mu 0.05 --rpm 60:240:4 --wavelength 0.05
    """
    from .._validation import parse_range
    from ..stability import runout_tolerance

    model = build_model_from_options(preset, config, sets, allow_fe=True)
    mus = parse_range("--mu", mu_spec)
    fe = fe_kwargs_from_options(model, rpm_spec, band_spec, method, n_modes)
    if fe:
        return _tolerance_fe(model, fe, mus, wavelength, mu_max, as_json)
    results = [runout_tolerance(model, float(m), wavelength=wavelength, damped=damped) for m in mus]
    if as_json:
        emit_json(results[0].to_dict() if len(results) == 1 else {"tolerances": [r.to_dict() for r in results]})
        return
    head = f"{'mu':>8} {'tan(theta)max':>14} {'theta_max [deg]':>16} {'side':>8}"
    if wavelength is not None:
        head += f" {'q0_max [um]':>12}"
    click.echo(head)
    for r in results:
        line = f"{r.mu:8.4f} {r.tan_theta_max:14.6f} {r.theta_max_deg:16.4f} {r.limiting_side:>8}"
        if r.q0_max is not None:
            line += f" {r.q0_max * 1e6:12.4f}"
        click.echo(line)


def _tolerance_fe(model, fe, mus, wavelength, mu_max, as_json) -> None:
    """Run-out tolerance of an FE model at each disc speed: mu_e = mu + tan(theta) up to mu_crit."""
    import math

    import numpy as np

    from .._validation import InputError, validate_positive
    from ..stability import fe_critical_friction

    if mus.size != 1:
        raise InputError("For FE models --mu takes one value.")
    mu = float(mus[0])
    ds = fe_critical_friction(model, fe["rpm"], mu_max=mu_max, mu_operating=mu, method=fe["method"],
                              band=fe["band"], n_modes=fe["n_modes"])
    tmax = ds.tan_theta_max.values
    q0 = None
    if wavelength is not None:
        q0 = np.where(tmax > 0, tmax * validate_positive("--wavelength", wavelength) / (2 * math.pi), 0.0)
    out = {"rpm": ds.rpm.values, "mu": mu, "mu_critical": ds.mu_critical.values, "tan_theta_max": tmax,
           "theta_max_deg": ds.theta_max_deg.values, "q0_max": q0, "wavelength": wavelength,
           "method": ds.attrs["method"]}
    if as_json:
        emit_json(out)
        return
    click.echo(f"{'rpm':>10} {'mu_crit':>10} {'tan(theta)max':>14} {'theta_max [deg]':>16}"
               + (f" {'q0_max [um]':>12}" if q0 is not None else ""))
    for i, r in enumerate(out["rpm"]):
        line = f"{r:10.4g} {out['mu_critical'][i]:10.6f} {tmax[i]:14.6f} {out['theta_max_deg'][i]:16.4f}"
        if q0 is not None:
            line += f" {q0[i] * 1e6:12.4f}"
        click.echo(line)
