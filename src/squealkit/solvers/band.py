"""Complex eigenvalues of FE brake models: a dense full solve and a sparse band solve.

The quadratic problem ``(lambda^2 M + lambda C + K) x = 0`` of an
:class:`~squealkit.fe.model.FEModel` at disc speed ``disc_speed`` and friction ``mu`` is solved

- densely (:func:`dense_eigs`): all 2n eigenvalues, LAPACK on the 2n x 2n state matrix
  (``[[0, I], [-M^-1 K, -M^-1 C]]``; the generalised pencil where M is singular);
- in a frequency band (:func:`band_eigs`): shift-invert block Krylov-Schur
  (:class:`ShiftInvert`) on the first companion linearisation, where applying
  ``(A - s B)^-1 B`` needs only one sparse LU of ``P(s) = s^2 M + s C + K`` per shift ``s``
  (never a 2n x 2n matrix); shifts ``s = j 2 pi f`` walk along the band from both ends, each
  placed where the previous one's trusted disc ends.

Each eigenpair is checked by its backward error
``eta = ||P(lambda) x|| / ((|lambda|^2 ||M|| + |lambda| ||C|| + ||K||) ||x||)`` (Frobenius
norms; Tisseur, Linear Algebra Appl. 309, 2000), which is about machine precision for a
converged pair whatever its conditioning.
"""

from __future__ import annotations

import itertools
import math
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .._deprecation import TAN_THETA_WHY as _TAN_THETA_WHY
from .._deprecation import keyword_only, renamed_kwargs
from .._threads import honour_thread_limit, thread_limit
from .._validation import InputError, validate_finite, validate_int, validate_model, validate_positive
from ..fe.model import FEModel
from .lu import Backend, factorize, fill_reducing_order

__all__ = [
    "BAND_HZ",
    "DENSE_MAX_DOF",
    "EigenSolution",
    "ShiftInvert",
    "backward_errors",
    "band_eigs",
    "dense_eigs",
    "dense_parts",
    "pencil_backward_errors",
]

#: The squeal band [Hz] searched by default (SAE J2521 and the paper: 1-16 kHz).
BAND_HZ = (1000.0, 16000.0)
#: Backward error above which an eigenpair is not trusted.
RESIDUAL_TOL = 1e-8
#: Up to this many DOFs a dense solve of all modes is the quicker way (``method="auto"``).
DENSE_MAX_DOF = 1000



@dataclass(frozen=True)
class EigenSolution:
    """Eigenvalues of an FE model at one operating point.

    Attributes
    ----------
    eigenvalues : ndarray, shape (k,)
        ``lambda = sigma + j omega_d`` [1/s], one per mode (of a conjugate pair the one with
        ``omega_d >= 0``), by frequency, lowest first.
    vectors : ndarray, shape (n, k)
        Right eigenvectors x (unit 2-norm), column per eigenvalue; None if not asked for.
    residuals : ndarray, shape (k,)
        Backward error eta of each pair (module docstring).
    covered_growth : float
        The band is complete for modes with ``|sigma| <=`` this [1/s] (``inf`` for a full solve).
    """

    eigenvalues: NDArray[np.complex128]
    vectors: NDArray[np.complex128] | None
    residuals: NDArray[np.float64]
    covered_growth: float = math.inf

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        """Damped frequencies [Hz]."""
        return self.eigenvalues.imag / (2 * math.pi)

    @property
    def frequency(self) -> NDArray[np.float64]:
        """Deprecated name of :attr:`frequency_hz` (kept one release)."""
        import warnings

        warnings.warn("EigenSolution.frequency is deprecated; use frequency_hz (same meaning).", DeprecationWarning,
                      stacklevel=2)
        return self.frequency_hz


def validate_band(band: object) -> tuple[float, float]:
    """A frequency band ``(lo, hi)`` [Hz] with ``0 <= lo < hi``."""
    try:
        lo, hi = band  # type: ignore[misc]
    except (TypeError, ValueError):
        raise InputError(f"Parameter band={band!r} must be a pair (lo, hi) in Hz.") from None
    lo = validate_positive("band lo", lo, allow_zero=True)
    hi = validate_positive("band hi", hi)
    if not hi > lo:
        raise InputError(f"Parameter band=({lo:g}, {hi:g}) Hz: hi must exceed lo.")
    return lo, hi


