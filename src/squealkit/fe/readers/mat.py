"""MATLAB ``.mat`` files of FE matrices: v4/v5/v7 through SciPy, v7.3 (HDF5) through h5py."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..._validation import InputError
from ._common import as_sparse

__all__ = ["read_mat"]


def _h5_sparse(key: str, obj: Any, path: Path) -> sp.csc_matrix:
    """A MATLAB v7.3 sparse matrix (group of ``data``, ``ir``, ``jc``; rows in ``MATLAB_sparse``), checked.

    The declared rows, the column pointers and the row indices are checked against each other
    before the matrix is built, so a damaged or hostile file is one line, not a huge allocation
    or a silently empty matrix.
    """
    def bad(what: str) -> InputError:
        return InputError(f"{path.name}: sparse matrix {key!r} is damaged: {what}.")

    raw = obj.attrs["MATLAB_sparse"]
    try:
        n_rows = int(np.asarray(raw).reshape(-1)[0])
    except (TypeError, ValueError, IndexError):
        shown = raw.decode(errors="replace") if isinstance(raw, bytes) else raw
        raise bad(f"its MATLAB_sparse attribute (the number of rows) is {shown!r}, not an integer") from None
    if n_rows < 0:
        raise bad(f"its MATLAB_sparse attribute (the number of rows) is {n_rows}")
    if "jc" not in obj:
        raise bad("it has no column pointers 'jc'")
    jc = np.asarray(obj["jc"], dtype=np.int64).reshape(-1)
    ir = np.asarray(obj["ir"], dtype=np.int64).reshape(-1) if "ir" in obj else np.zeros(0, np.int64)
    data = np.asarray(obj["data"]) if "data" in obj else np.zeros(0)
    if data.dtype.names:  # complex: a compound of real and imag
        raise InputError(f"{path.name}: Matrix {key} is complex; FE matrices must be real.")
    data = data.reshape(-1)
    if jc.size < 1 or jc[0] != 0 or np.any(np.diff(jc) < 0) or jc[-1] != ir.size or ir.size != data.size:
        raise bad(f"column pointers 'jc' ({jc.size} of them, last {jc[-1] if jc.size else None}) do not match "
                  f"{ir.size} row indices and {data.size} values")
    if ir.size and (ir.min() < 0 or ir.max() >= n_rows):
        raise bad(f"row indices {int(ir.min())}..{int(ir.max())} outside its {n_rows} rows")
    return sp.csc_matrix((data.astype(np.float64), ir, jc), shape=(n_rows, jc.size - 1))


def _h5_matrices(path: Path) -> dict[str, Any]:
    """MATLAB v7.3 (HDF5): dense arrays stored transposed; sparse ones as groups of data/ir/jc."""
    import h5py

    out: dict[str, Any] = {}
    with h5py.File(path, "r") as f:
        for key, obj in f.items():
            if key.startswith("#"):  # MATLAB's internal references
                continue
            if isinstance(obj, h5py.Group) and "MATLAB_sparse" in obj.attrs:
                out[key] = _h5_sparse(key, obj, path)
            elif isinstance(obj, h5py.Dataset) and obj.ndim == 2:
                arr = np.asarray(obj)
                if arr.dtype.names:
                    raise InputError(f"{path.name}: Matrix {key} is complex; FE matrices must be real.")
                out[key] = as_sparse(key, arr.T, path)
    return out


def read_mat(path: str | Path) -> dict[str, Any]:
    """Matrices of a MATLAB ``.mat`` file: v4/v5/v7 through SciPy, v7.3 (HDF5) through h5py.

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
    from scipy.io.matlab import MatReadError

    p = Path(path)
    try:
        import h5py

        if h5py.is_hdf5(p):
            return _h5_matrices(p)
    except InputError:
        raise
    except (OSError, KeyError, ValueError) as e:  # h5py: damaged or truncated file, a missing object
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    try:
        doc = scipy.io.loadmat(p)
    except (MatReadError, ValueError, TypeError, OSError, NotImplementedError, IndexError, EOFError) as e:
        raise InputError(f"{p.name}: not a readable MATLAB file: {e}") from e
    return {k: as_sparse(k, v, p) for k, v in doc.items()
            if not k.startswith("__") and (sp.issparse(v) or getattr(v, "ndim", 0) == 2)
            and (sp.issparse(v) or v.dtype.kind in "biufc")}
