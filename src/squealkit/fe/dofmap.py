"""One global DOF map of an FE model: ``(node label, DOF number) -> index`` across all of its files.

Industrial FE codes label every unknown by its node and DOF (Abaqus ``12, 3``: node 12, ``u3``;
ANSYS ``12 UZ``; Nastran ``GRID 12, component 3``). The files of one model need not all hold
the same DOFs (a friction matrix lives on the contact nodes only), and a code may add internal
nodes with negative labels (Abaqus Lagrange multipliers, connector nodes). :class:`DofMap` is the
union of the labels of all files of a model, in a fixed order (positive node labels ascending,
then internal ones; DOFs ascending within a node), and :class:`LabelledMatrix` is one matrix as a
file gives it: entries addressed by labels, placed into the global numbering by
:func:`assemble_labelled`.

DOF numbers follow Abaqus and Nastran: 1-3 translations ``u1..u3``, 4-6 rotations ``ur1..ur3``;
ANSYS labels map onto the same numbers (``UX -> 1 ... ROTZ -> 6``, others as ANSYS numbers them);
0 is a scalar point (Nastran SPOINT) or an equation number of an unlabelled file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from .._validation import InputError

__all__ = ["DofMap", "LabelledMatrix"]

#: FE matrices symmetric by definition: a file giving one triangle of these is mirrored.
SYMMETRIC_MATRICES: tuple[str, ...] = ("M", "D1", "D4", "K1", "KGeo")
#: DOF numbers stay below this (ANSYS numbers its DOF kinds up to a few hundred).
_DOF_LIMIT = 1 << 20
#: Node labels stay within +- this, so (node, dof) packs into one int64 key.
_NODE_LIMIT = 1 << 42
_DOF_NAMES = {0: "u0", 1: "u1", 2: "u2", 3: "u3", 4: "ur1", 5: "ur2", 6: "ur3"}


def _key(node: NDArray[np.int64], dof: NDArray[np.int64]) -> NDArray[np.int64]:
    return node * _DOF_LIMIT + dof


def _labels(name: str, node: Any, dof: Any) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    node = np.asarray(node, dtype=np.int64).reshape(-1)
    dof = np.asarray(dof, dtype=np.int64).reshape(-1)
    if node.shape != dof.shape:
        raise InputError(f"{name}: {node.size} node labels but {dof.size} DOF numbers.")
    if node.size and (np.abs(node).max() >= _NODE_LIMIT):
        raise InputError(f"{name}: node label {int(node[np.argmax(np.abs(node))])} is beyond +-{_NODE_LIMIT}.")
    if dof.size and (dof.min() < 0 or dof.max() >= _DOF_LIMIT):
        bad = int(dof[(dof < 0) | (dof >= _DOF_LIMIT)][0])
        raise InputError(f"{name}: DOF number {bad} is outside 0..{_DOF_LIMIT - 1}.")
    return node, dof


@dataclass(frozen=True, eq=False)
class DofMap:
    """The labels of an FE model's unknowns: unknown ``i`` is DOF ``dof[i]`` of node ``node[i]``.

    Attributes
    ----------
    node : ndarray of int64, shape (n,)
        Node label of each unknown (negative: an internal node of the FE code).
    dof : ndarray of int64, shape (n,)
        DOF number at that node (1-3 translations, 4-6 rotations, 0 scalar point).

    Examples
    --------
    >>> dm = DofMap.from_labels([7, 3, 3, -1], [1, 2, 1, 1])
    >>> dm.node.tolist(), dm.dof.tolist()
    ([3, 3, 7, -1], [1, 2, 1, 1])
    >>> dm.index([7, 3], [1, 2]).tolist()
    [2, 1]
    >>> dm.names[-1]
    'n-1.u1'
    """

    node: Any
    dof: Any

    def __post_init__(self) -> None:
        node, dof = _labels("DOF map", self.node, self.dof)
        keys = _key(node, dof)
        if np.unique(keys).size != keys.size:
            raise InputError("DOF map: a (node, DOF) label appears twice.")
        node.flags.writeable = False
        dof.flags.writeable = False
        object.__setattr__(self, "node", node)
        object.__setattr__(self, "dof", dof)
        order = np.argsort(keys, kind="stable")
        object.__setattr__(self, "_sorted_keys", keys[order])
        object.__setattr__(self, "_order", order)

    @classmethod
    def from_labels(cls, node: Any, dof: Any) -> DofMap:
        """The map of the distinct ``(node, dof)`` pairs given (repeats allowed), in the canonical order.

        Positive node labels ascending, then internal (negative) ones by their magnitude; DOFs
        ascending within a node.
        """
        node, dof = _labels("DOF labels", node, dof)
        keys = np.unique(_key(node, dof))
        node_u = np.floor_divide(keys, _DOF_LIMIT)
        dof_u = keys - node_u * _DOF_LIMIT
        order = np.lexsort((dof_u, np.abs(node_u), node_u < 0))
        return cls(node_u[order], dof_u[order])

    @property
    def n_dof(self) -> int:
        """Number of unknowns n."""
        return int(self.node.size)

    def __len__(self) -> int:
        return self.n_dof

    def index(self, node: Any, dof: Any, *, what: str = "a file") -> NDArray[np.int64]:
        """The index of each ``(node, dof)`` label; one line naming the first label not in the map."""
        node, dof = _labels(what, node, dof)
        keys = _key(node, dof)
        pos = np.searchsorted(self._sorted_keys, keys)
        pos = np.minimum(pos, max(self._sorted_keys.size - 1, 0))
        hit = self._sorted_keys[pos] == keys if self._sorted_keys.size else np.zeros(keys.size, bool)
        if not np.all(hit):
            i = int(np.flatnonzero(~hit)[0])
            raise InputError(f"{what}: node {int(node[i])} DOF {int(dof[i])} is not in the model's DOF map.")
        return self._order[pos]

    @property
    def names(self) -> tuple[str, ...]:
        """A name per unknown, ``n<node>.<u1|u2|u3|ur1|ur2|ur3>`` (``n12.u3``; ``dof<k>`` beyond 6)."""
        return tuple(f"n{n}.{_DOF_NAMES.get(d, f'dof{d}')}" for n, d in zip(self.node.tolist(), self.dof.tolist(),
                                                                          strict=True))

    def to_dict(self) -> dict[str, Any]:
        """The labels as lists (for JSON)."""
        return {"node": self.node.tolist(), "dof": self.dof.tolist()}


@dataclass(frozen=True, eq=False)
class LabelledMatrix:
    """One matrix of a file, its entries addressed by labels: ``A[(rn, rd), (cn, cd)] = value``.

    Attributes
    ----------
    row_node, row_dof, col_node, col_dof : ndarray of int64, shape (nnz,)
        Labels of each entry's row and column.
    value : ndarray of float64, shape (nnz,)
        The entries (repeated positions add up).
    symmetric : bool or None
        True: the file declares a symmetric matrix stored as one triangle (mirrored when placed);
        False: the entries are the whole matrix; None: the file does not say (Abaqus): a matrix
        symmetric by definition (:data:`SYMMETRIC_MATRICES`) is mirrored when no off-diagonal
        entry has its mirror entry in the file (one triangle), else taken as given.
    labels : tuple of ndarray, optional
        ``(node, dof)`` of DOFs the file declares beyond its entries (a mapping file), included in the map.
    source : str
        The file it came from, for messages.
    equations : bool
        The labels are equation numbers ``(k, 0)``, not nodes (Abaqus COORDINATE, Harwell-Boeing
        without a mapping file).
    """

    row_node: Any
    row_dof: Any
    col_node: Any
    col_dof: Any
    value: Any
    symmetric: bool | None = None
    labels: tuple[Any, Any] | None = None
    source: str = ""
    equations: bool = False

    def __post_init__(self) -> None:
        rn, rd = _labels(self.source, self.row_node, self.row_dof)
        cn, cd = _labels(self.source, self.col_node, self.col_dof)
        value = np.asarray(self.value)
        if value.dtype.kind == "c":
            raise InputError(f"{self.source}: the matrix is complex; FE matrices must be real.")
        value = value.astype(np.float64).reshape(-1)
        if not (rn.size == cn.size == value.size):
            raise InputError(f"{self.source}: {rn.size} rows, {cn.size} columns and {value.size} values differ.")
        if not np.all(np.isfinite(value)):
            i = int(np.flatnonzero(~np.isfinite(value))[0])
            raise InputError(f"{self.source}: a non-finite value at node {rn[i]} DOF {rd[i]}, node {cn[i]} DOF "
                             f"{cd[i]}; FE matrices must be finite.")
        for key, val in (("row_node", rn), ("row_dof", rd), ("col_node", cn), ("col_dof", cd), ("value", value)):
            object.__setattr__(self, key, val)

    @property
    def nnz(self) -> int:
        """Number of entries in the file."""
        return int(self.value.size)

    def label_sets(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Every ``(node, dof)`` label the matrix uses or declares."""
        nodes = [self.row_node, self.col_node]
        dofs = [self.row_dof, self.col_dof]
        if self.labels is not None:
            n, d = _labels(self.source, *self.labels)
            nodes.append(n)
            dofs.append(d)
        return np.concatenate(nodes), np.concatenate(dofs)

    def is_one_triangle(self) -> bool:
        """No off-diagonal entry has its mirror entry (with at least one off-diagonal entry)."""
        r, c = _key(self.row_node, self.row_dof), _key(self.col_node, self.col_dof)
        off = r != c
        if not off.any():
            return False
        return not _has_mirror(r[off], c[off])

    def to_sparse(self, dof_map: DofMap, name: str) -> sp.coo_matrix:
        """The matrix in ``dof_map``'s numbering, shape (n, n); mirrored when stored as one triangle."""
        i = dof_map.index(self.row_node, self.row_dof, what=self.source)
        j = dof_map.index(self.col_node, self.col_dof, what=self.source)
        v = self.value
        mirror = self.symmetric
        if mirror is None:
            mirror = name in SYMMETRIC_MATRICES and self.is_one_triangle()
        if mirror:
            off = i != j
            if _has_mirror(i[off], j[off]):
                raise InputError(f"{self.source}: declared symmetric (one triangle) but holds entries on both sides "
                                 "of the diagonal.")
            i, j, v = np.concatenate([i, j[off]]), np.concatenate([j, i[off]]), np.concatenate([v, v[off]])
        n = dof_map.n_dof
        return sp.coo_matrix((v, (i, j)), shape=(n, n))