@honour_thread_limit
def pencil_backward_errors(M, C, K, lam: NDArray, X: NDArray) -> NDArray[np.float64]:
    """Backward errors of the pairs ``(lam[k], X[:, k])`` of ``lambda^2 M + lambda C + K`` (module docstring).

    Parameters
    ----------
    M, C, K : sparse or dense matrices, shape (n, n)
        Real or complex.
    lam : array_like, shape (k,)
        Eigenvalues.
    X : ndarray, shape (n, k)
        Right eigenvectors, one column per eigenvalue.

    Returns
    -------
    ndarray, shape (k,)
        ``inf`` where the denominator vanishes.
    """
    nM, nC, nK = (float(spla.norm(A) if sp.issparse(A) else np.linalg.norm(A)) for A in (M, C, K))
    lam = np.asarray(lam)
    R = real_times(M, X) * lam**2 + real_times(C, X) * lam + real_times(K, X)
    a = np.abs(lam)
    den = (a**2 * nM + a * nC + nK) * np.linalg.norm(X, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.linalg.norm(R, axis=0) / den, np.inf)


@honour_thread_limit
@renamed_kwargs(omega="disc_speed")
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def backward_errors(model: FEModel, disc_speed: float, mu: float, lam: NDArray, X: NDArray, *,
                    tan_theta: float = 0.0) -> NDArray[np.float64]:
    """Backward error ``eta`` of each eigenpair ``(lam[k], X[:, k])`` of the model (module docstring).

    Parameters
    ----------
    model : FEModel
    disc_speed : float
        Disc speed [rad/s] (keyword ``omega=`` deprecated).
    mu : float
        Friction coefficient.
    lam : array_like, shape (k,)
        Eigenvalues [1/s].
    X : array_like, shape (n, k)
        Right eigenvectors, one column per eigenvalue.
    tan_theta : float, default 0.0
        Run-out slope; ``mu + tan_theta`` enters the friction matrices.

    Returns
    -------
    ndarray, shape (k,)
    """
    validate_model(model, kind="fe")
    return pencil_backward_errors(model.mass_matrix(), model.damping_matrix(disc_speed, mu, tan_theta),
                                  model.stiffness_matrix(disc_speed, mu, tan_theta), lam, X)


def _one_per_mode(lam: NDArray, n: int) -> NDArray[np.intp]:
    """Indices of one eigenvalue per mode among the 2n: of each conjugate pair the one with
    omega > 0; of the real roots (even in number) the larger half, so a growing real root is kept."""
    scale = np.max(np.abs(lam)) if lam.size else 1.0
    real = np.abs(lam.imag) <= 1e-12 * np.maximum(np.abs(lam), scale * 1e-300)
    upper = np.flatnonzero(~real & (lam.imag > 0))
    reals = np.flatnonzero(real)
    reals = reals[np.argsort(-lam.real[reals], kind="stable")][: max(0, n - upper.size)]
    keep = np.concatenate([upper, reals])
    return keep[np.lexsort((lam.real[keep], np.abs(lam.imag[keep])))]


@dataclass(frozen=True)
class DenseParts:
    """A model's matrices as dense arrays, prepared once for many dense solves.

    ``parts`` are the matrices as given; where M is positive definite (``L`` its lower
    Cholesky factor, else False) ``congruent`` holds ``L^-1 P L^-T`` of every other matrix,
    so that the state matrix ``[[0, I], [-L^-1 K L^-T, -L^-1 C L^-T]]`` of any operating
    point is a weighted sum: a similarity of the usual state matrix that keeps symmetric
    parts symmetric (more accurate than ``M^-1 K``: 1e-10 against 3e-9 relative on
    disk_brake100).
    """

    parts: dict[str, NDArray]
    L: NDArray | bool
    congruent: dict[str, NDArray]


@honour_thread_limit
def dense_parts(model: FEModel) -> DenseParts:
    """The model's matrices prepared for repeated dense solves (:class:`DenseParts`).

    Parameters
    ----------
    model : FEModel

    Returns
    -------
    DenseParts
    """
    validate_model(model, kind="fe")
    parts = {name: getattr(model, name).toarray() for name in model.present}
    try:
        L = np.linalg.cholesky(parts["M"])
    except np.linalg.LinAlgError:
        return DenseParts(parts, False, {})

    def congruent(X):
        return sla.solve_triangular(L, sla.solve_triangular(L, X, lower=True).T, lower=True).T

    return DenseParts(parts, L, {k: congruent(v) for k, v in parts.items() if k != "M"})


