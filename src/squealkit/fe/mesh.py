"""The nodes and elements of an FE model's input deck, tied to its DOF map, for mode shapes on the brake.

:func:`read_mesh` reads

- Abaqus ``.inp``: ``*NODE`` and ``*ELEMENT, TYPE=...`` blocks (any number, continuation lines);
  meshio's own Abaqus reader keeps one ``*NODE`` block and drops the node labels, so the
  keywords are read here, with meshio's table of element types;
- Nastran ``.bdf``/``.nas``/``.dat``: ``GRID`` (basic coordinates, ``CP`` blank or 0) and the
  solid, shell and line elements (``CHEXA``, ``CPENTA``, ``CTETRA``, ``CQUAD4``, ``CTRIA3``,
  ``CBAR``, ``CBEAM``, ``CROD``...), small, large or free field;
- ANSYS ``.cdb`` (``CDWRITE``) through ansys-mapdl-reader's ``Archive``;
- anything else meshio reads (``.vtu``, ``.msh``...), with points labelled ``1..p``.

An :class:`FEMesh` keeps each point's node label, so that a DOF ``(node, dof)`` of the model's
:class:`~squealkit.fe.dofmap.DofMap` lands on its point (:meth:`FEMesh.dof_points`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._optional import require
from .._validation import InputError
from ._bulk import bulk_cards, field_int, field_real
from .dofmap import DofMap

__all__ = ["FEMesh", "abaqus_inp_text", "read_mesh", "write_abaqus_inp"]

#: Nastran element cards: (meshio cell type, number of nodes); CHEXA/CPENTA/CTETRA by their node count.
_NASTRAN_ELEMENTS = {
    "CROD": ("line", 2), "CBAR": ("line", 2), "CBEAM": ("line", 2), "CTRIA3": ("triangle", 3),
    "CQUAD4": ("quad", 4), "CTETRA": ("tetra", 4), "CPENTA": ("wedge", 6), "CHEXA": ("hexahedron", 8),
}
_NASTRAN_SOLID_HIGHER = {("CTETRA", 10): "tetra10", ("CPENTA", 15): "wedge15", ("CHEXA", 20): "hexahedron20"}


@dataclass(frozen=True, eq=False)
class FEMesh:
    """Nodes and elements of an FE model, points labelled by their node labels.

    Attributes
    ----------
    points : ndarray, shape (p, 3)
        Node coordinates [m, or the model's length unit].
    node_labels : ndarray of int64, shape (p,)
        The node label of each point (unique).
    cells : tuple of (str, ndarray)
        Element blocks: meshio cell type (``"hexahedron"``, ``"tetra10"``...) and the point
        indices of each element, shape (e, k).
    source : str
        The file it came from.
    """

    points: Any
    node_labels: Any
    cells: tuple[tuple[str, Any], ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        pts = np.asarray(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise InputError(f"{self.source}: mesh points must be of shape (p, 3), got {pts.shape}.")
        if pts.shape[1] == 2:
            pts = np.hstack([pts, np.zeros((len(pts), 1))])
        labels = np.asarray(self.node_labels, dtype=np.int64).reshape(-1)
        if labels.size != len(pts):
            raise InputError(f"{self.source}: {labels.size} node labels for {len(pts)} points.")
        uniq, counts = np.unique(labels, return_counts=True)
        if np.any(counts > 1):
            raise InputError(f"{self.source}: node {int(uniq[counts > 1][0])} is defined twice.")
        if not np.all(np.isfinite(pts)):
            raise InputError(f"{self.source}: a node coordinate is not finite.")
        cells = []
        for kind, conn in self.cells:
            conn = np.asarray(conn, dtype=np.int64)
            if conn.size and (conn.min() < 0 or conn.max() >= len(pts)):
                raise InputError(f"{self.source}: a {kind} element refers to a point outside the mesh.")
            cells.append((str(kind), conn))
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "node_labels", labels)
        object.__setattr__(self, "cells", tuple(cells))

    @property
    def n_points(self) -> int:
        """Number of nodes p."""
        return len(self.points)

    def point_index(self, labels: Any) -> NDArray[np.int64]:
        """The point of each node label, -1 where the mesh has no such node."""
        labels = np.asarray(labels, dtype=np.int64)
        order = np.argsort(self.node_labels)
        pos = np.searchsorted(self.node_labels[order], labels)
        pos = np.minimum(pos, self.n_points - 1)
        found = self.node_labels[order][pos] == labels
        return np.where(found, order[pos], -1)

    def dof_points(self, dof_map: DofMap) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
        """(DOF index, point, component 0-2) of the model's translational DOFs (1-3) on nodes of the mesh.

        Rotations, scalar points and internal nodes have no place on the mesh and are left out.

        Raises
        ------
        InputError
            If no translational DOF of the map is on a node of the mesh (the wrong mesh).
        """
        point = self.point_index(dof_map.node)
        keep = (point >= 0) & (dof_map.dof >= 1) & (dof_map.dof <= 3)
        if not keep.any():
            raise InputError(f"{self.source}: none of the model's {dof_map.n_dof} DOFs is a displacement of a node "
                             f"of this mesh (nodes {int(self.node_labels.min())}..{int(self.node_labels.max())}); "
                             "is it the mesh of these matrices?")
        dof = np.flatnonzero(keep)
        return dof, point[keep], dof_map.dof[keep] - 1

    def to_meshio(self) -> Any:
        """The mesh as a ``meshio.Mesh`` (point data ``node_label``); needs meshio."""
        meshio = require("meshio", "A mesh for meshio")

        return meshio.Mesh(self.points, list(self.cells), point_data={"node_label": self.node_labels})


# ----------------------------------------------------------------------------- readers


def read_mesh(path: str | Path) -> FEMesh:
    """The nodes and elements of an input deck (``.inp``, ``.bdf``/``.nas``/``.dat``, ``.cdb``) or a meshio file.

    Parameters
    ----------
    path : path
        The file.

    Returns
    -------
    FEMesh

    Raises
    ------
    InputError
        One line naming the file: missing, no nodes, an unknown element type, an element on an
        undefined node, a node defined twice, a line that is not numbers.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"Mesh file {str(p)!r} does not exist.")
    suffix = p.suffix.lower()
    if suffix == ".inp":
        return _read_inp(p)
    if suffix in (".bdf", ".nas", ".dat", ".blk"):
        return _read_bdf(p)
    if suffix == ".cdb":
        return _read_cdb(p)
    return _read_meshio(p)