def _has_mirror(r: NDArray[np.int64], c: NDArray[np.int64]) -> bool:
    """Whether any entry (r, c) has its mirror (c, r) among the entries (off-diagonal ones given)."""
    if r.size == 0:
        return False
    _, inv = np.unique(np.concatenate([r, c]), return_inverse=True)  # compact codes: no int64 overflow
    m = int(inv.max()) + 1
    ri, ci = inv[: r.size], inv[r.size:]
    return bool(np.isin(ci * m + ri, ri * m + ci).any())


def assemble_labelled(found: Mapping[str, LabelledMatrix]) -> tuple[DofMap, dict[str, sp.coo_matrix]]:
    """One DOF map over all the matrices (the union of their labels) and each matrix placed in it.

    Parameters
    ----------
    found : mapping of str to LabelledMatrix
        FE matrix name (``M``, ``K1``, ...) -> the matrix as its file gives it.

    Returns
    -------
    (DofMap, dict of str to scipy.sparse.coo_matrix)
        The global map and each matrix of shape (n, n) in its numbering.
    """
    nodes, dofs = zip(*(m.label_sets() for m in found.values()), strict=True)
    dof_map = DofMap.from_labels(np.concatenate(nodes), np.concatenate(dofs))
    return dof_map, {name: m.to_sparse(dof_map, name) for name, m in found.items()}
