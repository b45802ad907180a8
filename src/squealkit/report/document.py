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

    Attributes
    ----------
    quantity : str
        What is compared, e.g. ``"critical friction"``.
    published : float or (float, float) or None
        The paper's value or band (None: nothing published).
    computed : float or (float, float) or None
        squealkit's value or band, in the same ``unit``.
    unit : str
        Unit of both values (``""`` when dimensionless).
    agrees : bool or None, default None
        The caller's verdict (None: no verdict, e.g. nothing published).
    note : str, default ""
        The tolerance or reason behind the verdict.
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
    """A plain table: a header row and rows of cells (numbers are formatted by the renderer).

    Attributes
    ----------
    caption : str
        The table's caption.
    header : tuple of str
        Column headings.
    rows : tuple of tuple
        Rows of cells (numbers or text), each as long as ``header``.
    """

    caption: str
    header: tuple[str, ...]
    rows: tuple[tuple[object, ...], ...]


@dataclass(frozen=True)
class FigureRef:
    """A figure written by a step: its file stem in ``figures/`` and a caption.

    Attributes
    ----------
    stem : str
        File name without extension in ``figures/`` (the figure is written as PNG and SVG).
    caption : str
        The figure's caption.
    """

    stem: str
    caption: str


@dataclass(frozen=True)
class Section:
    """One part of the report (a paper section or figure group).

    Attributes
    ----------
    key : str
        Short id (e.g. ``"critical"``), the key of :meth:`ReproduceResult.numbers`.
    title : str
        Heading.
    paragraphs : tuple of str
        Text, each generated from the computed numbers.
    comparisons : tuple of Comparison
        Published-versus-computed rows.
    tables, figures : tuple of Table, tuple of FigureRef
        Tables and figures of the section.
    data : tuple of str
        Files the section wrote to ``data/``.
    numbers : dict of str to float
        The computed numbers the text quotes, for tests and ``--json``.
    views : tuple of str
        Self-contained HTML blocks placed before the figures (interactive 3D views: no
        network needed to show them).
    """

    key: str
    title: str
    paragraphs: tuple[str, ...] = ()
    comparisons: tuple[Comparison, ...] = ()
    tables: tuple[Table, ...] = ()
    figures: tuple[FigureRef, ...] = ()
    data: tuple[str, ...] = ()
    numbers: dict[str, float] = field(default_factory=dict)
    views: tuple[str, ...] = ()