def _read_meshio(p: Path) -> FEMesh:
    meshio = require("meshio", f"{p.name}: reading a mesh")
    try:
        m = meshio.read(p)
    except Exception as e:  # meshio raises many kinds on a malformed or unknown file
        raise InputError(f"{p.name}: not a readable mesh: {e}") from e
    labels = m.point_data.get("node_label")
    labels = np.arange(1, len(m.points) + 1) if labels is None else labels
    return FEMesh(m.points, labels, tuple((c.type, c.data) for c in m.cells), source=p.name)


def _inp_params(line: str) -> tuple[str, dict[str, str]]:
    parts = [x.strip() for x in line.strip().lstrip("*").split(",")]
    params = {}
    for x in parts[1:]:
        key, _, value = x.partition("=")
        params[key.strip().upper()] = value.strip()
    return parts[0].upper(), params


def _read_inp(p: Path) -> FEMesh:
    """Abaqus ``*NODE`` and ``*ELEMENT`` blocks of an input file (flat decks: parts are not instanced)."""
    require("meshio", f"{p.name}: reading an Abaqus input file")
    from meshio._common import num_nodes_per_cell
    from meshio.abaqus._abaqus import abaqus_to_meshio_type

    try:
        lines = p.read_text(encoding="latin-1").splitlines()
    except OSError as e:
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    labels: list[int] = []
    coords: list[list[float]] = []
    blocks: list[tuple[str, int, list[int], int]] = []  # (cell type, nodes per element, tokens, first line)
    mode: str | None = None
    for k, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            key, params = _inp_params(line)
            mode = None
            if key == "NODE":
                mode = "node"
            elif key == "ELEMENT":
                etype = params.get("TYPE", "").upper()
                if etype not in abaqus_to_meshio_type:
                    raise InputError(f"{p.name} line {k}: element type {etype or '(none)'!r} is not known.")
                kind = abaqus_to_meshio_type[etype]
                blocks.append((kind, num_nodes_per_cell[kind], [], k))
                mode = "element"
            elif key == "INCLUDE":
                raise InputError(f"{p.name} line {k}: *INCLUDE is not followed; give the mesh in one file.")
            continue
        if mode is None:
            continue
        fields = [x.strip() for x in line.split(",") if x.strip()]
        try:
            if mode == "node":
                labels.append(int(fields[0]))
                coords.append([float(x) for x in fields[1:4]] + [0.0] * (4 - len(fields)))
            else:
                blocks[-1][2].extend(int(x) for x in fields)
        except (ValueError, IndexError):
            raise InputError(f"{p.name} line {k}: not a {'node' if mode == 'node' else 'element'} line of "
                             f"numbers: {line[:60]!r}.") from None
    if not labels:
        raise InputError(f"{p.name}: no *NODE block; not an Abaqus input deck with a mesh.")
    mesh = FEMesh(np.array(coords), np.array(labels), (), source=p.name)
    cells = []
    for kind, per, tokens, first in blocks:
        if len(tokens) % (per + 1):
            raise InputError(f"{p.name} line {first}: the {kind} elements need {per} nodes each after the element "
                             f"label; {len(tokens)} numbers do not divide into them.")
        table = np.array(tokens, dtype=np.int64).reshape(-1, per + 1)[:, 1:]
        cells.append((kind, _points_of(mesh, table, p.name, kind)))
    return FEMesh(mesh.points, mesh.node_labels, tuple(cells), source=p.name)


