"""Units of user inputs: values written with a unit ("25 mm", "2.9 kHz", "80 um"), and unit slips.

squealkit works in SI. A value a user writes may carry its unit, in a model file, after ``--set``
or on the command line; it is converted to the unit its parameter declares (``param(default,
unit=...)``) with pint. A bare number is taken in that declared unit. A quantity whose plausible
range is declared (``param(..., plausible=(lo, hi))``, or a CLI option's :class:`Quantity`) is
checked against it, and a value outside that a common unit slip would bring inside (mm written
as m, kHz as Hz) is refused naming the slip: ``radius = 60 m is implausible for the probe radius;
did you mean 60 mm? write '60 mm'``.

Recording channels are converted to SI as they are read (:func:`channel_to_si`): a probe in
``um`` gives metres, a microphone in ``mPa`` pascals.
"""

from __future__ import annotations

import functools
import math
import warnings
from typing import Any

from ._validation import InputError

__all__: list[str] = []

#: The unit slips tried on an implausible bare number, per declared SI unit: what the user
#: probably meant (the number written in that unit).
SLIPS: dict[str, tuple[str, ...]] = {
    "m": ("mm", "um", "cm"),
    "Hz": ("kHz",),
    "Pa": ("MPa", "GPa"),
    "kg": ("g",),
    "kg/m^3": ("g/cm^3",),
    "rad": ("deg",),
    "N": ("kN",),
    "m/s": ("mm/s",),
}

#: SI unit of a recording channel, per dimensionality: channels in one of these are converted to it.
_CHANNEL_SI = {
    "[length]": "m",
    "[mass] / [length] / [time] ** 2": "Pa",
    "[length] / [time]": "m/s",
    "[length] / [time] ** 2": "m/s^2",
    "[mass] * [length] / [time] ** 2": "N",
    "[mass] * [length] ** 2 / [time] ** 3 / [current]": "V",
}
#: Units written as squealkit writes them (no conversion, no pint).
_SI_AS_IS = {"", "m", "Pa", "m/s", "m/s^2", "m/s**2", "N", "V", "1", "s", "Hz", "rad", "deg", "rpm"}


@functools.lru_cache(maxsize=1)
def registry() -> Any:
    """The pint unit registry (built once, on first use: about 0.3 s)."""
    import pint

    ureg = pint.UnitRegistry()
    ureg.formatter.default_format = "~"
    return ureg


def _pint_unit(unit: str) -> str:
    """squealkit's unit notation in pint's: ``N s/m`` -> ``N*s/m``, ``kg/m^3`` stays (pint reads ^)."""
    return " ".join(unit.split()).replace(" ", "*") if unit not in ("", "1") else "dimensionless"


def _factor(src: str, dst: str) -> float:
    """Factor from unit ``src`` to unit ``dst`` (pint)."""
    ureg = registry()
    return float(ureg.Quantity(1.0, _pint_unit(src)).to(_pint_unit(dst)).magnitude)


def _scale(x: float, factor: float) -> float:
    """``x * factor``, by a power of ten as one correctly rounded operation (80 um is 8e-05 m, not
    80 * 1e-6 = 7.999999999999999e-05)."""
    k = round(math.log10(factor)) if factor > 0 else 0
    if factor > 0 and factor == 10.0 ** k:
        return x * 10.0 ** k if k >= 0 else x / 10.0 ** -k
    return x * factor


def parse_quantity(name: str, value: Any, unit: str, *, plausible: tuple[float, float] | None = None,
                   what: str | None = None) -> float:
    """``value`` in ``unit``: a number as it is, or a string with its own unit converted.

    Parameters
    ----------
    name : str
        The parameter or option, for messages.
    value : float or str
        A number (in ``unit``), or text: a number (``"0.025"``) or a number and a unit
        (``"25 mm"``, ``"2.9 kHz"``, ``"80 um"``, ``"2 deg"``).
    unit : str
        The declared SI unit, e.g. ``"m"``, ``"Hz"``, ``"N s/m"``, ``"rad"``.
    plausible : (float, float), optional
        The range a value of this quantity lies in; outside it a likely unit slip is refused
        (see the module docstring), anything else outside it warns.
    what : str, optional
        What the quantity is, in words, for messages (default ``name``).

    Returns
    -------
    float
        The value in ``unit``.

    Raises
    ------
    InputError
        If the text is not a quantity, its unit is not one of ``unit``'s dimension, or a bare
        number is outside ``plausible`` where a common unit slip would bring it inside.

    Examples
    --------
    >>> parse_quantity("pin_diameter", "25 mm", "m")
    0.025
    >>> parse_quantity("disc_freq", "2.9 kHz", "Hz")
    2900.0
    """
    explicit = None
    if isinstance(value, str):
        text = value.strip()
        try:
            number = float(text)
        except ValueError:
            number, explicit = _convert_text(name, text, unit), text
    elif isinstance(value, bool):
        raise InputError(f"Parameter {name}={value!r} must be a number [{unit}], not a boolean.")
    else:
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise InputError(f"Parameter {name}={value!r} must be a number [{unit}] or a quantity such as "
                             f"'{_example(unit)}'.") from None
    if plausible is not None and math.isfinite(number):
        check_plausible(name, number, unit, plausible, what=what, explicit=explicit)
    return number


