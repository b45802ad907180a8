"""Readers for exported FE brake matrices: MATLAB ``.mat`` (v5 and v7.3/HDF5), Matrix Market, Nastran OP4.

Each reader returns ``{name in the file: scipy sparse matrix}`` (as read, not yet checked); :func:`load_fe_model`
picks the FE matrices (``M, D1, DG, DR, D4, K1, KR, KGeo``) out of one file or one file per
matrix, with the names they have in the files if those differ, and builds the
:class:`~squealkit.models.fe.FEModel`. Every failure is one :class:`InputError` line naming the file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from .._validation import InputError
from .fe import FE_MATRICES, FEModel

__all__ = ["load_fe_model", "read_mat", "read_matrices", "read_mtx", "read_op4"]

_SUFFIXES = (".mat", ".mtx", ".op4")


def _sparse(name: str, value: Any, path: Path) -> Any:
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
                out[key] = _sparse(key, arr.T, path)
    return out


def read_mat(path: str | Path) -> dict[str, Any]:
    """Matrices of a MATLAB ``.mat`` file: v4/v5/v7 through SciPy, v7.3 (HDF5) through h5py."""
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
    return {k: _sparse(k, v, p) for k, v in doc.items()
            if not k.startswith("__") and (sp.issparse(v) or getattr(v, "ndim", 0) == 2)
            and (sp.issparse(v) or v.dtype.kind in "biufc")}


def read_mtx(path: str | Path) -> dict[str, Any]:
    """The one matrix of a Matrix Market file (as Abaqus and ANSYS export), keyed by the file's stem."""
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
    return {p.stem: _sparse(p.stem, mat, p)}


def read_op4(path: str | Path) -> dict[str, Any]:
    """Matrices of a Nastran OP4 file (ASCII or binary), through pyNastran's reader.

    Needs the optional ``pyNastran`` package (``pip install "squealkit[nastran]"``).
    """
    p = Path(path)
    try:
        from pyNastran.op4.op4 import read_op4 as _read
    except ImportError:
        raise InputError(f"{p.name}: reading Nastran OP4 needs pyNastran: pip install 'squealkit[nastran]'.") from None
    try:
        mats = _read(str(p), debug=False)
    except Exception as e:  # pyNastran raises many kinds on a malformed file
        raise InputError(f"{p.name}: not a readable OP4 file: {e}") from e
    _check_op4_text(p)
    out = {}
    for name, m in mats.items():
        data = m.data if hasattr(m, "data") else m
        out[name.strip()] = _sparse(name, data, p)
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


