"""Pluggable sparse LU: factorise ``P`` once, solve ``P x = b`` for vectors or blocks many times.

Every factorisation of the band walks (:mod:`squealkit.solvers.band`) and of the reduction bases
(:mod:`squealkit.solvers.reduction`) goes through :func:`factorize`, so a faster direct solver
drops in without touching the algorithms, as pymor injects its shifted-system solver
(``eigs(..., shifted_system_solver=...)``). A backend is a callable

``backend(P, perm) -> factor``

taking a square sparse (or dense) matrix ``P`` and a fill-reducing ordering ``perm`` (or None:
the backend orders as it likes) and returning an object with ``factor.solve(B)`` (``B`` a vector
or an ``(n, k)`` block, real or complex) that raises :class:`RuntimeError` where ``P`` is exactly
singular. Choose one per call (``band_eigs(..., lu="dense")`` or a callable) or for a whole run
(:func:`set_lu_backend`, :func:`use_lu_backend`); :func:`register_lu_backend` adds one by name.

Built in:

- ``"superlu"`` (the default, always installed): SciPy's SuperLU on ``P[perm][:, perm]`` in a
  METIS nested-dissection order (:func:`fill_reducing_order`), diagonal pivots preferred
  (:class:`PermutedLU`);
- ``"dense"``: LAPACK's LU of the dense matrix (:class:`DenseLU`), for small models and as an
  independent check of the sparse one.
"""

from __future__ import annotations

import contextlib
import importlib.util
import threading
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from .._threads import honour_thread_limit
from .._validation import InputError

__all__ = [
    "LU_BACKENDS",
    "DenseLU",
    "Factor",
    "PermutedLU",
    "factorize",
    "fill_reducing_order",
    "get_lu_backend",
    "lu_backend",
    "register_lu_backend",
    "set_lu_backend",
    "use_lu_backend",
]


class Factor(Protocol):
    """What a backend returns: a factorisation that solves ``P x = b``."""

    def solve(self, b: NDArray) -> NDArray:  # pragma: no cover - a protocol
        """``P^-1 b`` for a vector or an ``(n, k)`` block ``b``."""
        ...


#: A backend: ``backend(P, perm) -> Factor`` (module docstring).
Backend = Callable[[Any, "NDArray[np.intp] | None"], Factor]


def fill_reducing_order(*mats) -> NDArray[np.intp]:
    """A fill-reducing ordering of the union sparsity pattern of ``mats`` (square, one size).

    METIS nested dissection (pymetis) of the graph of ``A + A^T``: on the built-in brake's
    115 326 DOFs it leaves 6.8e7 entries in L + U against 8.3e7 for SuperLU's minimum degree,
    and the factorisation takes 9 s CPU against 20 s. The pattern is the same at every shift,
    so one ordering serves a whole band solve.

    Parameters
    ----------
    *mats : sparse or dense matrices, shape (n, n)
        The matrices whose combined pattern is factorised (e.g. M, C and K).

    Returns
    -------
    ndarray of int, shape (n,)
        ``perm``: factorise ``P[perm][:, perm]``.
    """
    import pymetis

    pattern = sum(abs(sp.csr_matrix(m)) for m in mats)  # no cancellation: entries add in magnitude
    graph = (pattern + pattern.T).tocsr()
    graph.setdiag(0)
    graph.eliminate_zeros()
    perm, _ = pymetis.nested_dissection(pymetis.CSRAdjacency(graph.indptr, graph.indices))
    return np.asarray(perm, dtype=np.intp)