def _example(unit: str) -> str:
    return {"m": "25 mm", "Hz": "2.9 kHz", "Pa": "2.95 GPa", "kg": "33 g", "rad": "2 deg"}.get(unit, f"1 {unit}")


def _convert_text(name: str, text: str, unit: str) -> float:
    import pint

    ureg = registry()
    try:
        q = ureg.Quantity(text.replace("µ", "u").replace("μ", "u"))
    except (pint.errors.PintError, ValueError, TypeError, AttributeError, SyntaxError) as e:
        raise InputError(f"Parameter {name}={text!r} is not a number nor a quantity such as '{_example(unit)}' "
                         f"({type(e).__name__}).") from None
    try:
        return _scale(float(q.magnitude), float(ureg.Quantity(1.0, q.units).to(_pint_unit(unit)).magnitude))
    except pint.errors.DimensionalityError:
        raise InputError(f"Parameter {name}={text!r} is not in a unit of {unit!r} (e.g. '{_example(unit)}'); "
                         f"'{q.units:~}' is a {q.dimensionality} unit.") from None


def check_plausible(name: str, value: float, unit: str, plausible: tuple[float, float], *,
                    what: str | None = None, explicit: str | None = None) -> None:
    """Refuse a value outside ``plausible`` that a unit slip explains, warn about any other outside it.

    Zero is left to the parameter's own check (an amplitude of 0 is no run-out, not a slip).
    """
    lo, hi = plausible
    if value == 0.0 or lo <= abs(value) <= hi or (value < 0 and unit != "rad"):
        return  # a negative length or frequency is the parameter's own check's to refuse
    what = what or name
    shown = explicit or f"{value:g} {unit}"
    rng = f"{lo:g} to {hi:g} {unit}"
    if explicit is None:
        for slip in SLIPS.get(unit, ()):
            if lo <= abs(_scale(value, _factor(slip, unit))) <= hi:
                raise InputError(f"{name} = {shown} is implausible for {what} (expected {rng}); did you mean "
                                 f"{value:g} {slip}? write '{value:g} {slip}' (a bare number is in {unit}).")
    warnings.warn(f"{name} = {shown} is outside the range plausible for {what} ({rng}); check its unit.",
                  UserWarning, stacklevel=4)


def channel_to_si(unit: str) -> tuple[float, str, bool]:
    """Factor and SI unit of a recording channel's unit: ``"um"`` -> ``(1e-6, "m", True)``.

    Units of a dimension squealkit converts (length, pressure, velocity, acceleration, force,
    voltage) are converted to their SI unit; any other unit is kept as it is (factor 1), and an
    unknown one is reported by the last item, False.

    Parameters
    ----------
    unit : str
        The unit a file or ``--unit`` gives (``""`` when none).

    Returns
    -------
    factor : float
        Value in SI = value in ``unit`` times ``factor``.
    si_unit : str
        The unit after conversion.
    known : bool
        Whether pint knows ``unit`` (an empty unit counts as known).
    """
    u = unit.strip()
    if u in _SI_AS_IS:
        return 1.0, u, True
    import pint

    ureg = registry()
    try:
        q = ureg.Quantity(1.0, u.replace("µ", "u").replace("μ", "u"))
    except (pint.errors.PintError, ValueError, TypeError, AttributeError, SyntaxError, AssertionError):
        return 1.0, u, False
    target = _CHANNEL_SI.get(str(q.dimensionality))
    if target is None:
        return 1.0, u, True
    return _scale(1.0, float(q.to(_pint_unit(target)).magnitude)), target, True
