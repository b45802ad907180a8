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

Without the table, the paper's preset gets the paper's values and another model gets values
placed from its own damped onset on a flat disc (:meth:`ReportSettings.for_model`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from .._validation import InputError, validate_finite, validate_positive
from ..models import FrictionModel

__all__ = ["ReportSettings", "load_report_settings"]


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

    mu_design: float = 0.3
    mu_transient: float = 0.4
    mu_unstable: float = 0.6
    mu_cycle: float = 0.5
    sro_amplitude: float = 80e-6
    sro_wavelength: float = 1e-3
    speed: float = 0.02
    source: str = "the paper's operating point (§4, Fig. 4)"

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "source":
                continue
            value = getattr(self, f.name)
            if f.name.startswith("mu_"):
                validate_finite(f.name, value)
            else:
                validate_positive(f.name, value)

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
    def for_model(cls, model: FrictionModel) -> ReportSettings:
        """An operating point placed from the model's damped onset mu_c on a flat disc.

        The tolerance at 0.75 mu_c, the transients just below onset (0.9 mu_c) and clearly above
        it (1.5 mu_c), the limit cycle quoted at 1.3 mu_c, and a 1 mm run-out whose steepest slope
        is 0.3 mu_c, so that Fig. 4's mu + tan(theta) swings through the onset as in the paper.
        A model without a damped onset up to mu = 2 gets the paper's values, and says so.

        Parameters
        ----------
        model : FrictionModel
            The report's model.

        Returns
        -------
        ReportSettings
            With ``source`` saying where the values come from.
        """
        from ..stability import UnrealisticFrictionWarning, critical_friction

        with warnings.catch_warnings():  # an onset beyond friction materials: the report's §3 says so
            warnings.simplefilter("ignore", UnrealisticFrictionWarning)
            crit = critical_friction(model, 0.0, damped=True)
        if crit.status != "onset" or not math.isfinite(crit.mu_critical) or crit.mu_critical <= 0:
            return replace(cls(), source="the paper's operating point: this model has no damped onset on a flat "
                                         "disc up to mu = 2 to place one from")
        c = crit.mu_critical
        wavelength = 1e-3
        return cls(mu_design=_round(0.75 * c), mu_transient=_round(0.9 * c), mu_unstable=_round(1.5 * c),
                   mu_cycle=_round(1.3 * c), sro_amplitude=float(f"{0.3 * c * wavelength / (2 * math.pi):.2g}"),
                   sro_wavelength=wavelength, speed=0.02,
                   source=f"placed from this model's damped onset on a flat disc, mu_crit = {c:.4g}")

    @classmethod
    def from_table(cls, table: Mapping[str, Any], base: ReportSettings, name: str = "[report]") -> ReportSettings:
        """``base`` with the values of a ``[report]`` table; an unknown key is an error.

        Parameters
        ----------
        table : mapping
            ``NAME = VALUE`` pairs, names of this class's fields (SI units: m, m/s).
        base : ReportSettings
            The values the table does not set.
        name : str
            The table's name in error messages.

        Returns
        -------
        ReportSettings
        """
        known = [f.name for f in fields(cls) if f.name != "source"]
        values = {}
        for key, value in table.items():
            if key not in known:
                raise InputError(f"Unknown {name} key {key!r}; known: {', '.join(known)}.")
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(f"{name} {key} = {value!r} must be a number.")
            values[key] = float(value)
        rest = [k for k in known if k not in values]
        return replace(base, **values, source=f"the model file's {name} table"
                       + (f"; {', '.join(rest)}: {base.source}" if rest else ""))


def _round(x: float) -> float:
    """Three significant digits: an operating point, not a computed result."""
    return float(f"{x:.3g}")


def load_report_settings(path: str | Path | None, model: FrictionModel, *, paper: bool) -> ReportSettings:
    """The operating point of a report on ``model``: a model file's ``[report]`` table over the defaults.

    Parameters
    ----------
    path : path-like or None
        The model file (TOML), or None.
    model : FrictionModel
        The report's model, to place the defaults from.
    paper : bool
        The model is the paper's: its defaults are the paper's values.

    Returns
    -------
    ReportSettings
    """
    from ..models.config import _read_toml

    base = ReportSettings.paper() if paper else ReportSettings.for_model(model)
    if path is None:
        return base
    table = _read_toml(path).get("report")
    if table is None:
        return base
    if not isinstance(table, Mapping):
        raise InputError(f"{Path(path).name}: [report] must be a table of NAME = VALUE.")
    try:
        return ReportSettings.from_table(table, base)
    except InputError as e:
        raise InputError(f"{Path(path).name}: {e}") from e
