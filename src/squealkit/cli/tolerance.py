"""``squealkit tolerance``: the run-out a disc may have and stay quiet."""

from __future__ import annotations

import click

from ._options import build_model_from_options, emit_json, model_options


@click.command()
@model_options
@click.option("--mu", "mu_spec", required=True, metavar="MU|START:STOP:N", help="Friction coefficient(s).")
@click.option("--wavelength", type=float, default=None,
              help="Run-out wavelength lambda in METRES; gives the amplitude tolerance q0 (eq. 11).")
@click.option("--damped", is_flag=True, help="Include the damping matrix.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
def tolerance(preset, config, sets, mu_spec, wavelength, damped, as_json) -> None:
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
    """
    from .._validation import parse_range
    from ..stability import runout_tolerance

    model = build_model_from_options(preset, config, sets)
    mus = parse_range("--mu", mu_spec)
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
