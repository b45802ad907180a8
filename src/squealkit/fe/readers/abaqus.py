"""Abaqus ``*MATRIX OUTPUT`` files (``jobname_STIF2.mtx``, ``_MASS2``, ``_DMPV2``...).

Two text formats (Abaqus Keywords Guide, ``*MATRIX OUTPUT`` and ``*MATRIX INPUT``):

``FORMAT=MATRIX INPUT`` (the default)
    one entry a line, ``row node, row DOF, column node, column DOF, value``; a symmetric matrix
    as one triangle (lower, upper, or square with equal mirror entries), an unsymmetric one square.
    Internal nodes (Lagrange multipliers) carry negative labels.
``FORMAT=COORDINATE``
    ``row, column, value`` with global equation numbers (1-based), symmetric matrices as one
    triangle. The equations are labelled ``(equation, 0)`` in the DOF map: the files of one
    model share Abaqus's equation numbering, but it cannot be matched with node labels.

Which triangle is given is not declared: a matrix symmetric by definition (``M``, ``K1``, ``D1``,
``KGeo``) whose file holds no mirror pair is mirrored (:class:`~squealkit.fe.dofmap.LabelledMatrix`).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..._validation import InputError
from ..dofmap import LabelledMatrix

__all__ = ["read_abaqus_matrix", "sniff_abaqus"]

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?"
_INT = r"[-+]?\d+"
_SEP = r"\s*[,\s]\s*"
_MATRIX_INPUT = re.compile(rf"^\s*{_INT}\s*,\s*{_INT}\s*,\s*{_INT}\s*,\s*{_INT}\s*,\s*{_NUMBER}\s*,?\s*$")
_COORDINATE = re.compile(rf"^\s*{_INT}{_SEP}{_INT}{_SEP}{_NUMBER}\s*$")


def _data_lines(text: str) -> list[tuple[int, str]]:
    """(line number, line) of the data lines: blank lines and ``**`` comments skipped."""
    return [(k, line) for k, line in enumerate(text.splitlines(), start=1)
            if line.strip() and not line.lstrip().startswith("**")]


def sniff_abaqus(head: str) -> str | None:
    """``"matrix input"`` or ``"coordinate"`` when the first data line of a text fits that format, else None.

    The first line decides, so that a damaged line further down is named by the reader.
    """
    lines = [line for _, line in _data_lines(head)][:1]
    if not lines:
        return None
    if _MATRIX_INPUT.match(lines[0]):
        return "matrix input"
    if _COORDINATE.match(lines[0]):
        return "coordinate"
    return None


def read_abaqus_matrix(path: str | Path) -> dict[str, LabelledMatrix]:
    """The matrix of an Abaqus ``*MATRIX OUTPUT`` file (MATRIX INPUT or COORDINATE format), by its stem.

    Parameters
    ----------
    path : path
        The ``.mtx`` file Abaqus wrote.

    Returns
    -------
    dict of str to LabelledMatrix
        ``{stem: matrix}``; symmetry is decided when the model is assembled.

    Raises
    ------
    InputError
        One line naming the file and its first line that fits neither format.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="ascii", errors="strict")
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{p.name}: not a readable Abaqus matrix file: {e}") from e
    lines = _data_lines(text)
    if not lines:
        raise InputError(f"{p.name}: an Abaqus matrix file with no entries.")
    kind = sniff_abaqus("\n".join(line for _, line in lines[:6]) + "\n")
    if kind is None:
        raise InputError(f"{p.name} line {lines[0][0]}: not an Abaqus matrix entry "
                         f"(row node, row DOF, column node, column DOF, value): {lines[0][1].strip()[:60]!r}.")
    width = 5 if kind == "matrix input" else 3
    pattern = _MATRIX_INPUT if kind == "matrix input" else _COORDINATE
    for k, line in lines:  # every line, so that a misplaced field is named, not shifted into the next entry
        if not pattern.match(line):
            fields = ("row node, row DOF, column node, column DOF, value" if kind == "matrix input"
                      else "row, column, value")
            raise InputError(f"{p.name} line {k}: not an Abaqus {kind.upper()} entry ({fields}): "
                             f"{line.strip()[:60]!r}.")
    table = np.array(" ".join(line for _, line in lines).replace(",", " ").split()).reshape(len(lines), width)
    try:
        labels = table[:, : width - 1].astype(np.int64)
    except (ValueError, OverflowError) as e:
        raise InputError(f"{p.name}: a node, DOF or equation label beyond 64-bit integers: {e}") from e
    values = np.char.replace(np.char.upper(table[:, -1]), "D", "E").astype(np.float64)
    if kind == "matrix input":
        rn, rd, cn, cd = labels.T
        if min(rd.min(), cd.min()) < 0:
            k = lines[int(np.flatnonzero((rd < 0) | (cd < 0))[0])]
            raise InputError(f"{p.name} line {k[0]}: a negative DOF number: {k[1].strip()[:60]!r}.")
    else:
        rn, cn = labels.T
        if min(rn.min(), cn.min()) < 1:
            k = lines[int(np.flatnonzero((rn < 1) | (cn < 1))[0])]
            raise InputError(f"{p.name} line {k[0]}: an equation number below 1: {k[1].strip()[:60]!r}.")
        rd = cd = np.zeros_like(rn)
    return {p.stem: LabelledMatrix(rn, rd, cn, cd, values, symmetric=None, source=p.name,
                                   equations=kind == "coordinate")}
