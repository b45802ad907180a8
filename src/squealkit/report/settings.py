"""The operating point a report is written for: friction values, run-out and sliding speed.

The paper fixes its own (§4: mu = 0.4 and 0.6, v = 0.02 m/s; Fig. 4: q0 = 80 um, lambda = 1 mm;
the run-out tolerance at mu = 0.3). Those numbers are the paper's rig's; for another rig they may
sit far from its onset. A model file's ``[report]`` table sets them::

    [report]
    mu_design = 0.05        # friction of the run-out tolerance
    mu_transient = 0.06     # Fig. 3's first case and Fig. 4's friction
    mu_unstable = 0.09      # Fig. 3's clearly unstable case
    mu_cycle = 0.08         # friction at which the limit-cycle amplitude is quoted
    sro_amplitude = 4e-6    # m, sine run-out amplitude q0 of Fig. 4
    sro_wavelength = 1e-3   # m
    speed = 0.02            # m/s, sliding speed

A value may carry its own unit as text (``sro_amplitude = "4 um"``, ``speed = "20 mm/s"``), as in
the model file's other tables; a bare number is in the unit above. The FE report's keys
(:mod:`squealkit.report.fe_modes`) are declared and parsed the same way (:func:`report_key`).

Without the table, the paper's preset gets the paper's values and another model gets values
placed from its own damped onset on a flat disc (:meth:`ReportSettings.for_model`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import MISSING, Field, dataclass, field, fields, replace
from pathlib import Path
from typing import Any, ClassVar

from .._operating_point import SPEED
from .._validation import InputError, validate_finite, validate_int, validate_positive
from ..models import FrictionModel
from .context import ReportContext

__all__ = ["ReportSettings"]

# ----------------------------------------------------------------------------- the [report] table's keys

#: What a key of a ``[report]`` table holds, and the words of what it accepts.
_KINDS = {
    "finite": "a number",
    "positive": "a number > 0",
    "values": "a number or a list of numbers",
    "band": "[LOW, HIGH] with 0 < LOW < HIGH",
    "sweep": "[START, STOP, N] with an integer N >= 2",
    "count": "an integer >= 1",
    "choice": "one of the names",
}


def report_key(default: Any = MISSING, *, unit: str, doc: str, kind: str = "finite",
               choices: Callable[[], tuple[str, ...]] | None = None) -> Any:
    """Declare a key of a ``[report]`` table: a dataclass field with its unit, meaning and check.

    One declaration drives the table's parsing (:func:`report_table_values`), the settings'
    own check on construction (:func:`check_report_keys`) and the error messages, for the
    small-model report (:class:`ReportSettings`) and the FE report
    (:class:`~squealkit.report.fe_modes.FEReportSettings`) alike.

    Parameters
    ----------
    default : object, optional
        The field's default.
    unit : str
        SI unit the value is held in (``"1"`` dimensionless, ``"m"``, ``"m/s"``, ``"Hz"``, ``"rpm"``;
        ``""`` for a count or a name). A value written with its own unit (``"80 um"``, ``"9 kHz"``)
        is converted to it; a bare number is taken in it.
    doc : str
        What the key is, in words.
    kind : str
        ``finite``, ``positive``, ``values`` (one number or a list: a tuple), ``band`` ((LOW, HIGH)
        or None), ``sweep`` ((START, STOP, N)), ``count`` (an integer >= 1) or ``choice``.
    choices : callable, optional
        For ``kind="choice"``: returns the accepted names (called when a value is checked, so a
        heavy module is imported only then).
    """
    if kind not in _KINDS or (kind == "choice") != (choices is not None):
        raise ValueError(f"report key kind {kind!r} with choices {choices!r}")
    return field(default=default, metadata={"unit": unit, "doc": doc, "report_kind": kind, "choices": choices})


def _number(name: str, value: object, unit: str) -> float:
    """A finite number in ``unit``: a number, or text (a number, or a number with its unit: ``"80 um"``)."""
    if unit in ("", "1"):
        return validate_finite(name, value)
    from .._units import parse_quantity

    return validate_finite(name, parse_quantity(name, value, unit))


def report_value(f: Field, value: Any, name: str) -> Any:
    """``value`` of the declared key ``f``, converted to its unit and checked; one-line InputError naming ``name``.

    Parameters
    ----------
    f : dataclasses.Field
        A field declared with :func:`report_key`.
    value : object
        The value as written (a TOML value, or what the caller passed).
    name : str
        The key as the messages name it (``"[report] rpm"`` for a table, ``"rpm"`` for the API).

    Returns
    -------
    float, tuple, int, str or None
        The value in the key's unit and shape.
    """
    kind, unit = f.metadata["report_kind"], f.metadata["unit"]
    accepted = _KINDS[kind] + (f" [{unit}]" if unit not in ("", "1") else "")
    if kind == "finite":
        return _number(name, value, unit)
    if kind == "positive":
        return validate_positive(name, _number(name, value, unit))
    if kind == "count":
        return validate_int(name, value, 1)
    if kind == "choice":
        known = f.metadata["choices"]()
        if value not in known:
            raise InputError(f"{name} = {value!r}; known: {', '.join(known)}.")
        return value
    if kind == "band" and value is None:
        return None
    many = isinstance(value, list | tuple)
    if kind == "values":
        values = value if many else [value]
        if not values:
            raise InputError(f"{name} is empty; give {accepted}.")
        return tuple(_number(name, v, unit) for v in values)
    if kind == "band":
        if not (many and len(value) == 2):
            raise InputError(f"{name} = {value!r} must be {accepted}.")
        lo, hi = (validate_positive(name, _number(name, v, unit)) for v in value)
        if not lo < hi:
            raise InputError(f"{name} = {value!r}: LOW must be below HIGH.")
        return (lo, hi)
    if not (many and len(value) == 3):  # a sweep
        raise InputError(f"{name} = {value!r} must be {accepted}.")
    return (_number(name, value[0], unit), _number(name, value[1], unit), validate_int(f"{name} N", value[2], 2))


def check_report_keys(settings: Any) -> None:
    """Convert and check every declared key of a frozen settings dataclass in place (its ``__post_init__``)."""
    for f in fields(settings):
        if "report_kind" in f.metadata:
            object.__setattr__(settings, f.name, report_value(f, getattr(settings, f.name), f.name))


def report_table_values(cls: type, table: Mapping[str, Any], *, what: str, name: str = "[report]") -> dict[str, Any]:
    """The values of a ``[report]`` table for the settings class ``cls``: each converted and checked.

    Parameters
    ----------
    cls : type
        A settings dataclass whose keys are declared with :func:`report_key`.
    table : mapping
        ``NAME = VALUE`` pairs.
    what : str
        Whose table it is, for the message on an unknown key (``"an FE model's report"``).
    name : str
        The table's name in messages.

    Returns
    -------
    dict
        Key to value, in the keys' units.

    Raises
    ------
    InputError
        One line naming an unknown key (and the known ones) or a bad value (and what is accepted).
    """
    declared = {f.name: f for f in fields(cls) if "report_kind" in f.metadata}
    for key in table:
        if key not in declared:
            raise InputError(f"{name}: unknown key {key!r} for {what}; known: {', '.join(declared)}.")
    return {key: report_value(declared[key], value, f"{name} {key}") for key, value in table.items()}


def read_report_table(path: str | Path | None) -> Mapping[str, Any] | None:
    """The ``[report]`` table of a model file (None: no file, or no table); not a table is an InputError."""
    if path is None:
        return None
    from ..models.config import _read_toml

    table = _read_toml(path).get("report")
    if table is not None and not isinstance(table, Mapping):
        raise InputError(f"{Path(path).name}: [report] must be a table of NAME = VALUE.")
    return table


def settings_from_file(path: str | Path | None, cls: type, default: Callable[[], Any]) -> Any:
    """``default()`` with the ``[report]`` table of the model file ``path`` (``cls.from_table``); errors name the file.

    The table is checked before ``default()`` places the defaults (that may be work, and may warn),
    so a bad table is refused first, in one line.
    """
    table = read_report_table(path)
    if table is None:
        return default()
    try:
        report_table_values(cls, table, what=cls.table_of)
    except InputError as e:
        raise InputError(f"{Path(path).name}: {e}") from e  # type: ignore[arg-type]
    return cls.from_table(table, default())


# ----------------------------------------------------------------------------- the small model's operating point


@dataclass(frozen=True)
class ReportSettings:
    """Where a report looks at its model: frictions, the Fig. 4 run-out and the sliding speed.

    Attributes
    ----------
    mu_design : float
        Friction of the run-out tolerance (paper: 0.3).
    mu_transient : float
        Friction of Fig. 3's first case and of the Fig. 4 run-out run (paper §4: 0.4).
    mu_unstable : float
        Friction of the Fig. 3 figure, meant to be clearly unstable (paper: 0.6).
    mu_cycle : float
        Friction at which the limit-cycle amplitude is quoted (0.5 in the paper's report).
    sro_amplitude : float
        Sine run-out amplitude q0 [m] (paper Fig. 4: 80e-6).
    sro_wavelength : float
        Sine run-out wavelength lambda [m] (paper Fig. 4: 1e-3).
    speed : float
        Sliding speed v [m/s] (paper §4: 0.02).
    source : str
        Where the values come from, in words, for the report's text.
    """

    mu_design: float = report_key(0.3, unit="1", doc="friction of the run-out tolerance")
    mu_transient: float = report_key(0.4, unit="1", doc="friction of Fig. 3's first case and Fig. 4")
    mu_unstable: float = report_key(0.6, unit="1", doc="friction of Fig. 3's clearly unstable case")
    mu_cycle: float = report_key(0.5, unit="1", doc="friction at which the limit-cycle amplitude is quoted")
    sro_amplitude: float = report_key(80e-6, unit="m", kind="positive", doc="sine run-out amplitude q0")
    sro_wavelength: float = report_key(1e-3, unit="m", kind="positive", doc="sine run-out wavelength")
    speed: float = report_key(SPEED, unit="m/s", kind="positive", doc="sliding speed")
    source: str = "the paper's operating point (§4, Fig. 4)"
    #: Whose ``[report]`` table this is, in messages.
    table_of: ClassVar[str] = "a small model's report"

    def __post_init__(self) -> None:
        check_report_keys(self)

    @property
    def sro_slope(self) -> float:
        """The steepest slope of the sine run-out, 2 pi q0 / lambda (eq. 11)."""
        return 2.0 * math.pi * self.sro_amplitude / self.sro_wavelength

    @property
    def is_paper(self) -> bool:
        """True when the operating point is the paper's."""
        keys = [f.name for f in fields(self) if f.name != "source"]
        return all(getattr(self, k) == getattr(ReportSettings(), k) for k in keys)

    @classmethod
    def paper(cls) -> ReportSettings:
        """The paper's operating point."""
        return cls()

    @classmethod
    def for_model(cls, model: FrictionModel, *, context: ReportContext | None = None) -> ReportSettings:
        """An operating point placed from the model's damped onset mu_c on a flat disc.

        The tolerance at 0.75 mu_c, the transients just below onset (0.9 mu_c) and clearly above
        it (1.5 mu_c), the limit cycle quoted at 1.3 mu_c, and a 1 mm run-out whose steepest slope
        is 0.3 mu_c, so that Fig. 4's mu + tan(theta) swings through the onset as in the paper.
        A model without a damped onset up to mu = 2 gets the paper's values, and says so.

        Parameters
        ----------
        model : FrictionModel
            The report's model.
        context : ReportContext, optional
            The report's shared results: its flat-disc onset is computed once per report.

        Returns
        -------
        ReportSettings
            With ``source`` saying where the values come from.
        """
        from ..stability import UnrealisticFrictionWarning
        from .context import flat_onset

        with warnings.catch_warnings():  # an onset beyond friction materials: the report's §3 says so
            warnings.simplefilter("ignore", UnrealisticFrictionWarning)
            crit = flat_onset(model, context)
        if crit.status != "onset" or not math.isfinite(crit.mu_critical) or crit.mu_critical <= 0:
            return replace(cls(), source="the paper's operating point: this model has no damped onset on a flat "
                                         "disc up to mu = 2 to place one from")
        c = crit.mu_critical
        wavelength = 1e-3
        return cls(mu_design=_round(0.75 * c), mu_transient=_round(0.9 * c), mu_unstable=_round(1.5 * c),
                   mu_cycle=_round(1.3 * c), sro_amplitude=float(f"{0.3 * c * wavelength / (2 * math.pi):.2g}"),
                   sro_wavelength=wavelength, speed=SPEED,
                   source=f"placed from this model's damped onset on a flat disc, mu_crit = {c:.4g}")

    @classmethod
    def from_table(cls, table: Mapping[str, Any], base: ReportSettings, name: str = "[report]") -> ReportSettings:
        """``base`` with the values of a ``[report]`` table; an unknown key is an error.

        Parameters
        ----------
        table : mapping
            ``NAME = VALUE`` pairs, names of this class's fields (SI units: m, m/s; a value may
            carry its own unit as text, ``"80 um"``, ``"20 mm/s"``).
        base : ReportSettings
            The values the table does not set.
        name : str
            The table's name in error messages.

        Returns
        -------
        ReportSettings
        """
        values = report_table_values(cls, table, what=cls.table_of, name=name)
        rest = [f.name for f in fields(cls) if "report_kind" in f.metadata and f.name not in values]
        return replace(base, **values, source=f"the model file's {name} table"
                       + (f"; {', '.join(rest)}: {base.source}" if rest else ""))


def _round(x: float) -> float:
    """Three significant digits: an operating point, not a computed result."""
    return float(f"{x:.3g}")


def load_report_settings(path: str | Path | None, model: FrictionModel, *, paper: bool,
                         context: ReportContext | None = None) -> ReportSettings:
    """The operating point of a report on ``model``: a model file's ``[report]`` table over the defaults.

    Parameters
    ----------
    path : path-like or None
        The model file (TOML), or None.
    model : FrictionModel
        The report's model, to place the defaults from.
    paper : bool
        The model is the paper's: its defaults are the paper's values.
    context : ReportContext, optional
        The report's shared results (the flat-disc onset the defaults are placed from).

    Returns
    -------
    ReportSettings
    """
    return settings_from_file(path, ReportSettings, ReportSettings.paper if paper
                              else lambda: ReportSettings.for_model(model, context=context))
