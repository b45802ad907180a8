"""``squealkit fe-demo``: write the built-in FE disc brake as Matrix Market files + a model TOML."""

from __future__ import annotations

from pathlib import Path

import click

from ._options import deprecated_alias, emit_json, required


@click.command("fe-demo")
@click.option("--size", "n_theta", type=click.IntRange(min=8), default=48, show_default=True,
              help="Elements around the disc (even): 16 -> ~1.4e3 unknowns, 48 -> ~8.8e3, 96 -> ~3.4e4, "
                   "176 -> ~1.2e5.")
@click.option("--n-z", type=click.IntRange(min=1), default=1, show_default=True,
              help="Elements through the disc thickness.")
@click.option("--out-dir", "out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder to write (required; replaced only when complete).")
@deprecated_alias("--out", "--out-dir", "out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def fe_demo(n_theta: int, n_z: int, out: Path, as_json: bool) -> None:
    """Build the FE disc + pad model and write M, D1, DG, K1, KR, KGeo (.mtx), brake.toml, mesh.vtu.

    \b
    Example:
      squealkit fe-demo --size 48 --out-dir brake
    """
    from .._validation import InputError
    from ..fe.demo import build_fe_demo, write_fe_demo
    from ..io import check_output, written_path

    out = required(out, "--out-dir")
    if n_theta % 2:
        raise InputError(f"--size={n_theta} must be even.")
    check_output(out, directory=True)  # before the work: a new folder, or one squealkit wrote
    model = build_fe_demo(n_theta=n_theta, n_z=n_z)
    toml = write_fe_demo(model, out)
    # omega_ref: the older key of disc_speed_ref, printed too for one release
    info = {"config": str(toml), "n_dofs": int(model["n_dofs"]), "disc_speed_ref": model["disc_speed_ref"],
            "omega_ref": model["disc_speed_ref"],
            "mu_ref": model["mu_ref"], "f_ref": model["f_ref"],
            "files": sorted(p.name for p in written_path(out).iterdir() if not p.name.startswith("."))}
    if as_json:
        emit_json(info)
        return
    click.echo(f"wrote FE brake model ({info['n_dofs']} unknowns): {toml}")
