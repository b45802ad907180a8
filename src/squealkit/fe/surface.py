"""Where an FE model's unknowns sit on its mesh: DOF placement, the outer surface and the bodies.

What the views of mode shapes need from a mesh, for any model with one (an
:class:`~squealkit.fe.mesh.FEMesh` read from ``.inp``/``.bdf``/``.cdb``, or a ``meshio.Mesh``):

- :func:`dof_places`: the point and component (x, y, z) of each translational DOF;
- :func:`surface_triangles`: the boundary faces of the solid elements (and the shell
  elements themselves) as triangles, for a 3D view;
- :func:`bodies`: the separate bodies of the mesh (disc, pads...: the connected components of
  its elements), with every DOF given the body it belongs to.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

from .._validation import InputError

__all__ = ["Bodies", "bodies", "dof_places", "mesh_of", "mode_surface", "surface_triangles"]

#: The faces of a solid element by its corner nodes (VTK / meshio node order), each listed outward or not:
#: only which faces occur once matters. Higher-order elements use their corner nodes (they come first).
_FACES: dict[str, tuple[tuple[int, ...], ...]] = {
    "hexahedron": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)),
    "tetra": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)),
    "wedge": ((0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)),
    "pyramid": ((0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)),
}
_SHELLS = {"triangle": (0, 1, 2), "quad": (0, 1, 2, 3)}
#: The operating point's attributes a result passes on.
_POINT_ATTRS = ("rpm", "disc_speed", "mu", "theta", "tan_theta", "verdict")


def _base_kind(kind: str) -> str:
    """``hexahedron27`` -> ``hexahedron``, ``tetra10`` -> ``tetra``, ``quad8`` -> ``quad``."""
    return re.sub(r"\d+$", "", kind)


def mesh_of(model: Any) -> tuple[NDArray[np.float64], tuple[tuple[str, NDArray[np.int64]], ...]]:
    """The mesh of an FE model as ``(points (p, 3), cells)``.

    Parameters
    ----------
    model : FEModel
        A model with a mesh (an :class:`~squealkit.fe.mesh.FEMesh` or a ``meshio.Mesh``).

    Returns
    -------
    points : ndarray, shape (p, 3)
    cells : tuple of (str, ndarray)
        Cell type and point indices of each element block.

    Raises
    ------
    InputError
        If the model has no mesh.
    """
    mesh = getattr(model, "mesh", None)
    if mesh is None:
        raise InputError("The model has no mesh ([fe] mesh = \"brake.inp\" in its TOML): its modes cannot be drawn "
                         "on the brake.")
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.shape[1] == 2:
        points = np.hstack([points, np.zeros((len(points), 1))])
    cells = tuple((str(c[0]), np.asarray(c[1], dtype=np.int64)) if isinstance(c, tuple)
                  else (str(c.type), np.asarray(c.data, dtype=np.int64)) for c in mesh.cells)
    return points, cells


def _dofs_named_on_points(names: Any, n_pts: int) -> tuple[NDArray[np.int64], ...] | None:
    pattern = re.compile(r"^node(\d+)\.([xyz])$")
    hits = [(i, int(m.group(1)), "xyz".index(m.group(2))) for i, name in enumerate(names or ())
            if (m := pattern.match(str(name))) and int(m.group(1)) < n_pts]
    if not hits:
        return None
    return tuple(np.array(x, dtype=np.int64) for x in zip(*hits, strict=True))


def dof_places(model: Any) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """(DOF index, mesh point, component 0-2) of every translational DOF of the model that is on its mesh.

    A model read with labels (a :class:`~squealkit.fe.dofmap.DofMap` and an
    :class:`~squealkit.fe.mesh.FEMesh`) places DOF ``(node, 1..3)`` on the node's point; DOFs
    named ``node{k}.x/y/z`` (the built-in brake) go to point k; otherwise the DOFs must be the
    points' components in order (``n_dof`` = 1, 2 or 3 times the points). DOFs on nodes
    outside the mesh (mid-side nodes of a vertex-only mesh, rotations) are left out.

    Parameters
    ----------
    model : FEModel
        A model with a mesh.

    Returns
    -------
    dof, point, component : ndarray of int64, each shape (d,)

    Raises
    ------
    InputError
        If the model has no mesh, or its DOFs do not map onto the mesh.
    """
    from .mesh import FEMesh

    points, _ = mesh_of(model)
    n_pts = len(points)
    if isinstance(model.mesh, FEMesh) and getattr(model, "dof_map", None) is not None:
        return model.mesh.dof_points(model.dof_map)
    named = _dofs_named_on_points(model.dof_names, n_pts)
    if named is not None:
        return named  # type: ignore[return-value]
    comp = model.n_dof // n_pts if n_pts and model.n_dof % n_pts == 0 else 0
    if comp not in (1, 2, 3):
        raise InputError(f"The model's {model.n_dof} DOFs do not map onto the mesh's {n_pts} points "
                         "(nor are they named node{k}.x/y/z).")
    idx = np.arange(model.n_dof, dtype=np.int64)
    return idx, idx // comp, idx % comp


def surface_triangles(points: NDArray, cells: Any) -> NDArray[np.int64]:
    """The outer surface of a mesh as triangles (point indices, shape (t, 3)).

    Faces of solid elements that belong to one element only (the boundary), split into
    triangles; shell elements (``triangle``, ``quad``) are surface already. Line elements are
    left out. Higher-order elements contribute their corner nodes.

    Parameters
    ----------
    points : ndarray, shape (p, 3)
        The mesh's points (only their number matters).
    cells : sequence of (str, ndarray)
        Element blocks: meshio cell type and point indices, VTK node order.

    Returns
    -------
    ndarray of int64, shape (t, 3)
    """
    faces: list[NDArray[np.int64]] = []  # quads as (f, 4), triangles padded with -1
    for kind, conn in cells:
        base = _base_kind(kind)
        conn = np.asarray(conn, dtype=np.int64)
        if not conn.size:
            continue
        if base in _SHELLS:
            local = [_SHELLS[base]]
        elif base in _FACES:
            local = list(_FACES[base])
        else:
            continue
        for f in local:
            block = conn[:, list(f)]
            if block.shape[1] == 3:
                block = np.hstack([block, np.full((len(block), 1), -1, dtype=np.int64)])
            faces.append(block)
    if not faces:
        return np.zeros((0, 3), dtype=np.int64)
    allf = np.vstack(faces)
    key = np.sort(allf, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    outer = allf[counts[inverse.ravel()] == 1]
    quads = outer[outer[:, 3] >= 0]
    tris = outer[outer[:, 3] < 0][:, :3]
    return np.vstack([tris, quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]).astype(np.int64)


@dataclass(frozen=True)
class Bodies:
    """The separate bodies of a mesh and the body of each DOF.

    Attributes
    ----------
    names : tuple of str
        ``"body 1"``, ``"body 2"``...: the body with the most DOFs first.
    of_dof : ndarray of int64, shape (n_dof,)
        The body of each DOF (index into ``names``), -1 where none is known.
    centroid : ndarray, shape (b, 3)
        Mean position of each body's points [m].
    extent : ndarray, shape (b, 3)
        Size of each body's bounding box [m].
    """

    names: tuple[str, ...]
    of_dof: NDArray[np.int64]
    centroid: NDArray[np.float64]
    extent: NDArray[np.float64]

    def describe(self, k: int) -> str:
        """``body 1: 280 x 280 x 15 mm about (0, 0, 7.5) mm``."""
        e, c = 1e3 * self.extent[k], 1e3 * self.centroid[k] + 0.0
        c = np.where(np.abs(c) < 1e-6 * max(float(e.max()), 1e-300), 0.0, c)  # -6.6e-15 mm is 0
        return (f"{self.names[k]}: {e[0]:.4g} x {e[1]:.4g} x {e[2]:.4g} mm about "
                f"({c[0]:.4g}, {c[1]:.4g}, {c[2]:.4g}) mm")


def bodies(model: Any) -> Bodies:
    """The bodies of an FE model's mesh: the connected components of its elements.

    Disc, pads and caliper meshed apart and tied by springs or contact are separate bodies.
    Each DOF on a point of the mesh gets that point's body; a DOF off the mesh (a mid-side node
    of a mesh given by its vertices) gets the body of the DOF it is most strongly coupled to in
    the mass matrix (consistent mass couples the nodes of one element only); DOFs coupled to no
    body stay at -1.

    Parameters
    ----------
    model : FEModel
        A model with a mesh.

    Returns
    -------
    Bodies
    """
    points, cells = mesh_of(model)
    n_pts = len(points)
    rows, cols = [], []
    for _kind, conn in cells:
        if conn.size and conn.shape[1] > 1:
            rows.append(np.repeat(conn[:, 0], conn.shape[1] - 1))
            cols.append(conn[:, 1:].ravel())
    in_cell = np.zeros(n_pts, dtype=bool)
    for _kind, conn in cells:
        in_cell[conn.ravel()] = True
    graph = sp.coo_matrix((np.ones(sum(r.size for r in rows)), (np.concatenate(rows or [np.zeros(0, int)]),
                                                                np.concatenate(cols or [np.zeros(0, int)]))),
                          shape=(n_pts, n_pts))
    _, comp = connected_components(graph, directed=False)
    comp = np.where(in_cell, comp, -1)
    dof, point, _c = dof_places(model)
    of_dof = np.full(model.n_dof, -1, dtype=np.int64)
    of_dof[dof] = comp[point]
    # DOFs off the mesh (or on points in no element): the body of their strongest mass coupling
    M = abs(sp.csr_matrix(model.M))
    for _ in range(8):
        todo = np.flatnonzero(of_dof < 0)
        if not todo.size:
            break
        known = of_dof >= 0
        sub = M[todo][:, np.flatnonzero(known)].tocsr()
        if not sub.nnz:
            break
        best = np.asarray(sub.argmax(axis=1)).ravel()
        has = np.asarray(sub.max(axis=1).todense()).ravel() > 0
        of_dof[todo[has]] = of_dof[np.flatnonzero(known)[best[has]]]
    used = np.unique(of_dof[of_dof >= 0])
    counts = np.array([(of_dof == b).sum() for b in used])
    order = used[np.argsort(-counts, kind="stable")]
    renumber = np.full(max(int(comp.max(initial=-1)) + 1, 1), -1, dtype=np.int64)
    renumber[order] = np.arange(order.size)
    of_dof = np.where(of_dof >= 0, renumber[np.maximum(of_dof, 0)], -1)
    comp_new = np.where(comp >= 0, renumber[np.maximum(comp, 0)], -1)
    centroid = np.zeros((order.size, 3))
    extent = np.zeros((order.size, 3))
    for k in range(order.size):
        pts = points[comp_new == k]
        if len(pts):
            centroid[k] = pts.mean(axis=0)
            extent[k] = np.ptp(pts, axis=0)
    return Bodies(tuple(f"body {k + 1}" for k in range(order.size)), of_dof, centroid, extent)


def mode_surface(model: Any, ds: Any, energy: Any = None) -> Any:
    """The outer surface of the mesh with the complex mode shapes on its points, for 3D views.

    Parameters
    ----------
    model : FEModel
        A model with a mesh.
    ds : xarray.Dataset
        A result of :func:`~squealkit.stability.fe_modes` (shapes over ``(dof, mode)``).
    energy : xarray.Dataset, optional
        The :func:`~squealkit.fe.energy.mode_energy` of ``ds``: its friction work per node is
        put on the surface points too (``friction_work_point``).

    Returns
    -------
    xarray.Dataset
        ``kind = "fe_mode_surface"``: ``x, y, z`` [m] over ``surface_point``; ``triangles``
        (point indices) over ``(triangle, corner)``; ``shape_real``, ``shape_imag`` over
        ``(surface_point, component, mode)`` (the mode shapes as normalised by ``fe_modes``;
        points without DOFs at rest); the eigenvalue variables over ``mode``; with ``energy``,
        ``friction_work_point`` [J per cycle] over ``(surface_point, mode)``.
    """
    import xarray as xr

    points, cells = mesh_of(model)
    tri = surface_triangles(points, cells)
    if not tri.size:
        raise InputError("The mesh has no solid or shell elements: there is no surface to draw the modes on.")
    used = np.unique(tri)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    dof, point, comp = dof_places(model)
    X = ds["shape_real"].values + 1j * ds["shape_imag"].values
    on = remap[point] >= 0
    shape = np.zeros((used.size, 3, X.shape[1]), dtype=np.complex128)
    shape[remap[point[on]], comp[on]] = X[dof[on]]
    sp_dims = ("surface_point",)
    out = xr.Dataset(
        {
            "x": (sp_dims, points[used, 0], {"units": "m"}),
            "y": (sp_dims, points[used, 1], {"units": "m"}),
            "z": (sp_dims, points[used, 2], {"units": "m"}),
            "triangles": (("triangle", "corner"), remap[tri]),
            "shape_real": (("surface_point", "component", "mode"), shape.real),
            "shape_imag": (("surface_point", "component", "mode"), shape.imag),
            **{k: ds[k] for k in ("growth_rate", "frequency_hz", "damping_ratio", "unstable") if k in ds},
        },
        coords={"mode": ds["mode"].values, "component": ["x", "y", "z"]},
        attrs={**{k: v for k, v in ds.attrs.items() if k in _POINT_ATTRS},
               "kind": "fe_mode_surface", "title": "Complex mode shapes on the surface of the mesh"},
    )
    if energy is not None:
        w = np.zeros((used.size, X.shape[1]))
        wd = np.nan_to_num(energy["friction_work_dof"].values)
        np.add.at(w, remap[point[on]], wd[dof[on]])
        out["friction_work_point"] = (("surface_point", "mode"), w,
                                      {"units": "J", "long_name": "friction work per cycle through each node"})
    return out