def _weighted(mats: dict[str, NDArray], f: dict[str, float], names: tuple[str, ...], n: int) -> NDArray:
    out = np.zeros((n, n))
    for k in names:
        if k in f and f[k] != 0.0:
            out += f[k] * mats[k]
    return out


_C_NAMES = ("D1", "DR", "DG", "D4")
_K_NAMES = ("K1", "KR", "KGeo")


@honour_thread_limit
@renamed_kwargs(omega="disc_speed")
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def dense_eigs(model: FEModel, disc_speed: float, mu: float, *, tan_theta: float = 0.0, vectors: bool = True,
               parts: DenseParts | None = None) -> EigenSolution:
    """All eigenvalues of the model at ``(disc_speed, mu)`` by LAPACK on the 2n state matrix.

    Parameters
    ----------
    model : FEModel
    disc_speed : float
        Disc speed [rad/s] (keyword ``omega=`` deprecated).
    mu : float
        Friction coefficient; ``mu + tan_theta`` enters the friction matrices.
    tan_theta : float
        Run-out slope tan(theta).
    vectors : bool
        Also return right eigenvectors (needed for mode tracking and shapes) and backward errors.
    parts : DenseParts, optional
        :func:`dense_parts` of the model, reused across points.

    Returns
    -------
    EigenSolution
        n eigenvalues, one per mode (see :func:`_one_per_mode`); residuals NaN without vectors.

    Examples
    --------
    >>> from squealkit.fe import FEModel
    >>> m = FEModel.from_matrices(M=np.eye(1), K1=[[4.0]])
    >>> dense_eigs(m, 1.0, 0.0).eigenvalues     # x'' + 4 x = 0: lambda = 2j
    array([0.+2.j])
    """
    validate_model(model, kind="fe")
    parts = dense_parts(model) if parts is None else parts
    f = model.factors(disc_speed, mu, tan_theta)
    n = model.n_dof
    if parts.L is not False:
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -_weighted(parts.congruent, f, _K_NAMES, n)
        A[n:, n:] = -_weighted(parts.congruent, f, _C_NAMES, n)
        if vectors:
            lam, Z = sla.eig(A, check_finite=False, overwrite_a=True)
        else:
            lam, Z = sla.eigvals(A, check_finite=False, overwrite_a=True), None
    else:  # singular M: the pencil (A, B); its infinite eigenvalues are dropped
        A = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-_weighted(parts.parts, f, _K_NAMES, n), -_weighted(parts.parts, f, _C_NAMES, n)]])
        B = sla.block_diag(np.eye(n), parts.parts["M"])
        if vectors:
            lam, Z = sla.eig(A, B, check_finite=False)
        else:
            lam, Z = sla.eigvals(A, B, check_finite=False), None
        fin = np.isfinite(lam)
        lam = lam[fin]
        Z = Z[:, fin] if Z is not None else None
    keep = _one_per_mode(lam, n)
    lam = lam[keep]
    if Z is None:
        return EigenSolution(lam, None, np.full(lam.size, np.nan))
    X = Z[:n, keep]
    if parts.L is not False:
        X = sla.solve_triangular(parts.L, X, lower=True, trans="T")  # x = L^-T y
    X = X / np.linalg.norm(X, axis=0)
    C = _weighted(parts.parts, f, _C_NAMES, n)
    K = _weighted(parts.parts, f, _K_NAMES, n)
    return EigenSolution(lam, X, pencil_backward_errors(parts.parts["M"], C, K, lam, X))


