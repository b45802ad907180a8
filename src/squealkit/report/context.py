"""What several steps of one report share, computed once per report.

The damped onset on a flat disc (:func:`~squealkit.stability.critical_friction` at theta = 0) is
read by the operating point (:meth:`ReportSettings.for_model`), the Fig. 2 and critical-friction
sections, the limit cycles and the measurement section. :func:`~squealkit.report.reproduce` makes
one :class:`ReportContext` per report and hands it to each; a step called on its own (without one)
computes what it needs itself.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..models import FrictionModel
    from ..stability import CriticalFriction

__all__ = []


class ReportContext:
    """Results shared by the steps of one report, each computed on first use.

    A result's warnings are recorded when it is computed and issued again at every use, so each
    step's own warning filters decide, as they did when each step computed it itself.
    """

    def __init__(self) -> None:
        self._onsets: list[tuple[FrictionModel, bool, CriticalFriction, list[warnings.WarningMessage]]] = []

    def flat_onset(self, model: FrictionModel, *, damped: bool = True) -> CriticalFriction:
        """``critical_friction(model, 0.0, damped=damped)``, computed once per model and ``damped``."""
        for m, d, onset, said in self._onsets:
            if d == damped and m == model:
                _say_again(said)
                return onset
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            onset = _critical_friction(model, damped)
        self._onsets.append((model, damped, onset, said))
        _say_again(said)
        return onset


def _critical_friction(model: FrictionModel, damped: bool) -> CriticalFriction:
    from ..stability import critical_friction

    return critical_friction(model, 0.0, damped=damped)


def _say_again(said: list[warnings.WarningMessage]) -> None:
    for w in said:
        warnings.warn(w.message, stacklevel=3)


def flat_onset(model: FrictionModel, context: ReportContext | None = None, *, damped: bool = True) -> CriticalFriction:
    """The onset on a flat disc (theta = 0): from the report's ``context`` when there is one."""
    if context is None:
        return _critical_friction(model, damped)
    return context.flat_onset(model, damped=damped)
