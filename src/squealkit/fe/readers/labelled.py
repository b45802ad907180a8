"""Which labelled format a file holds, from its content, and its reader.

Abaqus ``*MATRIX OUTPUT`` text (MATRIX INPUT or COORDINATE), Nastran DMIG cards (bulk data or
punch), ANSYS Harwell-Boeing (HBMAT, with its ``.mapping`` file) and ANSYS ``.full``. A file of
none of these is left to the unlabelled readers (Matrix Market, ``.mat``, OP4).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..._validation import InputError
from ..dofmap import DofMap, LabelledMatrix, assemble_labelled
from ..mesh import FEMesh

__all__ = []

#: The formats recognised here, as named in messages.
LABELLED_FORMATS = ("Abaqus MATRIX INPUT", "Abaqus COORDINATE", "Nastran DMIG", "ANSYS Harwell-Boeing",
                    "ANSYS .full")
_HEAD_BYTES = 8192


def recognise(path: str | Path) -> str | None:
    """The labelled format of a file from its first bytes (one of :data:`LABELLED_FORMATS`), or None."""
    from .abaqus import sniff_abaqus
    from .ansys import sniff_full, sniff_hb
    from .nastran import sniff_dmig

    p = Path(path)
    with open(p, "rb") as f:
        head = f.read(_HEAD_BYTES)
    if sniff_full(head):
        return "ANSYS .full"
    if b"\0" in head:
        return None
    text = head.decode("latin-1")
    if text.lstrip().startswith("%%MatrixMarket"):
        return None
    kind = sniff_abaqus(text)
    if kind is not None:
        return f"Abaqus {kind.upper()}"
    if sniff_dmig(text):
        return "Nastran DMIG"
    if sniff_hb(text):
        return "ANSYS Harwell-Boeing"
    return None


def read_labelled(path: str | Path) -> dict[str, LabelledMatrix] | None:
    """The labelled matrices of a file by name, or None when its content is none of :data:`LABELLED_FORMATS`."""
    p = Path(path)
    try:
        fmt = recognise(p)
    except OSError as e:
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    if fmt is None:
        return None
    if fmt.startswith("Abaqus"):
        from .abaqus import read_abaqus_matrix

        return read_abaqus_matrix(p)
    if fmt == "Nastran DMIG":
        from .nastran import read_dmig

        return read_dmig(p)
    from .ansys import read_full, read_hb

    return read_full(p) if fmt == "ANSYS .full" else read_hb(p)


def place_labelled(mats: Mapping[str, Any], *, mesh: Any = None) -> tuple[DofMap | None, dict[str, Any]]:
    """The model's matrices in one DOF map when they come from labelled files, else as given.

    Parameters
    ----------
    mats : mapping of str to LabelledMatrix or sparse matrix
        FE matrix name -> the matrix its file gave.
    mesh : FEMesh, optional
        The model's mesh: checked to carry some of the DOFs (the right mesh for these matrices).

    Returns
    -------
    (DofMap or None, dict)
        The map (None for unlabelled files) and the matrices in its numbering.

    Raises
    ------
    InputError
        When labelled and unlabelled files are mixed (their numberings cannot be matched), or
        equation-numbered files (Abaqus COORDINATE, Harwell-Boeing without its mapping) with
        node-labelled ones.
    """
    labelled = {k: v for k, v in mats.items() if isinstance(v, LabelledMatrix)}
    if not labelled:
        return None, dict(mats)
    if len(labelled) != len(mats):
        plain = [k for k in mats if k not in labelled]
        raise InputError(f"Matrices {', '.join(labelled)} have node/DOF labels but {', '.join(plain)} do not: their "
                         "numberings cannot be matched; export all of them in one labelled format.")
    kinds = {k: bool(v.equations) for k, v in labelled.items()}
    if len(set(kinds.values())) > 1:
        eq = [k for k, v in kinds.items() if v]
        raise InputError(f"Matrices {', '.join(eq)} are numbered by equation (no node labels) but the others by "
                         "node and DOF: their numberings cannot be matched.")
    dof_map, placed = assemble_labelled(labelled)
    if isinstance(mesh, FEMesh) and not any(kinds.values()):
        mesh.dof_points(dof_map)  # one line when the mesh holds none of the DOFs
    return dof_map, placed
