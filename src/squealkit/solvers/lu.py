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
  independent check of the sparse one;
- ``"pardiso"`` (optional: ``pip install squealkit[fast]``, which brings ``pypardiso`` and MKL):
  Intel MKL PARDISO (:class:`PardisoLU`), real and complex, symmetric matrices by their lower
  triangle, threaded;
- ``"auto"`` (the default): PARDISO where it is installed and the matrix has at least
  :data:`PARDISO_MIN_DOF` rows, SuperLU otherwise.

The environment variable ``SQUEALKIT_LU`` (a backend name) sets the default of a run, e.g.
``SQUEALKIT_LU=superlu`` to force SuperLU.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import os
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

from .._optional import available, require
from .._threads import honour_thread_limit
from .._validation import InputError

__all__ = [
    "LU_BACKENDS",
    "PARDISO_MIN_DOF",
    "DenseLU",
    "Factor",
    "PardisoLU",
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


class _FactorBase:
    """What every built-in factorisation shares: its size and type, and the solve of vectors and blocks.

    A backend's class factorises in ``__init__`` (after ``super().__init__(P)``, which sets ``n``
    and ``dtype``, float64 or complex128) and solves an ``(n, k)`` block of its own ``dtype`` in
    ``_solve_block``. :meth:`solve` does the rest for all of them: a vector is a block of one; a
    right-hand side of another size is a ``ValueError``; a real one is cast to a complex factor's
    type; a complex one of a real factor is solved as its real and imaginary parts side by side
    (one pass over the real factors, never a complex copy of them).

    Attributes
    ----------
    n : int
        Rows of ``P``.
    dtype : numpy.dtype
        The factor's type (float64 or complex128).
    """

    def __init__(self, P) -> None:
        self.n = int(P.shape[0])
        self.dtype = np.result_type(P.dtype, np.float64)

    def _solve_block(self, B: NDArray) -> NDArray:  # pragma: no cover - each backend has its own
        raise NotImplementedError

    def solve(self, b: NDArray) -> NDArray:
        """``P^-1 b`` for a vector or an ``(n, k)`` block ``b``, real or complex.

        Parameters
        ----------
        b : ndarray, shape (n,) or (n, k)

        Returns
        -------
        ndarray, shape of ``b``
            Of type ``result_type(factor, b, float64)``.
        """
        b = np.asarray(b)
        if b.ndim not in (1, 2) or b.shape[0] != self.n:
            raise ValueError(f"A right-hand side of shape {b.shape} where the factor has {self.n} rows: "
                             f"give ({self.n},) or ({self.n}, k).")
        B = b.reshape(self.n, -1)
        if np.iscomplexobj(B) and self.dtype.kind != "c":
            k = B.shape[1]
            X = self._solve_block(np.concatenate([B.real, B.imag], axis=1).astype(self.dtype, copy=False))
            return (X[:, :k] + 1j * X[:, k:]).reshape(b.shape)
        return self._solve_block(B.astype(self.dtype, copy=False)).reshape(b.shape)


class PermutedLU(_FactorBase):
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
        super().__init__(P)
        self.perm = perm
        Pp = sp.csc_matrix(P, dtype=self.dtype)[perm][:, perm].tocsc()
        # diagonal pivots (threshold 0.1) keep the ordering; partial pivoting would undo it
        self.lu = spla.splu(Pp, permc_spec="NATURAL", diag_pivot_thresh=diag_pivot_thresh,
                            options={"SymmetricMode": True})

    @property
    def nnz(self) -> int:
        """Entries in L + U."""
        return self.lu.L.nnz + self.lu.U.nnz

    def _solve_block(self, B: NDArray) -> NDArray:
        X = np.empty_like(B)
        X[self.perm] = self.lu.solve(B[self.perm])
        return X


class DenseLU(_FactorBase):
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
        super().__init__(A)
        with warnings.catch_warnings():  # a zero pivot is the RuntimeError below, not a warning
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            self.lu, self.piv = sla.lu_factor(A.astype(self.dtype), check_finite=False)
        if np.any(np.diag(self.lu) == 0):
            raise RuntimeError("Factor is exactly singular")

    def _solve_block(self, B: NDArray) -> NDArray:
        return sla.lu_solve((self.lu, self.piv), B, check_finite=False)


@functools.cache
def _mkl_pardiso():
    """MKL's ``pardiso`` routine (from the ``mkl_rt`` library pypardiso finds), typed for ctypes."""
    PyPardisoSolver = require("pypardiso", "The PARDISO LU").PyPardisoSolver

    fn = PyPardisoSolver().libmkl.pardiso
    i32 = ctypes.POINTER(ctypes.c_int32)
    fn.argtypes = [ctypes.POINTER(ctypes.c_int64), i32, i32, i32, i32, i32, ctypes.c_void_p, i32, i32, i32, i32,
                   i32, i32, ctypes.c_void_p, ctypes.c_void_p, i32]
    fn.restype = None
    return fn


def _is_symmetric(A) -> bool:
    """Whether the sparse ``A`` equals its transpose exactly (pattern and values), by comparing
    the arrays of ``A`` and of its transpose in canonical CSR (one transposed copy, no difference)."""
    A = sp.csr_matrix(A)
    if A.shape[0] != A.shape[1]:
        return False
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    T = A.T.tocsr()
    T.sort_indices()
    return (np.array_equal(A.indptr, T.indptr) and np.array_equal(A.indices, T.indices)
            and np.array_equal(A.data, T.data))


class PardisoLU(_FactorBase):
    """Intel MKL PARDISO's factorisation of ``P`` (real or complex), solving ``P x = b`` for vectors
    or blocks ``b``.

    A symmetric ``P`` (exactly, as ``K1`` or ``K1 - s M``) is factorised as ``L D L^T`` from its
    lower triangle (matrix type -2, or 6 for complex symmetric): half the memory and work of an
    LU; any other as an LU with pivoting by maximum weighted matching and scaling (matrix type 11
    or 13). PARDISO orders by its own METIS nested dissection, or by ``perm`` where given, and runs
    on the threads MKL is allowed (bounded by :mod:`squealkit._threads` through threadpoolctl).
    Tiny pivots are perturbed (to 1e-13 of the largest) rather than failing, with up to two
    steps of iterative refinement; an exactly singular ``P`` (a zero pivot after that, or
    PARDISO's error -4) is a :class:`RuntimeError`, as with the other backends.

    Parameters
    ----------
    P : sparse or dense matrix, shape (n, n)
        Real or complex.
    perm : ndarray of int, shape (n,), optional
        A fill-reducing ordering (:func:`fill_reducing_order`): ``P[perm][:, perm]`` is factorised.
    symmetric : bool, optional
        Whether ``P`` is symmetric, when the caller knows (else checked: one transposed copy).
    before_factor : callable, optional
        Called with PARDISO's prediction of its peak memory [bytes] after the symbolic analysis
        and before the numerical factorisation (the exact fill of the ordering), e.g. to refuse
        a factorisation that will not fit.

    Attributes
    ----------
    nnz : int
        Entries in the factors (PARDISO's count).
    peak_bytes : int
        PARDISO's peak memory of analysis and factorisation [bytes].
    """

    def __init__(self, P, perm: NDArray[np.intp] | None = None, *, symmetric: bool | None = None,
                 before_factor: Callable[[int], None] | None = None):
        A = sp.csr_matrix(P)
        super().__init__(A)
        complex_ = self.dtype.kind == "c"
        symmetric = _is_symmetric(A) if symmetric is None else bool(symmetric)
        self.mtype = (6 if complex_ else -2) if symmetric else (13 if complex_ else 11)
        if symmetric:
            A = sp.triu(A, format="csr")  # PARDISO's symmetric types read the upper triangle by rows
        A.sum_duplicates()
        A.sort_indices()
        self._a = np.ascontiguousarray(A.data, dtype=self.dtype)
        self._ia = np.ascontiguousarray(A.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(A.indices, dtype=np.int32)
        self._pt = np.zeros(64, dtype=np.int64)
        iparm = np.zeros(64, dtype=np.int32)
        iparm[0] = 1  # these settings, not the defaults
        iparm[1] = 2  # METIS nested dissection, unless given one
        self._perm = None
        if perm is not None:  # ours: P[perm][:, perm] is factorised (one ordering for every shift)
            iparm[4] = 1
            self._perm = np.ascontiguousarray(perm, dtype=np.int32)
        iparm[7] = 0  # no iterative refinement (every eigenpair is checked by its backward error)
        iparm[9] = 13 if not symmetric else 8  # pivot perturbation 1e-13 (1e-8 for symmetric indefinite)
        iparm[10] = iparm[12] = int(not symmetric and perm is None)  # scaling and matching (unsymmetric)
        iparm[17] = -1  # report the entries of the factors
        iparm[34] = 1  # zero-based indices
        self._iparm = iparm
        self._factorised = True  # from here on PARDISO holds memory for this handle (released in __del__)
        self._call(11, np.zeros((self.n, 1), self.dtype))  # ordering and symbolic factorisation
        self.nnz = int(iparm[17])
        self.peak_bytes = 1024 * int(max(iparm[14], iparm[15] + iparm[16]))  # PARDISO's own prediction
        if before_factor is not None:
            before_factor(self.peak_bytes)
        self._call(22, np.zeros((self.n, 1), self.dtype))  # numerical factorisation
        self.nnz = int(iparm[17])

    def _call(self, phase: int, b: NDArray) -> NDArray:
        x = np.zeros_like(b)
        err = ctypes.c_int32(0)
        i32 = ctypes.c_int32

        def ref(v):
            return ctypes.byref(i32(v))

        _mkl_pardiso()(self._pt.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)), ref(1), ref(1), ref(self.mtype),
                       ref(phase), ref(self.n), self._a.ctypes.data, self._ia.ctypes.data_as(ctypes.POINTER(i32)),
                       self._ja.ctypes.data_as(ctypes.POINTER(i32)),
                       None if self._perm is None else self._perm.ctypes.data_as(ctypes.POINTER(i32)), ref(b.shape[1]),
                       self._iparm.ctypes.data_as(ctypes.POINTER(i32)), ref(0), b.ctypes.data, x.ctypes.data,
                       ctypes.byref(err))
        if err.value == -4 or (phase == 22 and err.value == 0 and self._iparm[13] and self._zero_pivot()):
            raise RuntimeError(f"Factor is exactly singular (PARDISO error {err.value})")
        if err.value != 0:
            raise RuntimeError(f"PARDISO failed with error {err.value} in phase {phase}")
        return x

    def _zero_pivot(self) -> bool:
        """Whether a perturbed pivot hides an exactly singular matrix: a solve that is not finite or
        whose residual is of the size of the solution (a perturbed pivot of 1e-13 amplifies by 1e13)."""
        b = np.ones((self.n, 1), self.dtype)
        self._factorised = True
        x = self._call(33, b)
        P = sp.csr_matrix((self._a, self._ja, self._ia), shape=(self.n, self.n))
        if self.mtype in (-2, 6):
            P = P + sp.triu(P, 1).T
        r = np.linalg.norm(P @ x - b)
        return not np.all(np.isfinite(x)) or r > 1e-6 * np.linalg.norm(b)

    def _solve_block(self, B: NDArray) -> NDArray:
        return self._call(33, np.asfortranarray(B))

    def __del__(self):
        with contextlib.suppress(Exception):
            if getattr(self, "_factorised", False):
                self._call(-1, np.zeros((self.n, 1), self.dtype))  # release PARDISO's memory


