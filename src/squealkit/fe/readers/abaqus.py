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

__all__ = ["read_abaqus_matrix"]

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
        with open(p, encoding="ascii", errors="strict") as f:
            head = f.read(4096)
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{p.name}: not a readable Abaqus matrix file: {e}") from e
    first = _data_lines(head)[:1]
    if not first:
        raise InputError(f"{p.name}: an Abaqus matrix file with no entries.")
    kind = sniff_abaqus(head)
    if kind is None:
        raise InputError(f"{p.name} line {first[0][0]}: not an Abaqus matrix entry "
                         f"(row node, row DOF, column node, column DOF, value): {first[0][1].strip()[:60]!r}.")
    width = 5 if kind == "matrix input" else 3
    table = _fast_table(p, width, comma="," in first[0][1])
    if table is None:  # some line does not fit: find and name it (the slow path, on errors only)
        _raise_first_bad(p, kind)
    labels, values = table
    if kind == "matrix input":
        rn, rd, cn, cd = labels.T
        if min(rd.min(), cd.min()) < 0:
            _raise_first_bad(p, kind, f"row {int(np.flatnonzero((rd < 0) | (cd < 0))[0]) + 1}: a negative DOF number")
    else:
        rn, cn = labels.T
        if min(rn.min(), cn.min()) < 1:
            _raise_first_bad(p, kind, f"row {int(np.flatnonzero((rn < 1) | (cn < 1))[0]) + 1}: an equation number "
                                      "below 1")
        rd = cd = np.zeros_like(rn)
    return {p.stem: LabelledMatrix(rn, rd, cn, cd, values, symmetric=None, source=p.name,
                                   equations=kind == "coordinate")}


def _fast_table(p: Path, width: int, comma: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """(integer labels (m, width - 1), values (m,)) through pandas' C parser; None if any line does not fit.

    A million entries take seconds; a pure-Python parse of each line would take minutes.
    """
    import pandas as pd

    try:
        df = pd.read_csv(p, sep="," if comma else r"\s+", header=None, comment="*", skipinitialspace=True,
                         engine="c", skip_blank_lines=True)
    except (ValueError, pd.errors.ParserError, OSError):
        return None
    while df.shape[1] > width and df.iloc[:, -1].isna().all():  # a trailing comma
        df = df.iloc[:, :-1]
    if df.shape[1] != width or df.shape[0] == 0:
        return None
    if any(df[c].dtype.kind != "i" for c in df.columns[:-1]):
        return None  # a label that is not an integer, or a missing field
    last = df.iloc[:, -1]
    if last.dtype.kind != "f" and last.dtype.kind != "i":  # Fortran's 1.5D+03, or a word
        try:
            last = pd.to_numeric(last.astype(str).str.replace("D", "E").str.replace("d", "e"), errors="raise")
        except (ValueError, TypeError):
            return None
    values = last.to_numpy(dtype=np.float64)
    if not np.all(np.isfinite(values)):
        return None
    return df.iloc[:, :-1].to_numpy(dtype=np.int64), values


def _raise_first_bad(p: Path, kind: str, extra: str | None = None) -> None:
    """One line naming the first line of the file that is not an entry of ``kind``."""
    pattern = _MATRIX_INPUT if kind == "matrix input" else _COORDINATE
    fields = "row node, row DOF, column node, column DOF, value" if kind == "matrix input" else "row, column, value"
    with open(p, encoding="ascii", errors="replace") as f:
        row = 0
        for k, line in enumerate(f, start=1):
            if not line.strip() or line.lstrip().startswith("*"):
                continue
            row += 1
            if not pattern.match(line) or (extra is not None and extra.startswith(f"row {row}:")):
                why = extra.split(": ", 1)[1] if extra is not None and pattern.match(line) else \
                    f"not an Abaqus {kind.upper()} entry ({fields})"
                raise InputError(f"{p.name} line {k}: {why}: {line.strip()[:60]!r}.")
    raise InputError(f"{p.name}: not an Abaqus {kind.upper()} file ({fields} a line).")