def _points_of(mesh: FEMesh, node_table: NDArray[np.int64], name: str, kind: str) -> NDArray[np.int64]:
    idx = mesh.point_index(node_table.reshape(-1))
    if np.any(idx < 0):
        bad = int(node_table.reshape(-1)[np.flatnonzero(idx < 0)[0]])
        raise InputError(f"{name}: a {kind} element refers to node {bad}, which is not defined.")
    return idx.reshape(node_table.shape)


def _read_bdf(p: Path) -> FEMesh:
    """GRID and element cards of Nastran bulk data."""
    try:
        text = p.read_text(encoding="latin-1")
    except OSError as e:
        raise InputError(f"{p.name}: cannot be read: {e}") from e
    cards = bulk_cards(text, ("GRID", *_NASTRAN_ELEMENTS))
    labels, coords = [], []
    elements: dict[str, list[list[int]]] = {}
    for k, card in cards:
        where = f"{p.name} line {k}"
        card = card + [""] * max(0, 9 - len(card))
        if card[0] == "GRID":
            if card[2].strip() not in ("", "0"):
                raise InputError(f"{where}: GRID {card[1].strip()} is given in coordinate system {card[2].strip()}; "
                                 "only basic coordinates (CP blank or 0) are read.")
            labels.append(field_int(card[1], f"{where} (GRID ID)"))
            coords.append([field_real(x, f"{where} (GRID X)") if x.strip() else 0.0 for x in card[3:6]])
            continue
        kind, per = _NASTRAN_ELEMENTS[card[0]]
        nodes = [x for x in card[3:] if x.strip()]
        if card[0] in ("CBAR", "CBEAM"):
            nodes = card[3:5]  # GA, GB; the orientation fields follow
        elif card[0] in ("CHEXA", "CPENTA", "CTETRA"):
            kind = _NASTRAN_SOLID_HIGHER.get((card[0], len(nodes)), kind)
            per = len(nodes) if kind != _NASTRAN_ELEMENTS[card[0]][0] else per
        else:
            nodes = card[3:3 + per]
        if len(nodes) < per:
            raise InputError(f"{where}: {card[0]} {card[1].strip()} has {len(nodes)} nodes, needs {per}.")
        elements.setdefault(kind, []).append([field_int(x, f"{where} ({card[0]} node)") for x in nodes[:per]])
    if not labels:
        raise InputError(f"{p.name}: no GRID cards; not a Nastran bulk data file with a mesh.")
    mesh = FEMesh(np.array(coords), np.array(labels), (), source=p.name)
    cells = tuple((kind, _points_of(mesh, np.array(rows, dtype=np.int64), p.name, kind))
                  for kind, rows in elements.items())
    return FEMesh(mesh.points, mesh.node_labels, cells, source=p.name)


