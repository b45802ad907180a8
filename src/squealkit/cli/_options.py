"""Options shared by the subcommands, and helpers to act on them."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
import numpy as np

from .._validation import InputError

F = Callable[..., Any]


def model_options(f: F) -> F:
    """--preset, --config and --set: which model a command works on."""
    f = click.option(
        "--set", "sets", metavar="NAME=VALUE", multiple=True,
        help="Override a model parameter (SI units; angles as NAME_deg=DEG). Repeatable, "
        "e.g. --set c1=0 --set alpha_deg=2.5.",
    )(f)
    f = click.option(
        "--config", type=click.Path(dir_okay=False, path_type=Path), default=None,
        help="Model file (TOML) describing your rig or model; see the README.",
    )(f)
    f = click.option(
        "--preset", default=None, metavar="NAME",
        help="Built-in model (default lv2013, the paper's rig); 'squealkit presets' lists them.",
    )(f)
    return f


def output_options(*, dataset: bool = True, plot: bool = True) -> Callable[[F], F]:
    """--json, --out FILE (.nc or .zarr) and --plot FILE.png."""

    def deco(f: F) -> F:
        if plot:
            f = click.option(
                "--plot", "plot_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
                help="Write a figure (.png, .svg or .pdf).",
            )(f)
        if dataset:
            f = click.option(
                "--out", "out_path", type=click.Path(path_type=Path), default=None,
                help="Write the full result as netCDF (.nc) or zarr (.zarr).",
            )(f)
        f = click.option(
            "--json", "as_json", is_flag=True, help="Print a machine-readable summary on stdout.",
        )(f)
        return f

    return deco


def scheduler_option(f: F) -> F:
    """--scheduler ADDRESS|local: run the work on a Dask cluster."""
    return click.option(
        "--scheduler", default=None, metavar="ADDRESS|local",
        help="Run on a Dask cluster: a scheduler address (tcp://HOST:8786, or a scheduler file .json), "
        "or 'local' for a local cluster with one worker per core. Needs squealkit[distributed].",
    )(f)


#: One-line notes for stderr, printed by the CLI's main only after the command succeeded (so a
#: user error stays one line).
PENDING_NOTES: list[str] = []


def build_model_from_options(preset: str | None, config: Path | None, sets: tuple[str, ...]):
    """The model named by --preset/--config with the --set overrides applied.

    With a model file that has a [rig] table, a note (on stderr, after the command succeeded)
    says where each frequency the model is derived from came from: given, or which beam theory.
    """
    from ..models import build_model, load_rig, parse_assignments

    model = build_model(preset, config, parse_assignments(sets))
    rig = load_rig(config) if config is not None else None
    if rig is not None:
        PENDING_NOTES.append(f"squealkit: rig frequencies: {rig.describe()}")
    return model


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return _jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def emit_json(obj: Any) -> None:
    """Print ``obj`` as JSON on stdout (NaN and infinity become null)."""
    click.echo(json.dumps(_jsonable(obj), indent=2, allow_nan=False))


def check_output_suffix(path: Path | None, suffixes: tuple[str, ...], option: str) -> None:
    """Reject an output path whose suffix the command cannot write, before any work."""
    if path is not None and path.suffix.lower() not in suffixes:
        raise InputError(f"{option} {str(path)!r} must end in {' or '.join(suffixes)}.")


class progress_callback:
    """A rich progress bar on stderr as a ``progress(done, total)`` callback.

    Disabled (yields None) when ``enabled`` is False or stderr is not a terminal user's.
    """

    def __init__(self, description: str, *, enabled: bool = True) -> None:
        self.description = description
        self.enabled = enabled
        self._progress = None

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

        self._progress = Progress(
            TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>5.1f}%"),
            TimeElapsedColumn(), TimeRemainingColumn(), console=Console(stderr=True), transient=True,
        )
        self._progress.start()
        task = self._progress.add_task(self.description, total=None)

        def update(done: int, total: int) -> None:
            self._progress.update(task, completed=done, total=total)

        return update

    def __exit__(self, *exc: object) -> None:
        if self._progress is not None:
            self._progress.stop()


def friction_options(f: F) -> F:
    """--stribeck MU_STATIC,V_STRIBECK and --speed V: speed-dependent friction at a sliding speed."""
    f = click.option(
        "--speed", type=float, default=0.02, show_default=True,
        help="Sliding speed v [m/s] (paper: 0.02 m/s). In stability analysis it matters only with --stribeck.",
    )(f)
    f = click.option(
        "--stribeck", "stribeck_spec", default=None, metavar="MU_STATIC,V_STRIBECK",
        help="Stribeck friction mu(v) = mu + (MU_STATIC - mu) exp(-|v| / V_STRIBECK) [V_STRIBECK in m/s], "
        "mu the kinetic coefficient; e.g. --stribeck 0.6,0.001.",
    )(f)
    return f


def parse_stribeck(spec: str | None):
    """The Stribeck law of ``--stribeck MU_STATIC,V_STRIBECK``, or None without it."""
    from ..models.friction import Stribeck

    if spec is None:
        return None
    parts = spec.split(",")
    if len(parts) != 2:
        raise InputError(f"--stribeck {spec!r} must be MU_STATIC,V_STRIBECK, e.g. 0.6,0.001.")
    try:
        mu_static, v_stribeck = (float(p) for p in parts)
    except ValueError:
        raise InputError(f"--stribeck {spec!r} must be two numbers MU_STATIC,V_STRIBECK, e.g. 0.6,0.001.") from None
    return Stribeck(mu_static, v_stribeck)


def friction_from_options(ctx: click.Context, stribeck_spec: str | None, speed: float) -> dict[str, Any]:
    """Keyword arguments ``friction``/``speed`` for the stability functions ({} for constant friction).

    A --speed given on the command line without --stribeck is an error: it would change nothing.
    """
    law = parse_stribeck(stribeck_spec)
    if law is None:
        if ctx.get_parameter_source("speed") == click.core.ParameterSource.COMMANDLINE:
            raise InputError("--speed only matters with --stribeck (speed-dependent friction); add --stribeck.")
        return {}
    return {"friction": law, "speed": speed}


def friction_json(fr: dict[str, Any]) -> dict[str, Any]:
    """The --json keys describing the friction law: ``stribeck`` and ``speed`` (none for constant friction)."""
    if not fr:
        return {}
    law = fr["friction"]
    return {"stribeck": {"mu_static": law.mu_static, "v_stribeck": law.v_stribeck}, "speed": fr["speed"]}