def _pardiso(P, perm: NDArray[np.intp] | None = None) -> PardisoLU:
    return PardisoLU(P, perm)


#: From this many rows up the ``"auto"`` backend factorises a REAL SYMMETRIC matrix (K1 of the
#: real modes, K1 - s M) by PARDISO when it is installed. The rule, measured on the built-in
#: brake (benchmarks/bench_fe_scale.py --lu-rule; one thread, a shared 2-core machine):
#:
#: - real symmetric K1, 33 966 DOFs: PARDISO's L D L^T holds 7.6e6 entries against SuperLU's
#:   1.41e7 (half the memory), factorises in 0.7 s after a 2 s symbolic analysis against 1.4 s,
#:   and solves as fast; below about 20 000 DOFs the analysis costs more than it saves, above it
#:   the memory halved is what lets the largest models fit;
#: - complex P(s) of the band solve (unsymmetric): at 8 802 and 33 966 DOFs PARDISO factorised
#:   no faster than SuperLU in the METIS order (3.3 s against 2.9 s at 34k) and its block solves
#:   were 1-3x slower, so ``"auto"`` keeps SuperLU there (``lu="pardiso"`` forces PARDISO); the
#:   whole band solve of the 115 326-DOF brake (1-16 kHz, two walks, load average 9-11) took
#:   556 s with PARDISO against 398 s with SuperLU, the same 44 eigenvalues to 1e-13.
PARDISO_MIN_DOF = 20_000