def _read_cdb(p: Path) -> FEMesh:
    """An ANSYS archive (``CDWRITE``) through ansys-mapdl-reader."""
    Archive = require("ansys.mapdl.reader", f"{p.name}: reading an ANSYS .cdb").Archive
    require("meshio", f"{p.name}: reading an ANSYS .cdb")
    try:
        archive = Archive(str(p))
        grid = archive.grid
    except Exception as e:  # the reader raises many kinds on a damaged file
        raise InputError(f"{p.name}: not a readable ANSYS archive: {e}") from e
    from meshio._vtk_common import vtk_to_meshio_type

    cells = tuple((vtk_to_meshio_type[int(t)], np.asarray(conn)) for t, conn in grid.cells_dict.items())
    return FEMesh(np.asarray(grid.points), np.asarray(grid.point_data["ansys_node_num"]), cells, source=p.name)


# ----------------------------------------------------------------------------- writing


_INP_TYPES = {"hexahedron": "C3D8", "hexahedron20": "C3D20", "tetra": "C3D4", "tetra10": "C3D10",
              "wedge": "C3D6", "quad": "S4", "triangle": "S3", "line": "B31"}


def abaqus_inp_text(mesh: FEMesh) -> str:
    """A mesh as the text of an Abaqus input deck (``*NODE``, one ``*ELEMENT`` block per cell type).

    Parameters
    ----------
    mesh : FEMesh
        Points [m] with their node labels, and the cells.

    Returns
    -------
    str
        The deck: one ``*NODE`` line per point (its label and coordinates), elements numbered from 1.
    """
    rows = ["** nodes and elements written by squealkit", "*NODE"]
    rows += [f"{n}, {x!r}, {y!r}, {z!r}" for n, (x, y, z) in zip(mesh.node_labels.tolist(), mesh.points.tolist(),
                                                               strict=True)]
    label = 1
    for kind, conn in mesh.cells:
        if kind not in _INP_TYPES:
            raise InputError(f"A {kind} element has no Abaqus type here; known: {', '.join(_INP_TYPES)}.")
        rows.append(f"*ELEMENT, TYPE={_INP_TYPES[kind]}")
        for e in mesh.node_labels[conn].tolist():
            rows.append(", ".join(map(str, [label, *e])))
            label += 1
    return "\n".join(rows) + "\n"


def write_abaqus_inp(mesh: FEMesh, path: str | Path) -> Path:
    """Write a mesh as an Abaqus input deck (:func:`abaqus_inp_text`), atomically.

    Parameters
    ----------
    mesh : FEMesh
        Points [m] with their node labels, and the cells.
    path : str or Path
        The ``.inp`` file to write (replaced only once complete: :func:`squealkit.io.atomic_path`).

    Returns
    -------
    Path
        ``path``.
    """
    from ..io import atomic_path

    out = Path(path)
    text = abaqus_inp_text(mesh)
    with atomic_path(out) as tmp:
        Path(tmp).write_text(text)
    return out