class ShiftInvert:
    """The eigenvalues of ``P(lambda) = lambda^2 M + lambda C + K`` nearest one shift ``s``, by
    block Krylov-Schur on the shift-inverted companion operator.

    The operator is ``(A - s B)^-1 B`` of the first companion form ``A = [[0, I], [-K, -C]]``,
    ``B = diag(I, M)``, balanced by ``D = diag(I, |s| I)`` (the state ``[x; lambda x / |s|]``,
    whose halves are of one size near the shift, so a small residual of the operator means a
    small backward error of x itself). Applying it to a block ``[V1; V2]`` needs one sparse LU of
    ``P(s)`` (:func:`~squealkit.solvers.lu.factorize`, backend ``lu``) and products with the real M and C only:
    ``W1 = -P(s)^-1 (C V1 + M (|s| V2 + s V1))``, ``W2 = (V1 + s W1) / |s|``.

    The eigenvalues ``theta`` of the operator largest in modulus are those ``lambda = s + 1/theta``
    nearest the shift. Krylov-Schur (Stewart, SIAM J. Matrix Anal. Appl. 23, 2001) in blocks of
    ``block`` vectors (Zhou & Saad, Numer. Algorithms 47, 2008): expand an orthonormal basis
    (classical Gram-Schmidt, twice) to ``m`` vectors, keep the Schur vectors of the ``p`` largest
    Ritz values and expand again, until the ``k`` largest have converged
    (``||Op z - theta z|| <= tol |theta|``). Compared with single-vector Arnoldi (ARPACK), a block
    shares each pass over the sparse LU factors and over the basis between its vectors (about
    half the time per vector on the built-in brake at 10^5 DOFs), and a block of two finds both
    members of an exact doublet from the start instead of by rounding errors. The state is kept,
    so asking for more eigenvalues at the same shift goes on from where it stopped.

    Parameters
    ----------
    M, C, K : sparse matrices, shape (n, n)
        The real mass, damping and stiffness matrices.
    s : complex
        The shift [1/s].
    perm : ndarray of int, shape (n,), optional
        Fill-reducing ordering for the LU (:func:`~squealkit.solvers.lu.fill_reducing_order`).
    block : int, default 2
        Vectors per Krylov block.
    tol : float, default 1e-12
        Convergence of a Ritz pair: ``||Op z - theta z|| <= tol |theta|``.
    max_restarts : int, default 300
        Restarts before giving up on the pairs not converged.
    lu : str or callable, optional
        LU backend of ``P(s)`` (:mod:`squealkit.solvers.lu`).
    """

    def __init__(self, M, C, K, s: complex, perm: NDArray[np.intp] | None = None, *,
                 block: int = 2, tol: float = 1e-12, max_restarts: int = 300, lu: str | Backend | None = None):
        self.s, self.n = complex(s), M.shape[0]
        self.block, self.tol, self.max_restarts = block, tol, max_restarts
        try:
            self.lu = factorize((s * s) * M + s * C + K, perm, lu=lu)
        except RuntimeError as e:  # exactly singular: an eigenvalue at the shift itself
            raise InputError(f"P(s) is singular at the shift s = {s:.6g} (an eigenvalue there): {e}") from e
        self.M, self.C = M.tocsr(), C.tocsr()
        self.scale = abs(self.s) if self.s != 0 else 1.0
        self.V: NDArray | None = None  # basis, N x (m + block), its first j columns expanded
        self.H: NDArray | None = None  # Rayleigh quotient, (m + block) x m
        self.j = 0

    @property
    def size(self) -> int:
        """Rows of the companion operator (2n)."""
        return 2 * self.n

    def apply(self, V: NDArray) -> NDArray:
        """The balanced shift-inverted operator applied to the columns of ``V`` (2n x b)."""
        n, s, a = self.n, self.s, self.scale
        V1, V2 = V[:n], V[n:]
        W1 = -self.lu.solve(real_times(self.C, V1) + real_times(self.M, a * V2 + s * V1))
        return np.concatenate([W1, (V1 + s * W1) / a])

    def nearest(self, k: int) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """The ``k`` eigenvalues nearest the shift and their right eigenvectors x (n x k, columns
        of unit norm); fewer (those converged) if ``max_restarts`` was not enough."""
        N, b = self.size, self.block
        m = min(max(3 * k, k + 8 * b, 32), N - b)
        if m < k + 2 * b:  # too small for a restarted Krylov method: all of it, densely
            theta, Z = sla.eig(self.apply(np.eye(N, dtype=np.complex128)))
            sel = np.argsort(-np.abs(theta), kind="stable")[:k]
            sel = sel[np.abs(theta[sel]) > 0]  # theta = 0: an infinite eigenvalue (singular M)
            return self._pairs(theta[sel], Z[:, sel])
        self._grow(m)
        restarts = 0
        while True:
            if self.j + b <= m:
                self._step()
                if self.j < k + 2 * b:  # too few Ritz values to judge yet
                    continue
            theta, Y, res = self._ritz()
            order = np.argsort(-np.abs(theta), kind="stable")
            want = order[:k]
            ok = res[want] <= self.tol * np.abs(theta[want])
            if ok.all():
                return self._pairs(theta[want], self.V[:, : self.j] @ Y[:, want])
            if self.j + b > m:  # the basis is full: keep the Schur vectors of the largest
                if restarts == self.max_restarts:
                    break
                self._restart(np.abs(theta[order[min(k + (m - k) // 2, m - b) - 1]]))
                restarts += 1
        # the nearest ones up to the first not converged, so that they are all there are inside
        # the farthest of them; every pair is checked by its backward error like every other
        done = want[: int(np.argmin(ok))]
        if not done.size:
            raise InputError(f"The eigenvalue solver did not converge at the shift {self.s.imag / (2 * math.pi):.6g} "
                             "Hz; use method='dense' or another band.")
        return self._pairs(theta[done], self.V[:, : self.j] @ Y[:, done])

    def _pairs(self, theta, Z):
        X = Z[: self.n]
        return self.s + 1.0 / theta, X / np.linalg.norm(X, axis=0)

    def _grow(self, m: int) -> None:
        """Room for a basis of m + block vectors; a new basis starts from a fixed random block."""
        N, b = self.size, self.block
        if self.V is None:
            self.V = np.zeros((N, m + b), np.complex128, order="F")
            self.H = np.zeros((m + b, m), np.complex128)
            start = np.random.default_rng(0).standard_normal((N, b)).astype(np.complex128)  # reproducible
            self.V[:, :b] = np.linalg.qr(start)[0]
        elif self.V.shape[1] < m + b:
            V = np.zeros((N, m + b), np.complex128, order="F")
            V[:, : self.V.shape[1]] = self.V
            H = np.zeros((m + b, m), np.complex128)
            H[: self.H.shape[0], : self.H.shape[1]] = self.H
            self.V, self.H = V, H

    def _step(self) -> None:
        """One block Arnoldi step: the operator on the last block, orthogonalised against the basis."""
        V, H, b, j = self.V, self.H, self.block, self.j
        W = self.apply(V[:, j : j + b])
        Vj = V[:, : j + b]
        for _ in range(2):  # classical Gram-Schmidt twice ("twice is enough")
            h = (Vj.T @ W.conj()).conj()
            W -= Vj @ h
            H[: j + b, j : j + b] += h
        Q, R = np.linalg.qr(W)
        lost = np.abs(np.diag(R)) <= 1e-13 * max(np.abs(R).max(), 1e-300)
        if lost.any():  # an invariant subspace: carry on with new directions, no coupling
            R[lost] = 0.0
            fresh = np.random.default_rng(j).standard_normal((W.shape[0], int(lost.sum()))) + 0j
            basis = np.concatenate([Vj, Q[:, ~lost]], axis=1)
            for _ in range(2):
                fresh -= basis @ (basis.T @ fresh.conj()).conj()
            Q[:, lost] = np.linalg.qr(fresh)[0]
        V[:, j + b : j + 2 * b] = Q
        H[j + b : j + 2 * b, j : j + b] = R
        self.j = j + b

    def _ritz(self):
        """Ritz values of the basis, their vectors in basis coordinates and residual norms."""
        j, b = self.j, self.block
        theta, Y = sla.eig(self.H[:j, :j])
        Y = Y / np.linalg.norm(Y, axis=0)
        return theta, Y, np.linalg.norm(self.H[j : j + b, :j] @ Y, axis=0)

    def _restart(self, keep_above: float) -> None:
        """Keep the Schur vectors of the Ritz values of modulus >= ``keep_above``."""
        j, b = self.j, self.block
        T, Z, p = sla.schur(self.H[:j, :j], output="complex",
                            sort=lambda x: abs(x) >= keep_above * (1 - 1e-12))
        p = min(p, j - b)
        coupling = self.H[j : j + b, :j] @ Z[:, :p]
        residual = self.V[:, j : j + b].copy()
        self.V[:, :p] = self.V[:, :j] @ Z[:, :p]
        self.V[:, p : p + b] = residual
        self.H[:] = 0.0
        self.H[:p, :p] = np.triu(T[:p, :p])
        self.H[p : p + b, :p] = coupling
        self.j = p


def real_times(A, X: NDArray) -> NDArray[np.complex128]:
    """``A @ X`` for a real (sparse or dense) A and a complex X (vector or block), as one real
    product on X's interleaved real and imaginary parts (no complex copy of A, a quarter of
    the work of a complex product).

    Parameters
    ----------
    A : sparse or dense matrix, shape (m, n)
    X : ndarray, shape (n,) or (n, k)

    Returns
    -------
    ndarray of complex128, shape (m,) or (m, k)
    """
    X = np.ascontiguousarray(X, dtype=np.complex128)
    if np.iscomplexobj(A.data if sp.issparse(A) else A):
        return A @ X
    shape = X.shape
    Y = A @ X.reshape(shape[0], -1).view(np.float64)
    return np.ascontiguousarray(Y).view(np.complex128).reshape((A.shape[0], *shape[1:]))


@honour_thread_limit
@renamed_kwargs(omega="disc_speed")
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def band_eigs(model: FEModel, disc_speed: float, mu: float, *, tan_theta: float = 0.0,
              band: tuple[float, float] = BAND_HZ, k: int | None = None, sigma_reach: float = 0.0,
              max_shifts: int = 400, workers: int | None = None, tol: float = 1e-12,
              lu: str | Backend | None = None) -> EigenSolution:
    """Eigenvalues with frequency in ``band`` [Hz], by shift-invert with one sparse LU per shift.

    Shifts ``s = j 2 pi f`` walk along the band from an end. At each, block Krylov-Schur
    (:class:`ShiftInvert`) finds the ``k`` eigenvalues nearest ``s``: every eigenvalue closer
    than the k-th is among them, so the disc of that radius r is complete. The next shift is
    placed ``r`` further on (half that where less than a disc is left); each shift keeps
    the eigenvalues of its own slice of the band (between the midpoints to its neighbours), so
    none is counted twice, and doublets (equal or nearly equal pairs) are kept whole. Where
    a disc would not reach its slice's far edge, or not ``sigma_reach`` off the axis over its
    slice, ``k`` is doubled and the shift solved again. The band is complete for modes with
    ``|sigma|`` below ``covered_growth`` (the least half-chord of a disc over its slice,
    at least ``sigma_reach``).

    With two workers, one walk starts at each end of the band and they stop where they meet,
    so no shift is solved twice; a walk also stops where the other one's shift in progress is
    nearer than half the larger of the two walks' last discs (that shift, or the other walk
    after it, covers the rest). More workers split the band into that many halves of
    sub-bands, each walked from both ends.

    Parameters
    ----------
    model : FEModel
    disc_speed, mu, tan_theta : float
        Disc speed [rad/s] (keyword ``omega=`` deprecated), friction and run-out slope, as for
        :func:`dense_eigs`.
    band : (float, float)
        Frequency band [Hz] (default 1-16 kHz).
    k : int, optional
        Eigenvalues per shift to start with. Default: 24 for one walk, 32 with two or more (fewer,
        larger discs; measured on the built-in brake at 600 rpm, mu 0.45, 1-16 kHz: one walk at
        33 966 DOFs 27.1 s with 24 against 35.4 s with 32, both 3 shifts; two walks 23.8 s and 5
        shifts against 19.9 s and 4; at 115 326 DOFs 121.7 s and 5 shifts against 100.7 s and 4).
    sigma_reach : float
        Find every mode in the band with ``|sigma| <= sigma_reach`` [1/s] at least (heavily
        damped models need it; unstable modes near the axis are found whatever its value).
    max_shifts : int
        Give up (InputError) past this many shifts in one walk.
    workers : int, optional
        Walks solved at once, each in its own thread with its own sparse LU (SuperLU
        releases the GIL); peak memory grows with it. Default: the thread limit of
        :mod:`squealkit._threads`.
    tol : float
        Convergence of a Ritz pair at a shift: ``||Op z - theta z|| <= tol |theta|`` for the
        shift-inverted operator (:class:`ShiftInvert`). The default gives eigenvalues to about
        machine precision; a reduction basis needs far less (:func:`~squealkit.solvers.reduction.pod_basis`
        uses 1e-9: 12 % less time). Every pair's backward error is reported whatever it is.
    lu : str or callable, optional
        The sparse LU of each shift (:mod:`squealkit.solvers.lu`): a backend name (``"superlu"``,
        ``"dense"``, or one registered) or a backend callable; default :func:`~squealkit.solvers.lu.lu_backend`.

    Returns
    -------
    EigenSolution
        The eigenvalues in the band (omega_d >= 0), lowest frequency first, with right
        eigenvectors and backward errors.
    """
    validate_model(model, kind="fe")
    lo, hi = validate_band(band)
    disc_speed = validate_finite("disc_speed", disc_speed)
    if not (0 < tol < 1):
        raise InputError(f"Parameter tol={tol!r} must be in (0, 1).")
    workers = thread_limit() if workers is None else max(1, int(workers))
    n = model.n_dof
    if k is not None:
        k = validate_int("k", k, 1)
    if k is None:
        k = max(1, min(24 if workers == 1 else 32, 2 * n - 4))
    if 2 * n <= k + 3:
        raise InputError(f"The model has {n} DOFs: too few for a band solve; use method='dense'.")
    M = model.mass_matrix().tocsr()
    C = model.damping_matrix(disc_speed, mu, tan_theta)
    K = model.stiffness_matrix(disc_speed, mu, tan_theta)
    workers = _walks_that_fit(n, max(A.nnz if sp.issparse(A) else n * n for A in (M, C, K)), k, workers, lu)
    perm = fill_reducing_order(M, C, K)
    edges = 2 * math.pi * np.linspace(lo, hi, (workers + 1) // 2 + 1)
    claims = [_Claims(a, b, top_closed=b == edges[-1]) for a, b in itertools.pairwise(edges)]
    walks = [(c, +1) for c in claims] + [(c, -1) for c in claims][: workers // 2]

    def walk(i):
        return _band_walk(M, C, K, n, *walks[i], k, sigma_reach, max_shifts, perm, tol, lu)

    # one BLAS thread per walk: the walks already use the cores
    with threadpool_limits(1, user_api="blas"):
        if len(walks) == 1:
            parts = [walk(0)]
        else:
            with ThreadPoolExecutor(max_workers=len(walks)) as pool:
                parts = list(pool.map(walk, range(len(walks))))
    lam = np.concatenate([p[0] for p in parts])
    X = np.concatenate([p[1] for p in parts], axis=1)
    order = np.lexsort((lam.real, lam.imag))
    lam, X = lam[order], X[:, order]
    X = X / np.linalg.norm(X, axis=0) if X.shape[1] else X
    res = pencil_backward_errors(M, C, K, lam, X)
    return EigenSolution(lam, X, res, covered_growth=min(p[2] for p in parts))


def _walks_that_fit(n: int, nnz: int, k: int, workers: int, lu) -> int:
    """The most walks up to ``workers`` whose estimated memory fits (:mod:`squealkit.solvers.memory`);
    an InputError when even one walk does not."""
    from . import lu as _lu
    from .memory import band_memory, check_fits, memory_limit

    name = lu if isinstance(lu, str) else (_lu.lu_backend() if lu is None else "superlu")
    limit = memory_limit()
    while workers > 1 and band_memory(n, nnz, k=k, workers=workers, backend=name) > limit:
        workers -= 1  # fewer walks at once: each holds its own factor
    check_fits(band_memory(n, nnz, k=k, workers=workers, backend=name), f"A band solve of {n} DOFs",
               "Use the subspace projection (method='subspace') or set a larger SQUEALKIT_MEMORY.")
    return workers


#: A shift claims the band up to this fraction of its disc's radius r ahead of it, and the next
#: shift goes as far again: the half-chord there, r sqrt(1 - _REACH^2), is the growth rate covered.
_REACH = 0.5


class _Claims:
    """What the walks over one sub-band ``[w_lo, w_hi]`` [rad/s] have covered: ``[w_lo, up)``
    from below and ``[down, w_hi)`` from above (``w_hi`` itself too when ``top_closed``)."""

    def __init__(self, w_lo: float, w_hi: float, *, top_closed: bool):
        self.w_lo, self.w_hi, self.top_closed = w_lo, w_hi, top_closed
        self.up, self.down = w_lo, w_hi
        self.pending = {+1: None, -1: None}  # centre of the shift each walk is solving
        self.reach = {+1: 0.0, -1: 0.0}  # each walk's last disc radius
        self.lock = threading.Lock()

    def frontier(self, d: int) -> float:
        """Where the other walk's claim starts, for the walk in direction ``d``."""
        return self.down if d > 0 else self.up

    def claim(self, d: int, to: float) -> None:
        if d > 0:
            self.up = to
        else:
            self.down = to

    def select(self, f: NDArray, a: float, b: float) -> NDArray[np.bool_]:
        """``a <= f < b``, and ``f == w_hi`` when b is the closed top of the band."""
        return (f >= a) & ((f < b) | ((f == b) & (b == self.w_hi) & self.top_closed))


def _band_walk(M, C, K, n, claims: _Claims, d: int, k, sigma_reach, max_shifts, perm, tol, lu):
    """The shift walk of :func:`band_eigs` from one end of ``claims``' sub-band (up from its
    bottom when ``d = +1``, down from its top when ``d = -1``) until it meets the other
    walk's claim: eigenvalues, right eigenvectors and the least covered growth rate."""
    lams, xs, chords = [], [], []
    edge = claims.w_lo if d > 0 else claims.w_hi  # where the current shift's slice starts
    center = edge
    kk = k
    op, op_center = None, None
    for _ in range(max_shifts):
        with claims.lock:
            far = claims.frontier(d)
            other = claims.pending[-d]
            if d * (far - edge) <= 0:  # the other walk has been here
                break
            if other is not None and abs(other - edge) <= _REACH * max(claims.reach.values()):
                break  # the other walk's shift in progress is nearer than ours would be: it finishes
            if d * (center - far) > 0:  # the other walk came nearer since this shift was placed
                center = 0.5 * (edge + far)
            claims.pending[d] = center
        kk = min(kk, 2 * n - 3)
        if op_center != center:  # one LU per shift, its Krylov basis kept when k grows
            op, op_center = ShiftInvert(M, C, K, 1j * center, perm, tol=tol, lu=lu), center
        lam, X = op.nearest(kk)
        dist = np.abs(lam - 1j * center)
        r = float(np.max(dist)) * (1.0 - 1e-6)
        behind = abs(center - edge)
        step = max(_REACH * r, 1e-9 * claims.w_hi)
        if r > sigma_reach:  # the slice where the disc reaches sigma_reach off the axis
            step = min(step, math.sqrt(r * r - sigma_reach * sigma_reach) / 1.05)
        with claims.lock:
            far = claims.frontier(d)
            if d * (far - edge) <= 0:  # the other walk covered this slice meanwhile
                claims.pending[d] = None
                break
            last = d * (center + d * step - far) >= 0
            top = far if last else center + d * step
            ahead = max(d * (top - center), 0.0)
            short = r <= 1.05 * math.hypot(behind, sigma_reach) or (last and r <= math.hypot(ahead, sigma_reach))
            grow = short and kk < 2 * n - 3
            if not grow:
                claims.claim(d, top)
                claims.pending[d] = None
                claims.reach[d] = r
        if grow:  # the disc misses part of its slice: more eigenvalues
            kk *= 2
            continue
        sel = (dist < r) & claims.select(lam.imag, *sorted((edge, top)))
        lams.append(lam[sel])
        xs.append(X[:, sel])
        chords.append(math.sqrt(max(r * r - max(behind, ahead) ** 2, 0.0)))
        if last:
            break
        # the next disc reaches back over this one's slice if it is at least half as large; where
        # less than a disc is left before the other walk, the middle of what is left
        edge, center, kk = top, top + d * min(_REACH * r, 0.5 * abs(far - top)), k
    else:
        raise InputError(f"The band {claims.w_lo / (2 * math.pi):g}-{claims.w_hi / (2 * math.pi):g} Hz "
                         f"needs more than {max_shifts} shifts; narrow it.")
    lam = np.concatenate(lams) if lams else np.zeros(0, complex)
    X = np.concatenate(xs, axis=1) if xs else np.zeros((n, 0), complex)
    return lam, X, min(chords) if chords else math.inf
