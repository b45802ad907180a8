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
    "InputError",
    "InputTypeError",
    "available_memory",
    "check_memory",
    "parse_range",
    "validate_angle",
    "validate_array_finite",
    "validate_dataset",
    "validate_finite",
    "validate_fs",
    "validate_int",
    "validate_model",
    "validate_positive",
    "validate_sign",
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


def validate_model(model: object, name: str = "model", *, kind: str = "any") -> object:
    """Return ``model`` if it is a squealkit model, else one line naming the argument and its type.

    ``kind``: ``"any"`` (a friction model or an :class:`~squealkit.models.fe.FEModel`), ``"friction"``
    (a preset, a rig's model, a matrix model) or ``"fe"``.
    """
    from .models._base import FrictionModel
    from .models.fe import FEModel

    kinds = {"any": ((FrictionModel, FEModel), "a squealkit model (get_preset, load_model, FEModel)"),
             "friction": ((FrictionModel,), "a squealkit model (get_preset, load_model; not an FE model here)"),
             "fe": ((FEModel,), "an FEModel (load_fe_model, FEModel.from_matrices)")}[kind]
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
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputTypeError(f"Parameter {name}={_short(value)} must be an integer, not {type(value).__name__}.")
    if value < minimum or (maximum is not None and value > maximum):
        upper = f" and <= {maximum}" if maximum is not None else ""
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
    if nbytes > 0.8 * avail:
        tail = f" {hint}" if hint else ""
        raise InputError(f"{what} needs about {_gib(nbytes)} of memory; {_gib(avail)} is available.{tail}")


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
    check_memory(32.0 * n, f"Parameter {name}={text!r} ({n} points)")  # the grid and its derived coordinates
    return np.linspace(start, stop, n)