class PermutedLU:
    """Sparse LU of ``P[perm][:, perm]`` (real or complex) by SuperLU, solving ``P x = b`` for
    vectors or blocks ``b``.

    SuperLU's symmetric mode (diagonal pivots preferred, threshold ``diag_pivot_thresh``) keeps
    the ordering instead of letting row pivoting undo it: on the built-in brake at 33 966 DOFs,
    3.3 s CPU and 1.6e7 entries in L + U with minimum degree against 27 s and 6.3e7 with
    SuperLU's default COLAMD and partial pivoting. Every eigenpair of the band solver is checked
    by its backward error, so a less stable pivot cannot go unnoticed.

    Parameters
    ----------
    P : sparse matrix, shape (n, n)
        Structurally symmetric (an FE matrix).
    perm : ndarray of int, shape (n,)
        Fill-reducing ordering (:func:`fill_reducing_order`).
    diag_pivot_thresh : float, default 0.1
        SuperLU's diagonal pivot threshold (0: every pivot on the diagonal, then ``U = D L^T``
        for a symmetric P, whose signs give the inertia).
    """

    def __init__(self, P, perm: NDArray[np.intp], *, diag_pivot_thresh: float = 0.1):
        self.perm = perm
        self.dtype = np.result_type(P.dtype, np.float64)
        Pp = sp.csc_matrix(P, dtype=self.dtype)[perm][:, perm].tocsc()
        # diagonal pivots (threshold 0.1) keep the ordering; partial pivoting would undo it
        self.lu = spla.splu(Pp, permc_spec="NATURAL", diag_pivot_thresh=diag_pivot_thresh,
                            options={"SymmetricMode": True})

    @property
    def nnz(self) -> int:
        """Entries in L + U."""
        return self.lu.L.nnz + self.lu.U.nnz

    def solve(self, b: NDArray) -> NDArray:
        """``P^-1 b`` for a vector or an ``(n, k)`` block ``b``.

        Parameters
        ----------
        b : ndarray, shape (n,) or (n, k)

        Returns
        -------
        ndarray, shape of ``b``
        """
        b = np.asarray(b)
        x = np.empty(b.shape, dtype=np.result_type(self.dtype, b.dtype))
        x[self.perm] = self.lu.solve(b[self.perm].astype(x.dtype, copy=False))
        return x


class DenseLU:
    """LAPACK's LU (``getrf``, partial pivoting) of the dense ``P``; ``perm`` is not needed.

    For models of a few hundred DOFs, and as an independent check of the sparse backend.

    Parameters
    ----------
    P : sparse or dense matrix, shape (n, n)

    Raises
    ------
    RuntimeError
        If ``P`` is exactly singular (a zero pivot).
    """

    def __init__(self, P):
        A = P.toarray() if sp.issparse(P) else np.asarray(P)
        self.dtype = np.result_type(A.dtype, np.float64)
        with warnings.catch_warnings():  # a zero pivot is the RuntimeError below, not a warning
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            self.lu, self.piv = sla.lu_factor(A.astype(self.dtype), check_finite=False)
        if np.any(np.diag(self.lu) == 0):
            raise RuntimeError("Factor is exactly singular")

    def solve(self, b: NDArray) -> NDArray:
        """``P^-1 b`` for a vector or an ``(n, k)`` block ``b``.

        Parameters
        ----------
        b : ndarray, shape (n,) or (n, k)

        Returns
        -------
        ndarray, shape of ``b``
        """
        b = np.asarray(b)
        dtype = np.result_type(self.dtype, b.dtype)
        lu = self.lu.astype(dtype, copy=False)
        return sla.lu_solve((lu, self.piv), b.astype(dtype, copy=False), check_finite=False)


def _superlu(P, perm: NDArray[np.intp] | None = None) -> PermutedLU:
    return PermutedLU(P, fill_reducing_order(P) if perm is None else perm)


def _dense(P, perm: NDArray[np.intp] | None = None) -> DenseLU:
    return DenseLU(P)


@dataclass(frozen=True)
class _Entry:
    backend: Backend
    requires: tuple[str, ...]
    install: str


#: The LU backends by name (:func:`register_lu_backend` adds one).
LU_BACKENDS: dict[str, _Entry] = {
    "superlu": _Entry(_superlu, (), ""),
    "dense": _Entry(_dense, (), ""),
}
_DEFAULT = {"name": "superlu"}
_LOCK = threading.Lock()


