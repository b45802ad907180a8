"""Options shared by the subcommands, and helpers to act on them."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click
import numpy as np

from .._validation import InputError

F = Callable[..., Any]


class Quantity(click.ParamType):
    """A CLI value in a declared SI unit: a bare number in that unit, or a number with its own unit
    ("60 mm", "80 um", "2.9 kHz") converted; a bare number outside ``plausible`` that a common unit
    slip explains is refused naming it (see :mod:`squealkit._units`)."""

    name = "quantity"

    def __init__(self, unit: str, *, plausible: tuple[float, float] | None = None, what: str | None = None) -> None:
        self.unit, self.plausible, self.what = unit, plausible, what

    def get_metavar(self, param: click.Parameter, *args: Any, **kwargs: Any) -> str:
        return f"VALUE[{self.unit}]|'N UNIT'"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> float:
        from .._units import parse_quantity

        if isinstance(value, float):
            return value  # a default, already in the unit
        name = param.opts[0] if param is not None and param.opts else "value"
        return parse_quantity(name, value, self.unit, plausible=self.plausible, what=self.what)


class NumberOrRange(click.ParamType):
    """One CLI type for an axis a command may sweep (``--rpm``, ``--mu``, ``--theta``,
    ``--sro-amplitude``): a number, or a range ``START:STOP:N`` (N points, ends included).

    A command that sweeps takes the text (checked here, turned into values with
    :func:`squealkit._validation.parse_range`); a command that needs one value declares
    ``single=True``, gets a float, and refuses a range in one line. With ``unit`` a single value
    may carry its own unit (``"80 um"``; see :class:`Quantity`).
    """

    name = "number_or_range"

    def __init__(self, *, single: bool = False, unit: str | None = None, plausible: tuple[float, float] | None = None,
                 what: str | None = None, needs: str = "one value") -> None:
        self.single, self.unit, self.plausible, self.what, self.needs = single, unit, plausible, what, needs

    def get_metavar(self, param: click.Parameter, *args: Any, **kwargs: Any) -> str:
        return "NUMBER" if self.single else "NUMBER|START:STOP:N"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        from .._validation import _RANGE_RE, parse_range

        name = param.opts[0] if param is not None and param.opts else "value"
        if isinstance(value, float) and self.single:
            return value  # a default
        text = str(value).strip()
        if _RANGE_RE.match(text):
            if self.single:
                command = f"squealkit {ctx.info_name}" if ctx is not None else "this command"
                raise InputError(f"{name} {text!r} is a range; {command} takes {self.needs}: give one number.")
            parse_range(name, text)  # START, STOP and N are numbers
            return text
        if self.unit is None:
            try:
                number = float(text)
            except ValueError:
                raise InputError(f"{name} {text!r} is not a valid float and not a range START:STOP:N.") from None
            if not math.isfinite(number):
                raise InputError(f"{name} {text!r} must be finite.")
            return number if self.single else text
        from .._units import parse_quantity

        number = parse_quantity(name, text, self.unit, plausible=self.plausible, what=self.what)
        return number if self.single else repr(number)


#: The probe's radius on the disc (analyze, report, campaign, synth): a lab disc is 5 mm to 1 m.
PROBE_RADIUS = Quantity("m", plausible=(5e-3, 1.0), what="the probe radius on the disc")
#: A disc surface run-out amplitude (sine q0, or RMS of roughness): micrometres to 2 mm.
RUNOUT_AMPLITUDE = Quantity("m", plausible=(1e-8, 2e-3), what="a disc run-out amplitude")
#: --sro-amplitude: a run-out amplitude [m] (a single value may carry its unit), or a range of them
#: (the Floquet map checks their range itself: up to 10 mm).
SRO_AMPLITUDE = NumberOrRange(unit="m")
#: --sro-amplitude where a command takes one amplitude.
SRO_AMPLITUDE_ONE = NumberOrRange(single=True, unit="m", plausible=RUNOUT_AMPLITUDE.plausible,
                                  what=RUNOUT_AMPLITUDE.what, needs="one run-out amplitude")
#: A run-out wavelength along the disc: 10 um to 2 m.
RUNOUT_WAVELENGTH = Quantity("m", plausible=(1e-5, 2.0), what="a run-out wavelength")


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


def writable(ctx: click.Context, param: click.Parameter, value: Path | None) -> Path | None:
    """Option callback: an output path is checked before any work (folder exists and takes
    a file, not a folder where a file is wanted; see :func:`squealkit.io.check_output`)."""
    if value is not None and not ctx.resilient_parsing:
        from ..io import check_output

        check_output(value, directory=value.suffix.lower() == ".zarr")
    return value


def writable_folder(ctx: click.Context, param: click.Parameter, value: Path | None) -> Path | None:
    """Option callback for an output folder: its parent takes a folder (the folder's own
    contents are checked by the command, which knows about ``--force``)."""
    if value is not None and not ctx.resilient_parsing:
        from ..io import check_output

        check_output(value, directory=True, force=True)
    return value


def output_options(*, dataset: bool = True, plot: bool = True) -> Callable[[F], F]:
    """--json, --out FILE (.nc or .zarr) and --plot FILE.png."""

    def deco(f: F) -> F:
        if plot:
            f = click.option(
                "--plot", "plot_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
                callback=writable, help="Write a figure (.png, .svg or .pdf).",
            )(f)
        if dataset:
            f = click.option(
                "--out", "out_path", type=click.Path(path_type=Path), default=None, callback=writable,
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


#: Subcommands that work on FE models (model = "fe").
FE_COMMANDS = ("stability", "critical", "modes", "tolerance", "report", "design")

#: One-line notes for stderr, printed by the CLI's main only after the command succeeded (so a
#: user error stays one line).
PENDING_NOTES: list[str] = []


def build_model_from_options(preset: str | None, config: Path | None, sets: tuple[str, ...], *,
                             allow_fe: bool = False):
    """The model named by --preset/--config with the --set overrides applied.

    An FE model (``model = "fe"``) is refused unless ``allow_fe``: only :data:`FE_COMMANDS` take one.
    With a model file that has a [rig] table, a note (on stderr, after the command succeeded)
    says where each frequency the model is derived from came from: given, or which beam theory.
    """
    from ..models import FEModel, build_model, load_rig, parse_assignments

    overrides = parse_assignments(sets)
    model = build_model(preset, config, overrides)
    if isinstance(model, FEModel) and not allow_fe:
        raise InputError(f"FE models (model = \"fe\") work with {', '.join(FE_COMMANDS)} only.")
    rig = load_rig(config, overrides) if config is not None and not isinstance(model, FEModel) else None
    if rig is not None:
        PENDING_NOTES.append(f"squealkit: rig frequencies: {rig.describe()}")
    return model


def damping_option(f: F) -> F:
    """--damped/--undamped: the model's damping is used unless --undamped (the paper's eq. 7 sweep)."""
    return click.option(
        "--damped/--undamped", "damped", default=True, show_default=True,
        help="Use the model's damping matrix (the default), or leave it out with --undamped (the paper's "
        "Fig. 2 sweep, eq. 7, is undamped). A note on stderr says when damping the model has is left out.",
    )(f)


def note_damping(model: Any, damped: bool) -> None:
    """One line on stderr (after the command succeeded) when damping the model has is left out."""
    from ..models._base import damping_names

    names = damping_names(model)
    if not damped and names:
        PENDING_NOTES.append(f"squealkit: the model's damping ({names}) is left out (--undamped).")


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
        if not self.enabled or not sys.stderr.isatty():  # a log or a pipe: no bar (rich left a blank line)
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
        help="Stribeck friction mu(v) = mu + (MU_STATIC - mu) exp(-abs(v) / V_STRIBECK) [V_STRIBECK in m/s], "
        "mu the kinetic coefficient; e.g. --stribeck 0.6,0.001.",
    )(f)
    return f


def refuse_options(names: tuple[str, ...], why: str) -> None:
    """Refuse options the user gave that would do nothing in this mode, before any work.

    ``names`` are the options' parameter names (``"mu_max"``); the first given on the command
    line is named in one line with ``why`` (when it applies), e.g. ``--mu-max applies to FE
    models only``. Every command that ignores options in some mode says so through here,
    never by silence.
    """
    ctx = click.get_current_context()
    for param in ctx.command.params:
        if param.name in names and ctx.get_parameter_source(param.name) == click.core.ParameterSource.COMMANDLINE:
            raise InputError(f"{param.opts[0]} {why}.")


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
        refuse_options(("speed",), "only matters with --stribeck (speed-dependent friction); add --stribeck")
        return {}
    return {"friction": law, "speed": speed}


def friction_json(fr: dict[str, Any]) -> dict[str, Any]:
    """The --json keys describing the friction law: ``stribeck`` and ``speed`` (none for constant friction)."""
    if not fr:
        return {}
    law = fr["friction"]
    return {"stribeck": {"mu_static": law.mu_static, "v_stribeck": law.v_stribeck}, "speed": fr["speed"]}


def criteria_options(f: F) -> F:
    """--setup, --band, --threshold-dba, --time-weighting, --min-duration: what counts as squeal."""
    f = click.option("--min-duration", type=float, default=0.01, show_default=True,
                     help="Shortest tonal event [s] (no standard fixes one).")(f)
    f = click.option("--time-weighting", type=click.Choice(["fast", "slow"]), default="fast", show_default=True,
                     help="IEC 61672-1 time weighting of the level (Fast 125 ms, Slow 1 s).")(f)
    f = click.option("--threshold-dba", type=float, default=70.0, show_default=True,
                     help="Squeal threshold [dB(A)] (SAE J2521: 70).")(f)
    f = click.option("--band", default=None, metavar="LOWER:UPPER",
                     help="A user squeal band [Hz] instead of the setup's, e.g. 1000:16000.")(f)
    f = click.option("--setup", type=click.Choice(["component", "corner"]), default=None,
                     help="SAE J2521 setup: component (brake not on a full corner, e.g. pin-on-disc: 2-16 kHz; "
                     "the default) or corner (full suspension corner or axle: 1.25-16 kHz).")(f)
    return f


def criteria_from_options(setup: str | None, band: str | None, threshold_dba: float, time_weighting: str,
                          min_duration: float):
    """The :class:`~squealkit.measurement.squeal.criteria.SquealCriteria` of the criteria options."""
    from ..measurement.squeal.criteria import squeal_criteria

    band_ = None
    if band is not None:
        lo, sep, hi = band.partition(":")
        if not sep:
            raise InputError(f"--band {band!r} must look like LOWER:UPPER in Hz, e.g. 1000:16000.")
        try:
            band_ = (float(lo), float(hi))
        except ValueError:
            raise InputError(f"--band {band!r} must be two numbers LOWER:UPPER in Hz, e.g. 1000:16000.") from None
    return squeal_criteria(setup, band=band_, threshold_dba=threshold_dba, time_weighting=time_weighting,
                           min_duration=min_duration)


def fe_options(*, band: bool = True, rpm_help: str = "Disc speed [rpm] (disc_speed = 2 pi rpm/60): one number, "
               "or N points from START to STOP. FE models only.", single_rpm: bool = False) -> Callable[[F], F]:
    """--rpm, --eigen-band, --method and --modes: the disc speed axis and the solver of FE models.

    ``--band`` is the squeal band of the recording commands; here it is a deprecated alias of
    ``--eigen-band`` for one release.
    """

    def deco(f: F) -> F:
        f = click.option("--modes", "n_modes", type=int, default=None, metavar="N",
                         help="Reduced basis size for --method modal|pod (FE models).")(f)
        f = click.option("--method", type=click.Choice(["auto", "dense", "sparse", "modal", "pod", "subspace"]),
                         default="auto",
                         show_default=True,
                         help="FE solver: dense (all modes), sparse (a band, shift-invert), modal (real modes) or "
                         "pod (eigenvectors at the middle --rpm and the ends of the friction range, with the "
                         "real modes: the fast path for large sweeps), subspace (projection on the real modes to 1.5x "
                         "the band's top: the largest models); reduced eigenpairs are each checked in the full model; "
                         "auto = dense up to 1000 DOFs, subspace where a band solve would not fit in memory "
                         "($SQUEALKIT_MEMORY caps it).")(f)
        if band:
            f = deprecated_alias("--band", "--eigen-band", "band_spec", metavar="LO:HI")(f)
            f = click.option("--eigen-band", "band_spec", default=None, metavar="LO:HI",
                             help="FE models: the frequency band [Hz] the eigenvalue solvers search (sparse default "
                             "1000:16000, others all modes).")(f)
        f = click.option("--rpm", "rpm_spec", type=NumberOrRange(single=single_rpm, needs="one disc speed"),
                         default=None, help=rpm_help)(f)
        return f

    return deco


def fe_kwargs_from_options(model: Any, rpm_spec: str | None, band_spec: str | None, method: str,
                           n_modes: int | None, *, need_rpm: bool = True) -> dict[str, Any]:
    """``rpm``, ``band``, ``method``, ``n_modes`` for the FE functions; {} for other models (and an
    error if FE options were given to them)."""
    from .._validation import parse_range
    from ..models import FEModel

    if not isinstance(model, FEModel):
        given = [o for o, v in (("--rpm", rpm_spec), ("--eigen-band", band_spec), ("--modes", n_modes))
                 if v is not None]
        if method != "auto":
            given.append("--method")
        if given:
            raise InputError(f"{given[0]} applies to FE models only (model = \"fe\" in the --config file).")
        return {}
    if rpm_spec is None and need_rpm:
        raise InputError("An FE model needs disc speeds: --rpm START:STOP:N (rpm).")
    out: dict[str, Any] = {"method": method, "n_modes": n_modes}
    if rpm_spec is not None:
        rpm = parse_range("--rpm", rpm_spec) if isinstance(rpm_spec, str) else np.array([float(rpm_spec)])
        if np.any(rpm <= 0):
            raise InputError(f"--rpm {rpm_spec!r}: disc speeds must be > 0 rpm.")
        out["rpm"] = rpm
    if band_spec is not None:
        lo, sep, hi = band_spec.partition(":")
        try:
            out["band"] = (float(lo), float(hi))
        except ValueError:
            raise InputError(f"--eigen-band {band_spec!r} must be LO:HI in Hz, e.g. 1000:16000.") from None
        if not sep:
            raise InputError(f"--eigen-band {band_spec!r} must be LO:HI in Hz, e.g. 1000:16000.")
    else:
        out["band"] = None
    if n_modes is not None and n_modes < 1:
        raise InputError(f"--modes {n_modes} must be >= 1.")
    return out


def recording_options(*, required: bool = True) -> Callable[[F], F]:
    """How to read and analyse a rig recording: channels, disc speed or tacho, probe, criteria, scaling.

    One definition for every command that analyses a recording (``analyze``, ``report --recording``).
    With ``required`` (``analyze``) --mic, --displacement and --radius must be given; otherwise the
    channels default to ``mic`` and ``displacement`` and the command checks --radius when it needs it.
    Turn the values into arguments with :func:`recording_kwargs_from_options`.
    """
    mic = {"required": True} if required else {"default": "mic", "show_default": True}
    disp = {"required": True} if required else {"default": "displacement", "show_default": True}
    radius = {"required": True} if required else {"default": None}
    options = [
        click.option("--mic", help="Microphone channel [Pa]: name or 0-based index.", **mic),
        click.option("--displacement", help="Eddy-current probe channel [m]: name or index.", **disp),
        click.option("--rpm", type=NumberOrRange(single=True, needs="one disc speed"), default=None,
                     help="Disc speed [rpm] (constant; or give --tacho)."),
        click.option("--radius", type=PROBE_RADIUS, help="Probe radius on the disc [m], or with a unit: '60 mm'.",
                     **radius),
        click.option("--tacho", default=None, help="Tacho channel (name or index): disc angle and speed from it."),
        click.option("--tacho-kind", type=click.Choice(["pulses", "angle"]), default="pulses", show_default=True,
                     help="Tacho channel: a pulse train or an angle (degrees)."),
        click.option("--pulses-per-rev", type=int, default=1, show_default=True, help="Tacho pulses per revolution."),
        click.option("--probe-offset-deg", type=float, default=0.0, show_default=True,
                     help="The probe sits this far upstream of the pin [deg] (sees the surface earlier)."),
        click.option("--acoustic-delay", type=float, default=0.0, show_default=True,
                     help="Delay of the sound from the pin to the microphone [s]."),
        click.option("--polarity", type=click.Choice(["1", "-1"]), default="1", show_default=True,
                     help="-1 when the probe reads the run-out reversed."),
        criteria_options,
        click.option("--min-tnr-db", type=float, default=8.0, show_default=True,
                     help="Tonality a squeal component needs: its tone-to-noise ratio [dB] over the noise in its "
                     "critical band (ECMA-418-1 prominent tone: 8). Broadband noise stays below 0."),
        click.option("--fs", type=float, default=None, help="Sample rate [Hz] for a CSV without time column."),
        click.option("--scale", "scales", multiple=True, metavar="CHANNEL=FACTOR",
                     help="File value -> physical unit factor per channel (e.g. WAV full scale in Pa). Repeatable."),
        click.option("--unit", "units", multiple=True, metavar="CHANNEL=UNIT", help="Unit of a channel. Repeatable."),
    ]

    def deco(f: F) -> F:
        for option in reversed(options):  # click lists options in the order they are written here
            f = option(f)
        return f

    return deco


def channel_pairs(option: str, items: tuple[str, ...]) -> dict[str, str]:
    """``CHANNEL=VALUE`` items of a repeatable option (--scale, --unit) as a dict."""
    out = {}
    for it in items:
        name, sep, value = it.partition("=")
        if not sep or not name.strip() or not value.strip():
            raise InputError(f"{option} {it!r} must look like CHANNEL=VALUE.")
        out[name.strip()] = value.strip()
    return out


def recording_kwargs_from_options(*, rpm: float | None, tacho: str | None, tacho_kind: str, pulses_per_rev: int,
                                  probe_offset_deg: float, acoustic_delay: float, polarity: str, setup: str | None,
                                  band: str | None, threshold_dba: float, time_weighting: str, min_duration: float,
                                  min_tnr_db: float, scales: tuple[str, ...], units: tuple[str, ...],
                                  ) -> tuple[dict[str, Any], dict[str, float], dict[str, str]]:
    """The values of :func:`recording_options` as (analysis options, scale map, unit map).

    The analysis options are keyword arguments of :func:`squealkit.measurement.analyze_recording`
    besides the channels, ``rpm`` and ``radius``; the maps go to
    :func:`squealkit.measurement.open_recording`. Without --tacho, --rpm is required.
    """
    from .._validation import validate_finite

    crit = criteria_from_options(setup, band, threshold_dba, time_weighting, min_duration)
    kw: dict[str, Any] = dict(setup=crit.setup if crit.setup != "user" else None, band=crit.band,
                              threshold_dba=crit.threshold_dba, time_weighting=crit.time_weighting,
                              min_duration=crit.min_duration, probe_offset_deg=probe_offset_deg,
                              acoustic_delay=acoustic_delay, polarity=int(polarity), min_tnr_db=min_tnr_db)
    if tacho is not None:
        kw.update(tacho=int(tacho) if tacho.isdigit() else tacho, tacho_kind=tacho_kind,
                  pulses_per_rev=pulses_per_rev)
    elif rpm is None:
        raise InputError("Give the disc speed --rpm, or a --tacho channel.")
    scale_map = {k: validate_finite(f"--scale {k}", v) for k, v in channel_pairs("--scale", scales).items()}
    return kw, scale_map, channel_pairs("--unit", units)


# -- one vocabulary: every option name, its type and its meaning (tests/test_naming.py) -------------


@dataclass(frozen=True)
class Term:
    """What an option name means in every command that has it.

    ``type`` is the kind of value (:func:`option_type` of the click parameter): ``flag``,
    ``number``, ``int``, ``text``, ``choice`` (the choices may differ by command: the options of
    the command's engine), ``file``, ``folder``, ``number_or_range`` (one :class:`NumberOrRange`
    type; commands that need one value refuse a range) or ``quantity[UNIT]``; ``unit`` is what
    its help must state (e.g. ``[rpm]``, ``DEGREES``); ``multiple`` for a repeatable option.
    """

    type: str
    meaning: str
    unit: str = ""
    multiple: bool = False


#: Option name -> its one meaning. A new option is declared here first; the naming test fails
#: for an option not declared, or declared with another type or unit than a command gives it.
OPTIONS: dict[str, Term] = {
    "--acoustic-delay": Term("number", "delay of the sound from the pin to the microphone", "[s]"),
    "--at-onset": Term("flag", "take the critical friction at --theta instead of --mu"),
    "--band": Term("text", "the squeal band LOWER:UPPER (SAE J2521 criteria), instead of the --setup's", "[Hz]"),
    "--campaign": Term("int", "write a synthetic campaign of N applications"),
    "--condition-channels": Term("flag", "a synthetic campaign records pressure and temperature as channels"),
    "--confidence": Term("number", "level of the confidence band and intervals"),
    "--config": Term("file", "model file (TOML) describing a rig or model"),
    "--contact": Term("choice", "contact law (linear, nonlinear)"),
    "--damped": Term("flag", "use the model's damping matrix (--undamped leaves it out)"),
    "--displacement": Term("text", "eddy-current probe channel: name or index", "[m]"),
    "--doe": Term("text", "design of experiments: sweep a declared design parameter, NAME=START:STOP:N",
                  multiple=True),
    "--duration": Term("number", "length of the simulated or synthetic signal", "[s]"),
    "--eigen-band": Term("text", "FE models: the frequency band LO:HI the eigenvalue solvers search", "[Hz]"),
    "--fit": Term("text", "calibrate a model quantity within bounds, NAME=LO:HI", multiple=True),
    "--force": Term("flag", "write into an output folder that holds other files"),
    "--format": Term("choice", "file format of the recordings written"),
    "--freq": Term("number", "squeal frequency of a synthetic recording", "[Hz]"),
    "--fs": Term("number", "sample rate", "[Hz]"),
    "--harmonics": Term("int", "harmonics H of a harmonic-balance cycle"),
    "--harmonics-tol": Term("number", "adapt H until the amplitudes change by at most this (relative)"),
    "--json": Term("flag", "print a machine-readable result on stdout"),
    "--level-dba": Term("number", "saturated squeal level", "[dB(A)]"),
    "--level-dof": Term("text", "DOF whose velocity radiates"),
    "--method": Term("choice", "the numerical method of the command's engine (FE solver, time integrator)"),
    "--mic": Term("text", "microphone channel: name or index", "[Pa]"),
    "--min-duration": Term("number", "shortest tonal event", "[s]"),
    "--min-tnr-db": Term("number", "tone-to-noise ratio a squeal component needs", "[dB]"),
    "--modes": Term("int", "FE models: reduced basis size for --method modal|pod"),
    "--mu": Term("number_or_range", "friction coefficient(s): a number or START:STOP:N"),
    "--mu-max": Term("number", "search friction up to this value"),
    "--n-z": Term("int", "elements through the disc thickness"),
    "--no-report": Term("flag", "skip the HTML report"),
    "--no-sensitivity": Term("flag", "skip the Sobol' indices"),
    "--out": Term("file", "write the result to this file (.nc, .zarr, or the command's format)"),
    "--out-dir": Term("folder", "write the command's outputs into this folder"),
    "--perturbation": Term("number", "RMS of a random initial displacement", "[m]"),
    "--plot": Term("file", "write the figure(s) to this file (.png, .svg or .pdf; analyze: one file per figure "
                   "from this name)"),
    "--plot-map": Term("file", "also write a stability map figure to this file"),
    "--polarity": Term("choice", "-1 when the probe reads the run-out reversed"),
    "--preset": Term("text", "built-in model"),
    "--pressure-channel": Term("text", "channel giving an application's pressure", "[bar]"),
    "--probe-offset-deg": Term("number", "probe position upstream of the pin", "[deg]"),
    "--pulses-per-rev": Term("int", "tacho pulses per revolution"),
    "--quick": Term("flag", "coarser grids and shorter runs: a preview"),
    "--radiation-factor": Term("number", "sound pressure per unit velocity at the listener", "[Pa/(m/s)]"),
    "--radius": Term("quantity[m]", "probe radius on the disc", "[m]"),
    "--recording": Term("file", "a rig recording to analyse"),
    "--rpm": Term("number_or_range", "disc speed: a number, or START:STOP:N where the command sweeps it", "[rpm]"),
    "--rpm-end": Term("number", "disc speed at the end of a synthetic stop", "[rpm]"),
    "--rtol": Term("number", "relative tolerance of the time integrator"),
    "--samples": Term("int", "Monte Carlo samples"),
    "--scale": Term("text", "file value -> physical unit factor of a channel, CHANNEL=FACTOR", multiple=True),
    "--scatter": Term("text", "robust margins: a scattering quantity and its coefficient of variation, NAME=COV",
                      multiple=True),
    "--scheduler": Term("text", "run on a Dask cluster: a scheduler address or 'local'"),
    "--seed": Term("int", "seed of the random numbers"),
    "--sensitivity": Term("flag", "also report the sensitivities of the critical friction"),
    "--set": Term("text", "override a model parameter, NAME=VALUE", multiple=True),
    "--setup": Term("choice", "SAE J2521 setup (component, corner)"),
    "--size": Term("int", "elements around the demo disc"),
    "--speed": Term("number", "sliding speed", "[m/s]"),
    "--squeal-on": Term("choice", "run-out stage on which a synthetic squeal grows"),
    "--sro": Term("choice", "disc surface run-out profile"),
    "--sro-amplitude": Term("number_or_range", "sine run-out amplitude q0 (or RMS of roughness)", "[m]"),
    "--sro-file": Term("file", "run-out profile file"),
    "--sro-wavelength": Term("quantity[m]", "run-out wavelength", "[m]"),
    "--stability": Term("choice", "how the stability of a limit cycle is computed"),
    "--stribeck": Term("text", "Stribeck friction MU_STATIC,V_STRIBECK"),
    "--summary": Term("file", "write the campaign summary (CSV) to this file"),
    "--tacho": Term("text", "tacho channel: name or index"),
    "--tacho-kind": Term("choice", "tacho channel kind (pulses, angle)"),
    "--temperature-channel": Term("text", "channel giving an application's temperature", "[C]"),
    "--theta": Term("number_or_range", "run-out incline: a number or START:STOP:N", "DEGREES"),
    "--threshold-dba": Term("number", "squeal threshold", "[dB(A)]"),
    "--time-weighting": Term("choice", "IEC 61672-1 time weighting (fast, slow)"),
    "--tolerance": Term("number", "frequency tolerance of a match between a measured squeal and a predicted mode",
                        "[%]"),
    "--transfer": Term("file", "measured transfer p/v against frequency (CSV)"),
    "--uncertain": Term("file", "TOML file with the [uncertain] table"),
    "--unit": Term("text", "unit of a channel, CHANNEL=UNIT", multiple=True),
    "--vtk": Term("file", "write mode shapes with the mesh (.vtu)"),
    "--wavelength": Term("quantity[m]", "run-out wavelength of the amplitude tolerance", "[m]"),
}

#: Old spellings kept for one release: (command, old option) -> the option that now says it. Each
#: is a hidden alias that prints one deprecation line on stderr (:func:`deprecated_alias`).
DEPRECATED_OPTIONS: dict[tuple[str, str], str] = {
    **{(c, "--band"): "--eigen-band" for c in ("stability", "critical", "modes", "tolerance", "design")},
    ("synth", "--tacho-ppr"): "--pulses-per-rev",
    **{(c, "--out"): "--out-dir" for c in ("campaign", "fe-demo", "report", "reproduce")},
}


def option_type(param: click.Parameter) -> str:
    """The :class:`Term` type of a click parameter (what the naming test compares across commands)."""
    t = param.type
    if getattr(param, "is_flag", False):
        return "flag"
    if isinstance(t, NumberOrRange):
        return "number_or_range"
    if isinstance(t, Quantity):
        return f"quantity[{t.unit}]"
    if isinstance(t, click.Choice):
        return "choice"
    if isinstance(t, click.Path):
        return "folder" if not t.file_okay else "file"
    if isinstance(t, click.types.FloatParamType | click.FloatRange):
        return "number"
    if isinstance(t, click.types.IntParamType | click.IntRange):
        return "int"
    return "text"


def deprecated_alias(old: str, new: str, dest: str, *, callback: Callable[..., Any] | None = None,
                     **kwargs: Any) -> Callable[[F], F]:
    """A hidden option ``old`` that gives its value to the option ``new`` (parameter ``dest``),
    with one line on stderr after the command succeeded (:data:`PENDING_NOTES`, so an error stays
    one line): ``squealkit: warning: OLD is deprecated in 'squealkit CMD'; use NEW (its meaning).``

    Declare it beside ``new`` with the same ``type`` (``kwargs``) and ``callback``; listed in
    :data:`DEPRECATED_OPTIONS`. Giving both is refused.
    """

    def take(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
        if value is None or ctx.resilient_parsing:
            return value
        if ctx.get_parameter_source(dest) == click.core.ParameterSource.COMMANDLINE:
            raise InputError(f"{old} is the deprecated spelling of {new}: give {new} only.")
        if callback is not None:
            value = callback(ctx, param, value)
        PENDING_NOTES.append(f"squealkit: warning: {old} is deprecated in 'squealkit {ctx.info_name}'; use {new} "
                             f"({OPTIONS[new].meaning}).")
        ctx.params[dest] = value
        ctx.set_parameter_source(dest, click.core.ParameterSource.COMMANDLINE)
        return value

    return click.option(old, f"{dest}__deprecated_{old.lstrip('-').replace('-', '_')}", default=None, hidden=True,
                        expose_value=False, callback=take, **kwargs)


def required(value: Any, option: str) -> Any:
    """``value``, or click's usage error for a missing ``option``: for an option that a deprecated
    alias may give instead (click's ``required=True`` would refuse the alias alone)."""
    if value is None:
        raise click.UsageError(f"Missing option '{option}'.", ctx=click.get_current_context())
    return value
