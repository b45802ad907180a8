"""The report as data: sections with text, tables, published-vs-computed numbers and figures.

Steps of :func:`squealkit.report.reproduce` build :class:`Section` values; :mod:`.html`
renders them. Keeping the content apart from its rendering lets tests check the numbers
without parsing HTML.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["Comparison", "FigureRef", "Section", "Table"]


@dataclass(frozen=True)
class Comparison:
    """A published number beside the one squealkit computed.

    ``published`` may be a number, a ``(low, high)`` band, or None (nothing published).
    ``agrees`` is the caller's verdict with the tolerance stated in ``note``.
    """

    quantity: str
    published: float | tuple[float, float] | None
    computed: float | tuple[float, float] | None
    unit: str
    agrees: bool | None = None
    note: str = ""

    def difference(self) -> str:
        """The relative difference as text ('' when it does not apply)."""
        if isinstance(self.published, int | float) and isinstance(self.computed, int | float):
            if self.published == 0 or not math.isfinite(self.computed):
                return ""
            return f"{100.0 * (self.computed - self.published) / abs(self.published):+.2f} %"
        if isinstance(self.published, tuple) and isinstance(self.computed, tuple):
            lo = 100.0 * (self.computed[0] - self.published[0]) / abs(self.published[0])
            hi = 100.0 * (self.computed[1] - self.published[1]) / abs(self.published[1])
            return f"{lo:+.2f} % / {hi:+.2f} %"
        return ""


@dataclass(frozen=True)
class Table:
    """A plain table: a header row and rows of cells (numbers are formatted by the renderer)."""

    caption: str
    header: tuple[str, ...]
    rows: tuple[tuple[object, ...], ...]


@dataclass(frozen=True)
class FigureRef:
    """A figure written by a step: its file stem in ``figures/`` and a caption."""

    stem: str
    caption: str


@dataclass(frozen=True)
class Section:
    """One part of the report (a paper section or figure group)."""

    key: str
    title: str
    paragraphs: tuple[str, ...] = ()
    comparisons: tuple[Comparison, ...] = ()
    tables: tuple[Table, ...] = ()
    figures: tuple[FigureRef, ...] = ()
    data: tuple[str, ...] = ()
    numbers: dict[str, float] = field(default_factory=dict)