def _auto(P, perm: NDArray[np.intp] | None = None) -> Factor:
    """PARDISO for a large real symmetric sparse ``P`` where installed (:data:`PARDISO_MIN_DOF`), else SuperLU."""
    if (sp.issparse(P) and P.shape[0] >= PARDISO_MIN_DOF and not np.iscomplexobj(P.data)
            and _available("pardiso") and _is_symmetric(P)):
        return PardisoLU(P, perm, symmetric=True)
    return _superlu(P, perm)


def _available(name: str) -> bool:
    """Whether every module the backend ``name`` requires imports (:func:`squealkit._optional.available`)."""
    return all(available(m) for m in LU_BACKENDS[name].requires)


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
    "pardiso": _Entry(_pardiso, ("pypardiso",), "pip install squealkit[fast] (pypardiso with MKL)"),
    "auto": _Entry(_auto, (), ""),
}
#: The environment variable naming the default backend of a run.
ENV_VAR = "SQUEALKIT_LU"
_DEFAULT: dict[str, str | None] = {"name": None}  # None: $SQUEALKIT_LU, else "auto"
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
        lu = lu_backend()
    if callable(lu) and not isinstance(lu, str):
        return lu
    entry = LU_BACKENDS.get(lu) if isinstance(lu, str) else None
    if entry is None:
        raise InputError(f"Unknown LU backend lu={lu!r}; known: {', '.join(LU_BACKENDS)}.")
    missing = [m for m in entry.requires if not available(m)]
    if missing:
        hint = f": {entry.install}" if entry.install else ""
        raise InputError(f"LU backend {lu!r} is not available: it needs {', '.join(missing)} (not installed, or "
                         f"it does not import){hint}.")
    return entry.backend


def lu_backend() -> str:
    """The name of the default LU backend: the one set (:func:`set_lu_backend`), else the
    environment variable ``SQUEALKIT_LU``, else ``"auto"``.

    Returns
    -------
    str
    """
    if _DEFAULT["name"] is not None:
        return _DEFAULT["name"]
    env = os.environ.get(ENV_VAR, "").strip()
    if env and env not in LU_BACKENDS:
        raise InputError(f"{ENV_VAR}={env!r} is not an LU backend; known: {', '.join(LU_BACKENDS)}.")
    return env or "auto"


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
        previous, _DEFAULT["name"] = lu_backend(), name
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
    saved = _DEFAULT["name"]  # None (the environment's) is restored as None
    set_lu_backend(name)
    try:
        yield name
    finally:
        with _LOCK:
            _DEFAULT["name"] = saved


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
