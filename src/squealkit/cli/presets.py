"""``squealkit presets``: list the built-in models and their parameters."""

from __future__ import annotations

import click

from ._options import emit_json


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Print the presets as JSON.")
def presets(as_json: bool) -> None:
    """List the built-in models with each parameter, its value and unit.

    \b
    Example:
      squealkit presets
      squealkit stability --preset hoffmann2002 --mu 0:1:201 --theta 0
    """
    from ..models import PRESETS, get_preset

    out = {}
    for name, (desc, _) in PRESETS.items():
        model = get_preset(name)
        info = model.parameter_info()
        out[name] = {
            "description": desc,
            "model": model.kind,
            "parameters": {k: {"value": v, "unit": info[k]["unit"], "doc": info[k]["doc"]}
                           for k, v in model.parameters().items()},
        }
    if as_json:
        emit_json(out)
        return
    for name, entry in out.items():
        click.echo(f"{name}: {entry['description']}")
        for k, p in entry["parameters"].items():
            value = f"{p['value']:.6g}" if isinstance(p["value"], int | float) else str(p["value"])
            click.echo(f"  {k:<8} = {value:<14} [{p['unit']}]  {p['doc']}")
