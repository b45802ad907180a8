"""``squealkit rig``: the model a rig file derives, with the source of every frequency."""

from __future__ import annotations

from pathlib import Path

import click

from .._validation import InputError
from ._options import damping_option, emit_json, note_damping


@click.command()
@click.option("--config", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Model file with a [rig] table (default: the paper's rig, FEA frequencies of Table 1).")
@click.option("--set", "sets", metavar="NAME=VALUE", multiple=True,
              help="Override a model parameter (SI units; angles as NAME_deg=DEG), as in every command.")
@damping_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON on stdout.")
def rig(config, sets, damped, as_json) -> None:
    """Derived parameters of a rig: each frequency and where it came from, and the onset of squeal.

    A pin frequency left out of the [rig] table comes from beam theory (Timoshenko
    bending, quarter-wave rod axial); a warning says when mode coupling would need
    friction no brake material has. The model is the one every other command builds
    from the same file: its [parameters] table and --set apply (P, alpha and the
    dampers to the rig itself), and mu_crit includes the model's damping unless
    --undamped.

    \b
    Examples:
      squealkit rig
      squealkit rig --config examples/myrig.toml --json

    \b
    --json keys: frequencies (pin_bending, pin_axial, disc: frequency_hz, source),
    parameters (m1, m2, k1, k2, k3, kc [SI]), pin_mass_factor, preload,
    static_contact_force [N], P [N], damped, mu_crit (flat disc; null if none up to 2).
    """
    from ..models import build_model, load_rig, model_from_dict, parse_assignments
    from ..models.config import rig_from_dict
    from ..models.rig import PAPER_PIN_FREQ_HZ
    from ..stability import critical_friction

    overrides = parse_assignments(sets)
    if config is None:  # the paper's rig with its FEA pin frequencies (Table 1)
        doc = {"rig": {"pin_bending_freq": PAPER_PIN_FREQ_HZ["bending"], "pin_axial_freq": PAPER_PIN_FREQ_HZ["axial"]}}
        the_rig, model = rig_from_dict(doc, overrides), model_from_dict(doc, overrides=overrides)
    else:
        the_rig = load_rig(config, overrides)
        if the_rig is None:
            raise InputError(f"Model file {str(config)!r} has no [rig] table.")
        model = build_model(config=config, overrides=overrides)  # the model every command builds from the file
    note_damping(model, damped)
    c = critical_friction(model, damped=damped)
    out = {
        "frequencies": the_rig.frequency_sources(),
        "parameters": {k: float(getattr(model, k)) for k in ("m1", "m2", "k1", "k2", "k3", "kc")},
        "pin_mass_factor": the_rig.pin_mass_factor,
        "preload": the_rig.preload,
        "static_contact_force": float(model.static_contact_force(0.0)),
        "P": float(model.P),
        "damped": damped,
        "mu_crit": c.mu_critical if c.status == "onset" else None,
    }
    if as_json:
        emit_json(out)
        return
    for name, v in out["frequencies"].items():
        click.echo(f"{name.replace('_', ' '):<12} {v['frequency_hz']:9.1f} Hz  ({v['source']})")
    click.echo("  ".join(f"{k} = {v:.4g}" for k, v in out["parameters"].items()))
    click.echo(f"P = {out['P']:.4g} N, static contact force {out['static_contact_force']:.3g} N "
               f"(preload = {the_rig.preload}); "
               f"pin modal mass factor {the_rig.pin_mass_factor:g}")
    mu = out["mu_crit"]
    how = "damped" if damped else "undamped"
    click.echo(f"mu_crit (flat disc, {how}) = {mu:.4f}" if mu is not None else f"no onset up to mu = 2 ({how})")

