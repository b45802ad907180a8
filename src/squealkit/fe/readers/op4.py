"""Nastran OP4 files (ASCII or binary) of FE matrices, through pyNastran's reader."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..._optional import require
from ..._validation import InputError
from ._common import as_sparse

__all__ = ["read_op4"]


def read_op4(path: str | Path) -> dict[str, Any]:
    """Matrices of a Nastran OP4 file (ASCII or binary), through pyNastran's reader.

    Needs the optional ``pyNastran`` package (``pip install "squealkit[nastran]"``).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to sparse matrix
        The matrices by their names in the file, as read (not yet checked).
    """
    p = Path(path)
    _read = require("pyNastran.op4.op4", f"{p.name}: reading Nastran OP4").read_op4
    try:
        mats = _read(str(p), debug=False)
    except Exception as e:  # pyNastran raises many kinds on a malformed file
        raise InputError(f"{p.name}: not a readable OP4 file: {e}") from e
    _check_op4_text(p)
    out = {}
    for name, m in mats.items():
        data = m.data if hasattr(m, "data") else m
        out[name.strip()] = as_sparse(name, data, p)
    return out


def _check_op4_text(p: Path) -> None:
    """An ASCII OP4 file's values all finite: pyNastran's reader drops a ``NAN`` entry without a word."""
    with open(p, "rb") as f:
        head = f.read(4096)
    if b"\0" in head:  # binary OP4: its values are checked by FEModel once read
        return
    with open(p, encoding="ascii", errors="replace") as f:
        for line_no, line in enumerate(f, start=1):
            fields = line.split()
            if fields and all(_is_float(x) for x in fields) and not all(math.isfinite(float(x)) for x in fields):
                raise InputError(f"{p.name} line {line_no}: a non-finite value ({line.strip()}); "
                                 "FE matrices must be finite.")


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
