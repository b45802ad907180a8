"""Matrix Market files (``.mtx``, one matrix each, as Abaqus and ANSYS export)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..._validation import InputError
from ._common import as_sparse

__all__ = ["read_mtx"]


def read_mtx(path: str | Path) -> dict[str, Any]:
    """The one matrix of a Matrix Market file (as Abaqus and ANSYS export), keyed by the file's stem.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to sparse matrix
        The matrices by their names in the file, as read (not yet checked).
    """
    import scipy.io

    p = Path(path)
    try:
        rows, cols, entries, fmt, _, _ = scipy.io.mminfo(p)
    except (ValueError, TypeError, OSError, IndexError) as e:
        raise InputError(f"{p.name}: not a readable Matrix Market file: {e}") from e
    # every declared value takes at least 2 bytes of the file ("1\n"): a header declaring more
    # (a 1e5 x 1e5 dense array in a few bytes) is refused before anything of that size is allocated
    values = rows * cols if fmt == "array" else entries
    if values > p.stat().st_size // 2:
        raise InputError(f"{p.name}: declares {values} values ({rows} x {cols}, {fmt}) but the file holds only "
                         f"{p.stat().st_size} bytes: it is damaged or truncated.")
    try:
        mat = scipy.io.mmread(p)
    except (ValueError, TypeError, OSError, IndexError) as e:
        raise InputError(f"{p.name}: not a readable Matrix Market file: {e}") from e
    return {p.stem: as_sparse(p.stem, mat, p)}
