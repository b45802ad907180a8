"""ANSYS matrices: Harwell-Boeing files written by ``HBMAT`` (with their ``.mapping`` file) and ``.full`` files.

Harwell-Boeing (Duff, Grimes & Lewis, *Users' Guide for the Harwell-Boeing Sparse Matrix
Collection*, 1992): a header of four or five lines (title and key; card counts; ``MXTYPE`` such as
``RSA``/``RUA`` and the sizes; the Fortran formats of pointers, indices and values), then the
column pointers, row indices and values of the compressed columns (1-based). ``RSA`` is symmetric
with one triangle stored. SciPy's ``hb_read`` reads unsymmetric matrices only, so the (simple)
format is read here. ``HBMAT, Fname, Ext, --, ASCII, STIFF, NO, YES`` also writes
``Fname.mapping``: one line per equation, ``equation node DOF`` (``DOF`` a label such as ``UX``,
``ROTZ``), under a header line; without it the equations are labelled ``(equation, 0)``.

``.full`` (binary assembled matrices) is read through ansys-mapdl-reader (``FullFile.load_km``),
which gives the stiffness and mass matrices with the ``(node, DOF)`` of each equation.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np

from ..._optional import require
from ..._validation import InputError
from ..dofmap import LabelledMatrix

__all__ = ["read_full", "read_hb"]

#: ANSYS DOF labels and their numbers (ANSYS's own numbering: UX..ROTZ are 1..6 as in Abaqus and Nastran).
ANSYS_DOFS = {"UX": 1, "UY": 2, "UZ": 3, "ROTX": 4, "ROTY": 5, "ROTZ": 6, "AX": 7, "AY": 8, "AZ": 9,
              "VX": 10, "VY": 11, "VZ": 12, "WARP": 16, "CONC": 17, "HDSP": 18, "PRES": 19, "TEMP": 20,
              "VOLT": 21, "MAG": 22, "ENKE": 23, "ENDS": 24, "EMF": 25, "CURR": 26}
_MXTYPE = re.compile(r"^[RCP][SUHZR][AE]\s+\d+\s+\d+\s+\d+", re.IGNORECASE)
_FORMAT = re.compile(r"(\d*)\s*[IEDFG](\d+)", re.IGNORECASE)


def sniff_full(head: bytes) -> bool:
    """Whether bytes begin an ANSYS binary file of format 4 (``.full``): standard header of 100 items."""
    if len(head) < 12:
        return False
    items, _, fmt = struct.unpack("<3i", head[:12])
    return items == 100 and fmt == 4


def sniff_hb(head: str) -> bool:
    """Whether a text begins like a Harwell-Boeing file: a counts line, then ``MXTYPE`` and the sizes."""
    lines = head.splitlines()
    if len(lines) < 4:
        return False
    counts = lines[1].split()
    return 4 <= len(counts) <= 5 and all(x.isdigit() for x in counts) and bool(_MXTYPE.match(lines[2]))


def _fixed(lines: list[str], fmt: str, count: int, where: str, kind: type) -> np.ndarray:
    """``count`` values of fixed width from the lines, by a Fortran format such as ``(10I8)``, ``(4E20.12)``."""
    m = _FORMAT.search(fmt.upper().replace("1P", ""))
    if not m:
        raise InputError(f"{where}: Fortran format {fmt.strip()!r} is not understood.")
    per_line, width = int(m.group(1) or 1), int(m.group(2))
    values: list[str] = []
    for line in lines:
        line = line.rstrip("\n")
        values += [line[k * width:(k + 1) * width] for k in range(per_line) if line[k * width:(k + 1) * width].strip()]
        if len(values) >= count:
            break
    if len(values) < count:
        raise InputError(f"{where}: {len(values)} values where the header declares {count}: the file is truncated.")
    try:
        if kind is int:
            return np.array([int(v) for v in values[:count]], dtype=np.int64)
        return np.array([float(v.upper().replace("D", "E")) for v in values[:count]], dtype=np.float64)
    except ValueError as e:
        raise InputError(f"{where}: a value is not a number: {e}") from None


def read_hb(path: str | Path) -> dict[str, LabelledMatrix]:
    """The matrix of a Harwell-Boeing file (as ANSYS ``HBMAT`` writes it), labelled by its ``.mapping`` file.

    Parameters
    ----------
    path : path
        The HB file (``.matrix``, ``.rsa``, ``.rua``...); ``<stem>.mapping`` beside it labels its equations.

    Returns
    -------
    dict of str to LabelledMatrix
        ``{stem: matrix}``; an ``RSA`` matrix is one triangle of a symmetric one.

    Raises
    ------
    InputError
        One line naming the file: a complex or elemental matrix, a damaged header, pointers that do
        not match the entries, a mapping file that does not cover the equations.
    """
    p = Path(path)
    try:
        lines = p.read_text(encoding="latin-1").splitlines()
    except OSError as e:
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    if not sniff_hb("\n".join(lines[:5])):
        raise InputError(f"{p.name}: not a Harwell-Boeing file (no counts line and MXTYPE line).")
    counts = [int(x) for x in lines[1].split()]
    ptrcrd, indcrd, valcrd = counts[1:4]
    rhscrd = counts[4] if len(counts) > 4 else 0
    mxtype = lines[2][:3].upper()
    try:
        nrow, ncol, nnz = (int(x) for x in lines[2][3:].split()[:3])
    except ValueError:
        raise InputError(f"{p.name} line 3: the sizes are not integers: {lines[2].strip()!r}.") from None
    if mxtype[0] != "R":
        raise InputError(f"{p.name}: matrix type {mxtype} is not real (R..); FE matrices must be real.")
    if mxtype[2] != "A":
        raise InputError(f"{p.name}: matrix type {mxtype} is elemental; only assembled matrices (..A) are read.")
    if nrow != ncol:
        raise InputError(f"{p.name}: the matrix is {nrow} x {ncol}, not square.")
    fmts = lines[3]
    ptrfmt, indfmt, valfmt = fmts[0:16], fmts[16:32], fmts[32:52]
    start = 5 if rhscrd > 0 else 4
    where = p.name
    ptr = _fixed(lines[start:start + ptrcrd], ptrfmt, ncol + 1, f"{where} (column pointers)", int)
    ind = _fixed(lines[start + ptrcrd:start + ptrcrd + indcrd], indfmt, nnz, f"{where} (row indices)", int)
    val = _fixed(lines[start + ptrcrd + indcrd:start + ptrcrd + indcrd + valcrd], valfmt, nnz, f"{where} (values)",
                 float)
    if ptr[0] != 1 or np.any(np.diff(ptr) < 0) or ptr[-1] != nnz + 1:
        raise InputError(f"{where}: column pointers (first {ptr[0]}, last {ptr[-1]}) do not match {nnz} entries.")
    if nnz and (ind.min() < 1 or ind.max() > nrow):
        raise InputError(f"{where}: row indices {ind.min()}..{ind.max()} outside 1..{nrow}.")
    col = np.repeat(np.arange(1, ncol + 1, dtype=np.int64), np.diff(ptr))
    node, dof, mapped = _mapping(p, nrow)
    rn, rd = node[ind - 1], dof[ind - 1]
    cn, cd = node[col - 1], dof[col - 1]
    return {p.stem: LabelledMatrix(rn, rd, cn, cd, val, symmetric=mxtype[1] == "S", labels=(node, dof),
                                   source=p.name, equations=not mapped)}


def _mapping(p: Path, n: int) -> tuple[np.ndarray, np.ndarray, bool]:
    """(node, DOF) of each of the n equations from ``<stem>.mapping``, else ``(equation, 0)``."""
    found = [q for q in p.parent.glob("*") if q.stem == p.stem and q.suffix.lower() == ".mapping"]
    if not found:
        return np.arange(1, n + 1, dtype=np.int64), np.zeros(n, dtype=np.int64), False
    m = found[0]
    node = np.zeros(n, dtype=np.int64)
    dof = np.zeros(n, dtype=np.int64)
    seen = np.zeros(n, dtype=bool)
    for k, line in enumerate(m.read_text(encoding="latin-1").splitlines(), start=1):
        fields = line.split()
        if len(fields) < 3 or not fields[0].lstrip("-").isdigit():
            continue  # the header line
        try:
            eq, nd = int(fields[0]), int(fields[1])
        except ValueError:
            raise InputError(f"{m.name} line {k}: not 'equation node DOF': {line.strip()!r}.") from None
        label = fields[2].upper()
        d = ANSYS_DOFS.get(label, int(label) if label.isdigit() else None)
        if d is None:
            raise InputError(f"{m.name} line {k}: unknown DOF label {fields[2]!r}; known: {', '.join(ANSYS_DOFS)}.")
        if not 1 <= eq <= n:
            raise InputError(f"{m.name} line {k}: equation {eq} outside 1..{n} of {p.name}.")
        node[eq - 1], dof[eq - 1], seen[eq - 1] = nd, d, True
    if not seen.all():
        raise InputError(f"{m.name}: equation {int(np.flatnonzero(~seen)[0]) + 1} of {p.name} has no line "
                         f"({int((~seen).sum())} of {n} missing).")
    return node, dof, True


def read_full(path: str | Path) -> dict[str, LabelledMatrix]:
    """Stiffness ``K`` and mass ``M`` of an ANSYS ``.full`` file, labelled ``(node, DOF)``, through ansys-mapdl-reader.

    Needs the optional ``ansys-mapdl-reader`` package (``pip install "squealkit[ansys]"``). Only the
    upper triangle of a symmetric matrix is stored; it is mirrored when the model is assembled.
    Constrained DOFs (rows and columns of zeros in the file) are left out of the DOF map.

    Parameters
    ----------
    path : path
        The ``.full`` file.

    Returns
    -------
    dict of str to LabelledMatrix
        ``{"K": stiffness, "M": mass}``, each one triangle of a symmetric matrix.
    """
    import scipy.sparse as sp

    p = Path(path)
    FullFile = require("ansys.mapdl.reader.full", f"{p.name}: reading an ANSYS .full file").FullFile
    try:
        dof_ref, k, m = FullFile(str(p)).load_km(as_sparse=True, sort=False)
    except Exception as e:  # the reader raises many kinds on a damaged file
        raise InputError(f"{p.name}: not a readable ANSYS .full file: {e}") from e
    # dof_ref: (node, DOF index from 0 = UX); ANSYS numbers DOFs from 1
    node, dof = np.asarray(dof_ref[:, 0], dtype=np.int64), np.asarray(dof_ref[:, 1], dtype=np.int64) + 1
    out = {}
    for name, a in (("K", k), ("M", m)):
        if a is None:
            continue
        a = sp.coo_matrix(a)
        if a.dtype.kind == "c":
            raise InputError(f"{p.name}: matrix {name} is complex; FE matrices must be real.")
        upper_only = not np.any(a.row > a.col)  # a symmetric matrix is stored as its upper triangle
        out[name] = LabelledMatrix(node[a.row], dof[a.row], node[a.col], dof[a.col], a.data, symmetric=upper_only,
                                   source=f"{p.name} ({name})")
    return out
