"""What every FE matrix reader shares: a matrix of a file as a SciPy sparse matrix, as read."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..._validation import InputError

__all__ = ["as_sparse"]


def as_sparse(name: str, value: Any, path: Path) -> Any:
    """A matrix of a file as a sparse matrix, in the form it was read (no CSR of the declared size yet).

    Whether it is real, square and finite is :class:`FEModel`'s one check, for files and arrays alike.
    """
    if sp.issparse(value):
        return value
    arr = np.asarray(value)
    if arr.dtype.kind not in "biufc":
        raise InputError(f"{path.name}: matrix {name!r} is not numeric (dtype {arr.dtype}).")
    if arr.ndim != 2:
        raise InputError(f"{path.name}: {name!r} is not a matrix (shape {arr.shape}).")
    return sp.coo_matrix(arr)
