"""Readers for exported FE brake matrices, one module per format, behind one table of formats.

Each reader (``mat``: MATLAB v5 and v7.3/HDF5; ``mtx``: Matrix Market; ``op4``: Nastran OP4)
returns ``{name in the file: scipy sparse matrix}`` (as read, not yet checked); :func:`read_matrices`
picks the reader by the file's suffix from :data:`READERS`, and :func:`load_fe_model` picks the FE
matrices (``M, D1, DG, DR, D4, K1, KR, KGeo``) out of one file or one file per matrix, with the
names they have in the files if those differ, and builds the :class:`~squealkit.fe.model.FEModel`.
Every failure is one :class:`InputError` line naming the file.

Files whose entries carry node and DOF labels are told by their content, not their suffix (an
Abaqus ``*_STIF1.mtx`` is no Matrix Market file): Abaqus ``*MATRIX OUTPUT`` (``abaqus``), Nastran
DMIG bulk data or punch (``nastran``), ANSYS Harwell-Boeing with its ``.mapping`` and ``.full``
(``ansys``), recognised in :mod:`~squealkit.fe.readers.labelled`. Their matrices are placed in one
global :class:`~squealkit.fe.dofmap.DofMap` kept with the model (``FEModel.dof_map``), and a mesh
(``.inp``, ``.bdf``, ``.cdb`` or meshio's) is read as a :class:`~squealkit.fe.mesh.FEMesh` whose node
labels tie mode shapes to its points.

A new format is one module here (``reader(path) -> {name: sparse matrix}``, raising
:class:`InputError` naming the file) and one line in :data:`READERS` (or, from outside
squealkit, :func:`register_reader`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..._deprecation import renamed_kwargs
from ..._validation import InputError
from ..mesh import read_mesh
from ..model import FE_MATRICES, FEModel
from .labelled import LABELLED_FORMATS, place_labelled, read_labelled
from .mat import read_mat
from .mtx import read_mtx
from .op4 import read_op4

__all__ = ["READERS", "load_fe_model", "read_mat", "read_matrices", "read_mtx", "read_op4", "register_reader"]

#: A reader: ``reader(path) -> {name in the file: sparse matrix}``.
Reader = Callable[[Path], dict[str, Any]]

#: The readers by file suffix (lower case, with the dot).
READERS: dict[str, Reader] = {
    ".mat": read_mat,
    ".mtx": read_mtx,
    ".op4": read_op4,
}


def register_reader(suffix: str, reader: Reader) -> None:
    """Read files ending in ``suffix`` with ``reader`` (:func:`read_matrices`, :func:`load_fe_model`).

    Parameters
    ----------
    suffix : str
        The file suffix, with its dot (``".full"``); matched ignoring case.
    reader : callable
        ``reader(path) -> {name in the file: sparse matrix}``, raising :class:`InputError` naming the
        file for a file it cannot read.

    Returns
    -------
    None
    """
    if not isinstance(suffix, str) or not suffix.startswith(".") or len(suffix) < 2:
        raise InputError(f"A reader's suffix must start with a dot, like '.mtx', got {suffix!r}.")
    if not callable(reader):
        raise InputError(f"The reader for {suffix!r} must be callable as reader(path), got {type(reader).__name__}.")
    READERS[suffix.lower()] = reader


#: squealkit's own readers: a suffix whose reader is another one (:func:`register_reader`) is read by it.
_BUILT_IN = dict(READERS)
#: Suffixes whose files are never labelled text (binary MATLAB, OP4): read by suffix at once.
_NEVER_LABELLED = (".mat", ".op4")


def read_matrices(path: str | Path) -> dict[str, Any]:
    """All matrices of a file, as SciPy sparse matrices, or as labelled matrices for labelled formats.

    A file in one of the labelled formats (:data:`~squealkit.fe.readers.labelled.LABELLED_FORMATS`)
    is recognised from its content, whatever its suffix; any other file is read by the reader of
    its suffix (:data:`~squealkit.fe.readers.READERS`); a suffix given a reader by
    :func:`register_reader` is always read by that reader. Matrices keep the form they were read in (COO, CSC, or
    :class:`~squealkit.fe.dofmap.LabelledMatrix`); :func:`load_fe_model` places labelled ones in one
    DOF map, and :class:`FEModel` checks them and makes them CSR.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to sparse matrix
        The matrices by their names in the file.

    Raises
    ------
    InputError
        If the file does not exist, is of no labelled format and its suffix has no reader, or it
        cannot be read.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"Matrix file {str(p)!r} does not exist.")
    suffix = p.suffix.lower()
    registered = suffix in READERS and READERS[suffix] is not _BUILT_IN.get(suffix)
    if suffix not in _NEVER_LABELLED and not registered:
        found = read_labelled(p)
        if found is not None:
            return found
    if suffix not in READERS:
        raise InputError(f"Matrix file {p.name!r}: unknown format {suffix!r}; known: {', '.join(READERS)}, "
                         f"or by content: {', '.join(LABELLED_FORMATS)}.")
    return READERS[suffix](p)