def register_lu_backend(name: str, backend: Backend, *, requires: tuple[str, ...] = (), install: str = "") -> None:
    """Make ``backend`` available as ``lu=name``.

    Parameters
    ----------
    name : str
        The name it is chosen by.
    backend : callable
        ``backend(P, perm) -> factor`` with ``factor.solve(B)`` (module docstring).
    requires : tuple of str, optional
        Modules it imports; while one is missing, choosing it is an :class:`InputError` naming it.
    install : str, optional
        How to install them (shown in that error), e.g. ``"pip install pypardiso"``.

    Returns
    -------
    None

    Examples
    --------
    >>> register_lu_backend("dense-again", lambda P, perm: DenseLU(P))
    >>> get_lu_backend("dense-again") is LU_BACKENDS["dense-again"].backend
    True
    >>> del LU_BACKENDS["dense-again"]
    """
    if not isinstance(name, str) or not name:
        raise InputError(f"An LU backend needs a name, got {name!r}.")
    if not callable(backend):
        raise InputError(f"LU backend {name!r} must be callable as backend(P, perm), got {type(backend).__name__}.")
    LU_BACKENDS[name] = _Entry(backend, tuple(requires), install)


def get_lu_backend(lu: str | Backend | None = None) -> Backend:
    """The backend ``lu`` names (or is), the current default when None.

    Parameters
    ----------
    lu : str or callable, optional
        A name of :data:`LU_BACKENDS`, or a backend callable itself.

    Returns
    -------
    callable
        ``backend(P, perm) -> factor``.

    Raises
    ------
    InputError
        For an unknown name (the known ones listed) or a backend whose modules are not installed.
    """
    if lu is None:
        lu = _DEFAULT["name"]
    if callable(lu) and not isinstance(lu, str):
        return lu
    entry = LU_BACKENDS.get(lu) if isinstance(lu, str) else None
    if entry is None:
        raise InputError(f"Unknown LU backend lu={lu!r}; known: {', '.join(LU_BACKENDS)}.")
    missing = [m for m in entry.requires if importlib.util.find_spec(m) is None]
    if missing:
        hint = f": {entry.install}" if entry.install else ""
        raise InputError(f"LU backend {lu!r} is not available: it needs {', '.join(missing)}{hint}.")
    return entry.backend


def lu_backend() -> str:
    """The name of the default LU backend (``"superlu"`` unless set).

    Returns
    -------
    str
    """
    return _DEFAULT["name"]


def set_lu_backend(name: str) -> str:
    """Make ``name`` the default LU backend of every later solve; returns the previous default.

    Parameters
    ----------
    name : str
        A name of :data:`LU_BACKENDS` (checked to be available).

    Returns
    -------
    str
        The previous default.
    """
    if not isinstance(name, str):
        raise InputError(f"set_lu_backend takes a backend name, got {type(name).__name__}; "
                         "pass a callable per call (lu=...) or register it first.")
    get_lu_backend(name)
    with _LOCK:
        previous, _DEFAULT["name"] = _DEFAULT["name"], name
    return previous


@contextlib.contextmanager
def use_lu_backend(name: str) -> Iterator[str]:
    """The default LU backend set to ``name`` inside a ``with`` block, restored after.

    Parameters
    ----------
    name : str
        A name of :data:`LU_BACKENDS`.

    Yields
    ------
    str
        ``name``.
    """
    previous = set_lu_backend(name)
    try:
        yield name
    finally:
        set_lu_backend(previous)


@honour_thread_limit
def factorize(P, perm: NDArray[np.intp] | None = None, *, lu: str | Backend | None = None) -> Factor:
    """The factorisation of ``P`` by the backend ``lu`` (default: :func:`lu_backend`).

    Parameters
    ----------
    P : sparse or dense matrix, shape (n, n)
        Real or complex.
    perm : ndarray of int, shape (n,), optional
        A fill-reducing ordering for the backend (``superlu``: :func:`fill_reducing_order` of P
        when not given).
    lu : str or callable, optional
        The backend (module docstring).

    Returns
    -------
    Factor
        An object with ``solve(B)``.

    Raises
    ------
    RuntimeError
        If ``P`` is exactly singular.
    InputError
        For an unknown or unavailable backend.

    Examples
    --------
    >>> f = factorize(sp.csr_matrix([[2.0, 1.0], [1.0, 3.0]]), lu="dense")
    >>> np.round(f.solve(np.array([3.0, 4.0])), 12).tolist()
    [1.0, 1.0]
    """
    return get_lu_backend(lu)(P, perm)
