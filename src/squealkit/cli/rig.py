"""``squealkit rig``: the model a rig file derives, with the source of every frequency."""

from __future__ import annotations

from pathlib import Path

import click

from .._validation import InputError
from ._options import emit_json


@click.command()
@click.option("--config", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Model file with a [rig] table (default: the paper's rig, FEA frequencies of Table 1).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
def rig(config, as_json) -> None:
    """Derived parameters of a rig: each frequency and where it came from, and the onset of squeal.

    A pin frequency left out of the [rig] table comes from beam theory (Timoshenko
    bending, quarter-wave rod axial); a warning says when mode coupling would need
    friction no brake material has.

    \b
    Examples:
      squealkit rig
      squealkit rig --config examples/myrig.toml --json

    \b
    --json keys: frequencies (pin_bending, pin_axial, disc: frequency_hz, source),
    parameters (m1, m2, k1, k2, k3, kc [SI]), pin_mass_factor, preload,
    static_contact_force [N], mu_crit (flat disc, undamped; null if none up to 2).
    """
    from ..models import PinOnDiscRig, load_rig
    from ..stability import critical_friction

    if config is None:
        the_rig = PinOnDiscRig.paper()
    else:
        the_rig = load_rig(config)
        if the_rig is None:
            raise InputError(f"Model file {str(config)!r} has no [rig] table.")
    model = the_rig.to_model()
    c = critical_friction(model.undamped())
    out = {
        "frequencies": the_rig.frequency_sources(),
        "parameters": {k: float(getattr(model, k)) for k in ("m1", "m2", "k1", "k2", "k3", "kc")},
        "pin_mass_factor": the_rig.pin_mass_factor,
        "preload": the_rig.preload,
        "static_contact_force": float(model.static_contact_force(0.0)),
        "mu_crit": c.mu_critical if c.status == "onset" else None,
    }
    if as_json:
        emit_json(out)
        return
    for name, v in out["frequencies"].items():
        click.echo(f"{name.replace('_', ' '):<12} {v['frequency_hz']:9.1f} Hz  ({v['source']})")
    click.echo("  ".join(f"{k} = {v:.4g}" for k, v in out["parameters"].items()))
    click.echo(f"static contact force {out['static_contact_force']:.3g} N (preload = {the_rig.preload}); "
               f"pin modal mass factor {the_rig.pin_mass_factor:g}")
    mu = out["mu_crit"]
    click.echo(f"mu_crit (flat disc, undamped) = {mu:.4f}" if mu is not None else "no onset up to mu = 2")