def _pick(found: Mapping[str, Any], wanted: str, path: Path) -> Any:
    """The matrix named ``wanted`` in a file, matched exactly, else ignoring case (``KGEO`` for ``KGeo``)."""
    if wanted in found:
        return found[wanted]
    hits = [k for k in found if k.lower() == wanted.lower()]
    if len(hits) > 1:
        raise InputError(f"{path.name}: matrix name {wanted!r} is ambiguous: {', '.join(hits)}.")
    return found[hits[0]] if hits else None


@renamed_kwargs(omega_ref="disc_speed_ref")
def load_fe_model(
    file: str | Path | None = None,
    *,
    files: Mapping[str, str | Path] | None = None,
    names: Mapping[str, str] | None = None,
    disc_speed_ref: float = 1.0,
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
        One file holding all matrices (``.mat``, ``.op4``, Nastran DMIG ``.bdf``/``.pch``).
    files : mapping, optional
        One file per matrix, ``{"M": "M.mtx", "K1": "K1.mtx", ...}`` (any format; a file with
        several matrices contributes the one of that name, or its only one).
    names : mapping, optional
        The name each FE matrix has in the file where it differs, ``{"M": "MAA", "K1": "KAA"}``.
    disc_speed_ref, mu_ref, f_ref : float
        Reference values (see :class:`~squealkit.fe.model.FEModel`); ``omega_ref=`` is the
        deprecated name of ``disc_speed_ref=``.
    base_dir : path, optional
        Folder relative paths start from (the model file's folder).
    mesh : path, optional
        The mesh the DOFs live on, for mode shape export
        (:func:`~squealkit.stability.fe_sweep.modes_to_vtk`): an input deck (Abaqus ``.inp``,
        Nastran ``.bdf``, ANSYS ``.cdb``), whose node labels place labelled DOFs on their points,
        or any format meshio reads (e.g. ``mesh.vtu``); see :func:`~squealkit.fe.mesh.read_mesh`.
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
    extra = {"mesh": read_mesh(resolve(mesh)) if mesh is not None else None,
             "dof_names": _read_dof_names(resolve(dof_names)) if dof_names is not None else None}
    extra["dof_map"], mats = place_labelled(mats, mesh=extra["mesh"])
    try:
        return FEModel.from_matrices(**mats, disc_speed_ref=disc_speed_ref, mu_ref=mu_ref, f_ref=f_ref, source=source,
                                     **extra)
    except InputError as e:
        raise InputError(f"{source}: {e}") from e


def _read_dof_names(path: Path) -> tuple[str, ...]:
    """DOF names, one per line (blank lines ignored)."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"DOF names file {str(path)!r} does not exist.") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"DOF names file {str(path)!r} cannot be read: {e}") from e
    return tuple(line.strip() for line in text.splitlines() if line.strip())
