"""Figures and text files (JSON, CSV, HTML), written atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .._validation import InputError
from ._interrupts import deferred_interrupts
from ._staging import atomic_path

__all__ = ["save_figure", "write_text"]


def save_figure(fig: Any, path: str | Path, **kwargs: Any) -> Path:
    """Save a matplotlib figure atomically; the format follows the suffix (.png, .svg, .pdf).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure to save.
    path : path-like
        The output file, ending in ``.png``, ``.svg``, ``.pdf``, ``.jpg`` or ``.jpeg``.
    **kwargs
        Passed on to ``fig.savefig``; ``dpi`` defaults to 150 and ``bbox_inches`` to
        ``"tight"``.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    fmt = final.suffix.lstrip(".").lower()
    if fmt not in {"png", "svg", "pdf", "jpg", "jpeg"}:
        raise InputError(f"Figure {str(final)!r} needs a .png, .svg, .pdf or .jpg suffix.")
    kwargs.setdefault("dpi", 150)
    kwargs.setdefault("bbox_inches", "tight")
    with atomic_path(final) as tmp, deferred_interrupts():
        fig.savefig(tmp, format=fmt, **kwargs)
    return final


def write_text(path: str | Path, text: str) -> Path:
    """Write a text file (JSON, CSV, HTML) atomically.

    Parameters
    ----------
    path : path-like
        The output file.
    text : str
        The content, written as UTF-8.

    Returns
    -------
    pathlib.Path
        ``path`` as a ``Path``.
    """
    final = Path(path)
    with atomic_path(final) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return final
