"""Validators for the inputs squealkit shares across modules.

One validator per kind of input, each raising :class:`InputError` (a ``ValueError``)
with a message that names the parameter, its value and what is allowed. The CLI turns
these into one line on stderr and exit code 2.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MAX_POINTS",
    "PLAUSIBLE",
    "InputError",
    "InputTypeError",
    "available_memory",
    "check_budget",
    "check_memory",
    "parse_range",
    "validate_angle",
    "validate_array_finite",
    "validate_dataset",
    "validate_finite",
    "validate_fs",
    "validate_in_range",
    "validate_int",
    "validate_model",
    "validate_plausible",
    "validate_positive",
    "validate_sign",
    "work_limit_seconds",
]


class InputError(ValueError):
    """Bad user input: a parameter value, a range, a file or a configuration.

    Subclasses ``ValueError`` so library users can catch it as such; the CLI reports it
    in one line and exits with code 2.
    """


class InputTypeError(InputError, TypeError):
    """An argument of the wrong type (a string where a model is wanted, a dict for a Dataset).

    Both an :class:`InputError` (the CLI's exit 2) and a ``TypeError`` (Python's convention).
    """


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


#: The model base classes by kind (``"friction"``, ``"fe"``), registered by the modules that define them
#: (:func:`register_model_type`): this foundation checks models without importing the layers above it.
_MODEL_TYPES: dict[str, tuple[type, ...]] = {}


def register_model_type(kind: str, cls: type) -> None:
    """Make instances of ``cls`` pass :func:`validate_model` as models of ``kind`` (``"friction"`` or ``"fe"``)."""
    _MODEL_TYPES[kind] = (*_MODEL_TYPES.get(kind, ()), cls)


def validate_model(model: object, name: str = "model", *, kind: str = "any") -> object:
    """Return ``model`` if it is a squealkit model, else one line naming the argument and its type.

    ``kind``: ``"any"`` (a friction model or an :class:`~squealkit.fe.model.FEModel`), ``"friction"``
    (a preset, a rig's model, a matrix model) or ``"fe"``.
    """
    friction, fe = _MODEL_TYPES.get("friction", ()), _MODEL_TYPES.get("fe", ())
    kinds = {"any": ((*friction, *fe), "a squealkit model (get_preset, load_model, FEModel)"),
             "friction": (friction, "a squealkit model (get_preset, load_model; not an FE model here)"),
             "fe": (fe, "an FEModel (load_fe_model, FEModel.from_matrices)")}[kind]
    if not isinstance(model, kinds[0]):
        raise InputTypeError(f"{name} must be {kinds[1]}, not {type(model).__name__} {_short(model)}.")
    return model


def validate_dataset(ds: object, name: str = "ds", *, variables: Sequence[str] = (), attrs: Sequence[str] = (),
                     what: str = "") -> object:
    """Return ``ds`` if it is an ``xarray.Dataset`` holding ``variables`` and ``attrs``, else one line naming it.

    ``what`` names the function whose result is wanted (``"simulate"``), for the message.
    """
    import xarray as xr

    if not isinstance(ds, xr.Dataset):
        of = f" ({what})" if what else ""
        raise InputTypeError(f"{name} must be an xarray.Dataset{of}, not {type(ds).__name__} {_short(ds)}.")
    missing = [v for v in variables if v not in ds.variables] + [a for a in attrs if a not in ds.attrs]
    if missing:
        of = f" {what}" if what else ""
        raise InputError(f"{name} is not a{of} result: it has no {', '.join(map(repr, missing))}.")
    return ds


def validate_int(name: str, value: object, minimum: int, maximum: int | None = None) -> int:
    """Return ``value`` as an int in ``[minimum, maximum]``, rejecting bools, floats and text."""
    upper = f" and <= {maximum}" if maximum is not None else ""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputTypeError(f"Parameter {name}={_short(value)} must be an integer >= {minimum}{upper}, "
                             f"not {type(value).__name__}.")
    if value < minimum or (maximum is not None and value > maximum):
        raise InputError(f"Parameter {name}={value!r} must be an integer >= {minimum}{upper}.")
    return int(value)


def _as_float(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, Real | np.number | str):
        raise InputError(f"Parameter {name}={value!r} is not a number.")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as e:
        raise InputError(f"Parameter {name}={value!r} is not a number.") from e


def validate_finite(name: str, value: object) -> float:
    """Return ``value`` as a float, rejecting non-numbers, NaN and infinities."""
    x = _as_float(name, value)
    if not math.isfinite(x):
        raise InputError(f"Parameter {name}={x!r} must be finite.")
    return x


def validate_positive(name: str, value: object, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a float that is finite and > 0 (or >= 0 with ``allow_zero``)."""
    x = validate_finite(name, value)
    if x < 0 or (x == 0 and not allow_zero):
        need = ">= 0" if allow_zero else "> 0"
        raise InputError(f"Parameter {name}={x!r} must be {need}.")
    return x


def validate_angle(name: str, value: object) -> float:
    """Return an angle in radians, finite and strictly inside (-90 deg, 90 deg)."""
    x = validate_finite(name, value)
    if not abs(x) < math.pi / 2:
        raise InputError(
            f"Parameter {name}={x!r} rad ({math.degrees(x):.6g} deg) must lie strictly "
            "between -90 and 90 deg."
        )
    return x


def validate_sign(name: str, value: object) -> int:
    """Return +1 or -1; anything else is rejected."""
    x = validate_finite(name, value)
    if x not in (1.0, -1.0):
        raise InputError(f"Parameter {name}={value!r} must be +1 or -1.")
    return int(x)


def validate_fs(fs: object, name: str = "fs") -> float:
    """Return a sample rate in Hz: finite and > 0."""
    return validate_positive(name, fs)


def validate_array_finite(name: str, values: ArrayLike) -> NDArray[np.float64]:
    """Return ``values`` as a float64 array with only finite entries."""
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InputError(f"Parameter {name} must be numeric: {e}") from e
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise InputError(f"Parameter {name} contains a non-finite value ({bad!r}).")
    return arr


def available_memory() -> int:
    """Bytes of memory available to a new allocation now (Linux: ``MemAvailable``)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 1 << 62


def _gib(nbytes: float) -> str:
    return f"{nbytes / 2**30:.1f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.0f} MiB"


def check_memory(nbytes: float, what: str, hint: str = "") -> None:
    """Refuse, before allocating, work that will not fit in the memory available now.

    ``nbytes`` is an estimate of the peak; work above 80 % of what is available is refused
    with one line naming it, the estimate and what is available (and ``hint``, how to
    make it fit).
    """
    avail = available_memory()
    if not nbytes <= 0.8 * avail:
        tail = f" {hint}" if hint else ""
        raise InputError(f"{what} needs about {_gib(nbytes)} of memory; {_gib(avail)} is available.{tail}")


#: The most grid points (operating points, samples of a sweep) one result may hold: a 10 000 x
#: 10 000 map, about 8 GB as zarr. No figure or analysis needs more; split the range into runs.
MAX_POINTS = 10**8

#: The longest run started without being asked for [h]: a run estimated longer is refused up
#: front. The environment variable ``SQUEALKIT_MAX_HOURS`` sets another limit.
MAX_HOURS = 2.0


def work_limit_seconds() -> float:
    """The work budget of one run [s]: ``SQUEALKIT_MAX_HOURS`` hours, else :data:`MAX_HOURS`."""
    text = os.environ.get("SQUEALKIT_MAX_HOURS", "").strip()
    if not text:
        return MAX_HOURS * 3600.0
    try:
        hours = float(text)
    except ValueError:
        hours = float("nan")
    if not hours > 0:
        raise InputError(f"SQUEALKIT_MAX_HOURS={text!r} must be a number of hours > 0.")
    return hours * 3600.0


def _duration(seconds: float) -> str:
    if seconds >= 86400 * 365:
        return f"{seconds / (86400 * 365):.3g} years"
    if seconds >= 86400:
        return f"{seconds / 86400:.3g} days"
    return f"{seconds / 3600:.3g} h" if seconds >= 3600 else f"{seconds / 60:.3g} min"


def check_budget(what: str, *, points: float = 0.0, nbytes: float = 0.0, seconds: float = 0.0,
                 hint: str = "") -> None:
    """Refuse, before any work, a run beyond the points, memory or time one run may take.

    Every entry point that can be asked for unbounded work estimates it here first: ``points``
    (grid points of the result, at most :data:`MAX_POINTS`), ``nbytes`` (peak memory, see
    :func:`check_memory`) and ``seconds`` (a lower estimate of the run time, at most
    :func:`work_limit_seconds`). One line names the request, the estimate and the limit.
    """
    tail = f" {hint}" if hint else ""
    if not points <= MAX_POINTS:
        raise InputError(f"{what} has {points:.3g} points, above the {MAX_POINTS:.0e} one result may hold.{tail}")
    check_memory(nbytes, what, hint)
    limit = work_limit_seconds()
    if not seconds <= limit:
        raise InputError(f"{what} would take at least {_duration(seconds)}, above the {limit / 3600:g} h one run "
                         f"may take (SQUEALKIT_MAX_HOURS sets the limit).{tail}")


def validate_in_range(name: str, value: object, lo: float, hi: float, unit: str = "", *,
                      open_low: bool = False, why: str = "") -> float:
    """Return ``value`` as a finite float in ``[lo, hi]`` (``(lo, hi]`` with ``open_low``).

    The bounds are physical plausibility, not numerics: a value outside them is a unit or
    typing mistake, refused with one line naming it and the accepted range before it reaches
    a solver (where 1e300 overflows).
    """
    x = validate_finite(name, value)
    if x > hi or x < lo or (open_low and x == lo):
        u = f" {unit}" if unit else ""
        left = "(" if open_low else "["
        reason = f" ({why})" if why else ""
        raise InputError(f"Parameter {name}={x!r}{u} is outside the accepted range {left}{lo:g}, {hi:g}]{u}{reason}.")
    return x


#: Physically plausible ranges, declared once per quantity: quantity -> (low, high, unit, why).
#: A value beyond them is a unit or typing mistake (``1e300``): refused with one line before
#: it reaches a solver, by the API and so by the CLI.
PLAUSIBLE: dict[str, tuple[float, float, str, str]] = {
    "friction": (0.0, 100.0, "", "no contact has a friction coefficient above 100"),
    "speed": (0.0, 1e3, "m/s", "no brake or rig slides faster than 1000 m/s"),
    "rpm": (1e-3, 1e6, "rpm", "a disc between one turn in 1000 min and 1e6 rpm"),
    "level_dba": (-50.0, 200.0, "dB(A)", "sound in air stays below about 194 dB"),
    "acoustic_delay": (0.0, 1.0, "s", "a microphone within about 340 m of the pin"),
    "runout_amplitude": (0.0, 1e-2, "m", "disc run-out is micrometres, never above 1 cm"),
    "pressure_pa": (0.0, 1e6, "Pa", "a microphone's sound pressure stays below 1e6 Pa (214 dB)"),
}


def validate_plausible(name: str, value: object, quantity: str | None = None) -> float:
    """Return ``value`` as a float within the plausible range of ``quantity`` (default ``name``)
    declared in :data:`PLAUSIBLE`; one line naming the value and the range otherwise."""
    lo, hi, unit, why = PLAUSIBLE[quantity or name]
    return validate_in_range(name, value, lo, hi, unit, why=why)


_RANGE_RE = re.compile(r"^\s*([^:]+):([^:]+):([^:]+)\s*$")


def parse_range(name: str, text: str | Sequence[float] | float) -> NDArray[np.float64]:
    """Parse a grid given as ``"START:STOP:N"`` (N points, both ends included) or a number.

    Examples
    --------
    >>> parse_range("mu", "0:0.8:5")
    array([0. , 0.2, 0.4, 0.6, 0.8])
    """
    if isinstance(text, int | float | np.number) and not isinstance(text, bool):
        return np.array([validate_finite(name, text)])
    if not isinstance(text, str):
        return validate_array_finite(name, text)
    m = _RANGE_RE.match(text)
    if m is None:
        try:
            return np.array([validate_finite(name, text.strip())])
        except InputError:
            raise InputError(
                f"Parameter {name}={text!r} is not a range: use START:STOP:N "
                "(N points, ends included) or a single number."
            ) from None
    start = validate_finite(f"{name} start", m.group(1).strip())
    stop = validate_finite(f"{name} stop", m.group(2).strip())
    n_text = m.group(3).strip()
    try:
        n = int(n_text)
    except ValueError:
        raise InputError(
            f"Parameter {name}={text!r}: the point count N={n_text!r} is not a whole number."
        ) from None
    if n < 1:
        raise InputError(f"Parameter {name}={text!r}: the point count N={n} must be >= 1.")
    if n == 1 and start != stop:
        raise InputError(f"Parameter {name}={text!r}: one point needs START == STOP.")
    check_budget(f"Parameter {name}={text!r}", points=n, nbytes=32.0 * n)  # the grid, derived coordinates
    return np.linspace(start, stop, n)
