"""Tiny writers of the FE matrix formats squealkit reads, for known-answer round trips (test code only).

Each follows the format's documentation, independently of the readers:

- Abaqus ``*MATRIX INPUT`` data lines (Abaqus Keywords Guide, ``*MATRIX INPUT``: "row node, DOF
  for row node, column node, DOF for column node, matrix entry"; a symmetric matrix as its lower
  triangle), and the COORDINATE form ``row, column, value`` with equation numbers;
- Nastran DMIG (MSC Nastran Quick Reference Guide, DMIG: header ``NAME 0 IFO TIN TOUT POLAR NCOL``,
  column cards ``NAME GJ CJ _ G1 C1 A1 B1`` with continuations of ``G C A B``), free field and
  large field (``DMIG*`` with ``*`` continuations, as punch files are);
- Harwell-Boeing (Duff, Grimes & Lewis 1992, the header of four lines and compressed columns; ``RSA``
  keeps the lower triangle) and ANSYS's ``.mapping`` (``equation node DOF-label``, HBMAT's Mapping).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp

_ANSYS = {1: "UX", 2: "UY", 3: "UZ", 4: "ROTX", 5: "ROTY", 6: "ROTZ"}


def _entries(A, symmetric: bool):
    A = sp.coo_matrix(A)
    A.sum_duplicates()
    keep = A.data != 0
    r, c, v = A.row[keep], A.col[keep], A.data[keep]
    if symmetric:  # lower triangle
        low = r >= c
        r, c, v = r[low], c[low], v[low]
    return r, c, v.tolist()  # Python floats: repr gives the shortest exact decimal


def abaqus_matrix_input(path: Path, A, node, dof, *, symmetric: bool, order=None) -> Path:
    """``row node, row DOF, column node, column DOF, value``; ``order`` permutes the lines."""
    r, c, v = _entries(A, symmetric)
    idx = np.arange(r.size) if order is None else order(r.size)
    lines = [f"{node[r[k]]},{dof[r[k]]}, {node[c[k]]},{dof[c[k]]}, {v[k]!r}" for k in idx]
    path.write_text("\n".join(lines) + "\n")
    return path


def abaqus_coordinate(path: Path, A, *, symmetric: bool) -> Path:
    """``row column value`` with 1-based equation numbers."""
    r, c, v = _entries(A, symmetric)
    path.write_text("".join(f"{r[k] + 1} {c[k] + 1} {v[k]!r}\n" for k in range(r.size)))
    return path


def dmig(path: Path, mats: dict, node, dof, *, style: str = "free", bulk: bool = False) -> Path:
    """DMIG cards of several matrices ``{name: (A, symmetric)}`` (IFO 6 or 1, TIN 2), one file."""
    out = ["SOL 107", "CEND", "BEGIN BULK"] if bulk else []
    for name, (A, symmetric) in mats.items():
        ifo = 6 if symmetric else 1
        A = sp.csc_matrix(A)
        r, c, v = _entries(A, symmetric)
        if style == "free":
            out.append(f"DMIG,{name},0,{ifo},2,0,,,{A.shape[1]}")
        else:
            out.append(f"DMIG*   {name:<16s}{0:>16d}{ifo:>16d}{2:>16d}")
            out.append(f"*       {0:>16d}{0:>16d}{'':16s}{A.shape[1]:>16d}")
        for j in np.unique(c):
            rows = np.flatnonzero(c == j)
            groups = [(node[r[k]], dof[r[k]], v[k]) for k in rows]
            if style == "free":
                out.append(f"DMIG,{name},{node[j]},{dof[j]},,{groups[0][0]},{groups[0][1]},{groups[0][2]!r},")
                for g in groups[1:]:  # one (G, C, A, B) group of 4 fields a half line
                    out.append(f",{g[0]},{g[1]},{g[2]!r},,,,,")
            else:  # large field: 4 fields of 16 a line
                out.append(f"DMIG*   {name:<16s}{node[j]:>16d}{dof[j]:>16d}{'':16s}")
                for g in groups:
                    value = f"{g[2]:16.9E}".replace("E", "D")  # 10 significant digits fit 16 characters
                    out.append(f"*       {g[0]:>16d}{g[1]:>16d}{value}{'':16s}")
    if bulk:
        out.append("ENDDATA")
    path.write_text("\n".join(out) + "\n")
    return path


def harwell_boeing(path: Path, A, *, symmetric: bool, node=None, dof=None, title: str = "squealkit test") -> Path:
    """An HB file (RSA/RUA, 1-based compressed columns) and, with labels, its ``.mapping`` beside it."""
    n = A.shape[0]
    r, c, v = _entries(A, symmetric)
    C = sp.csc_matrix((v, (r, c)), shape=A.shape)
    C.sort_indices()
    ptr, ind, val = C.indptr + 1, C.indices + 1, C.data

    def block(values, per, fmt):
        return ["".join(fmt.format(x) for x in values[k:k + per]) for k in range(0, len(values), per)]

    p_lines = block(ptr, 8, "{:10d}")
    i_lines = block(ind, 8, "{:10d}")
    v_lines = block(val, 3, "{:25.16E}")
    head = [f"{title:<72s}{'KEY':<8s}",
            f"{len(p_lines) + len(i_lines) + len(v_lines):14d}{len(p_lines):14d}{len(i_lines):14d}{len(v_lines):14d}"
            f"{0:14d}",
            f"{'RSA' if symmetric else 'RUA':3s}{'':11s}{n:14d}{n:14d}{C.nnz:14d}{0:14d}",
            f"{'(8I10)':16s}{'(8I10)':16s}{'(3E25.16)':20s}{'':20s}"]
    path.write_text("\n".join(head + p_lines + i_lines + v_lines) + "\n")
    if node is not None:
        rows = [" Matrix Eqn   Node   DOF"] + [f"{k + 1:10d} {node[k]:10d}    {_ANSYS[int(dof[k])]}" for k in range(n)]
        path.with_suffix(".mapping").write_text("\n".join(rows) + "\n")
    return path