def read_matrices(path: str | Path) -> dict[str, Any]:
    """All matrices of a file, by its suffix (``.mat``, ``.mtx``, ``.op4``), as SciPy sparse matrices.

    They keep the form they were read in (COO, CSC); :class:`FEModel` checks them and makes them CSR.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"Matrix file {str(p)!r} does not exist.")
    suffix = p.suffix.lower()
    if suffix not in (".mat", ".op4"):  # Abaqus, ANSYS, Nastran files with node/DOF labels, told by their content
        from ..fe.readers.labelled import read_labelled

        found = read_labelled(p)
        if found is not None:
            return found
    if suffix == ".mat":
        return read_mat(p)
    if suffix == ".mtx":
        return read_mtx(p)
    if suffix == ".op4":
        return read_op4(p)
    from ..fe.readers.labelled import LABELLED_FORMATS

    raise InputError(f"Matrix file {p.name!r}: unknown format: its content is none of "
                     f"{', '.join(LABELLED_FORMATS)}, and its suffix {suffix!r} none of {', '.join(_SUFFIXES)}.")


def _pick(found: Mapping[str, Any], wanted: str, path: Path) -> Any:
    """The matrix named ``wanted`` in a file, matched exactly, else ignoring case (``KGEO`` for ``KGeo``)."""
    if wanted in found:
        return found[wanted]
    hits = [k for k in found if k.lower() == wanted.lower()]
    if len(hits) > 1:
        raise InputError(f"{path.name}: matrix name {wanted!r} is ambiguous: {', '.join(hits)}.")
    return found[hits[0]] if hits else None


def load_fe_model(
    file: str | Path | None = None,
    *,
    files: Mapping[str, str | Path] | None = None,
    names: Mapping[str, str] | None = None,
    omega_ref: float = 1.0,
    mu_ref: float = 1.0,
    f_ref: float = 1.0,
    base_dir: str | Path | None = None,
    mesh: str | Path | None = None,
    dof_names: str | Path | None = None,
    omit: Sequence[str] = (),
) -> FEModel:
    """An FE model read from exported matrices.

    Parameters
    ----------
    file : path, optional
        One file holding all matrices (``.mat`` or ``.op4``).
    files : mapping, optional
        One file per matrix, ``{"M": "M.mtx", "K1": "K1.mtx", ...}`` (any format; a file with
        several matrices contributes the one of that name, or its only one).
    names : mapping, optional
        The name each FE matrix has in the file where it differs, ``{"M": "MAA", "K1": "KAA"}``.
    omega_ref, mu_ref, f_ref : float
        Reference values (see :class:`~squealkit.models.fe.FEModel`).
    base_dir : path, optional
        Folder relative paths start from (the model file's folder).
    mesh : path, optional
        The mesh the DOFs live on (any format meshio reads, e.g. ``mesh.vtu``), for mode shape
        export (:func:`~squealkit.stability.fe_sweep.modes_to_vtk`); needs meshio.
    dof_names : path, optional
        A text file with one DOF name per line (``node12.x`` puts that DOF on mesh point 12).
    omit : sequence of str, optional
        Matrices read but left out of the assembly, e.g. ``("DG",)`` for no gyroscopic term
        (NLEVP's disk_brake100 with ``D = D1 + DR/omega``); ``M`` and ``K1`` cannot be omitted.

    Returns
    -------
    FEModel
        The model; matrices absent from the files are zero.

    Raises
    ------
    InputError
        If neither or both of ``file`` and ``files`` are given, a name is not an FE matrix,
        ``omit`` names ``M``, ``K1`` or no FE matrix, or a file cannot be read.

    Examples
    --------
    >>> from squealkit.data import nlevp_path
    >>> load_fe_model(nlevp_path("disk_brake100.mat")).present
    ('M', 'D1', 'DG', 'DR', 'K1', 'KR')
    """
    if (file is None) == (files is None):
        raise InputError("An FE model needs either file (all matrices in one file) or files (one per matrix).")
    names = dict(names or {})
    omit = (omit,) if isinstance(omit, str) else tuple(omit)
    for key in omit:
        if key not in FE_MATRICES or key in ("M", "K1"):
            raise InputError(f"omit={key!r}: only {', '.join(k for k in FE_MATRICES if k not in ('M', 'K1'))} "
                             "can be left out of an FE model (M and K1 are required).")
    for key in names:
        if key not in FE_MATRICES:
            raise InputError(f"Unknown FE matrix {key!r} in names; known: {', '.join(FE_MATRICES)}.")
    base = Path(base_dir) if base_dir is not None else Path(".")

    def resolve(x: str | Path) -> Path:
        p = Path(x)
        return p if p.is_absolute() else base / p

    mats: dict[str, Any] = {}
    if file is not None:
        path = resolve(file)
        found = read_matrices(path)
        for key in FE_MATRICES:
            m = _pick(found, names.get(key, key), path)
            if m is None and key in names:
                raise InputError(f"{path.name}: no matrix {names[key]!r} (for {key}); it has {', '.join(found)}.")
            if m is not None:
                mats[key] = m
        source = path.name
    else:
        for key, x in dict(files).items():
            if key not in FE_MATRICES:
                raise InputError(f"Unknown FE matrix {key!r} in files; known: {', '.join(FE_MATRICES)}.")
            path = resolve(x)
            found = read_matrices(path)
            m = _pick(found, names.get(key, key), path)
            if m is None:
                if len(found) != 1 or key in names:
                    raise InputError(f"{path.name}: no matrix {names.get(key, key)!r} (for {key}); "
                                     f"it has {', '.join(found) or 'none'}.")
                m = next(iter(found.values()))
            mats[key] = m
        source = ", ".join(str(v) for v in dict(files).values())
    for key in omit:
        mats.pop(key, None)
    if omit:
        source += f" (without {', '.join(omit)})"
    from ..fe.dofmap import place_labelled

    extra = {"mesh": _read_mesh(resolve(mesh)) if mesh is not None else None,
             "dof_names": _read_dof_names(resolve(dof_names)) if dof_names is not None else None}
    extra["dof_map"], mats = place_labelled(mats, mesh=extra["mesh"])
    try:
        return FEModel.from_matrices(**mats, omega_ref=omega_ref, mu_ref=mu_ref, f_ref=f_ref, source=source,
                                     **extra)
    except InputError as e:
        raise InputError(f"{source}: {e}") from e


def _read_mesh(path: Path) -> Any:
    """A mesh file (input deck or any meshio format) as an :class:`~squealkit.fe.mesh.FEMesh`."""
    from ..fe.mesh import read_mesh

    return read_mesh(path)


def _read_dof_names(path: Path) -> tuple[str, ...]:
    """DOF names, one per line (blank lines ignored)."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"DOF names file {str(path)!r} does not exist.") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"DOF names file {str(path)!r} cannot be read: {e}") from e
    return tuple(line.strip() for line in text.splitlines() if line.strip())
