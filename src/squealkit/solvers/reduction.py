"""Reduced complex eigenvalue analysis of large FE brake models, with full-model residuals.

An FE brake model is given in the exported matrix form (Abaqus/ANSYS/Nastran names)::

    (lambda^2 M + lambda C(v, mu) + K(v, mu)) x = 0
    C(v, mu) = D1 + (mu/mu_ref) DR (v_ref/v) + (v/v_ref) DG + D4/f_ref
    K(v, mu) = K1 + (mu/mu_ref) KR + (v/v_ref)**2 KGeo

with ``v`` the disc speed [rad/s] (the arguments ``disc_speed``, ``disc_speeds``) and
``lambda = sigma + i 2 pi f`` (``sigma`` the growth rate [1/s], ``f`` the frequency [Hz]).
The functions here take the matrices as a mapping (or any object with those attributes, e.g. an
``FEModel``): ``M`` and ``K1`` required, the others optional (``None``), plus ``disc_speed_ref``
(``v_ref``; formerly ``omega_ref``), ``mu_ref``, ``f_ref`` (default 1). ``omega`` is never the disc
speed here (an eigenfrequency elsewhere); the former keywords ``omega=``/``omegas=`` still work for
one release, with a DeprecationWarning.

Three steps, as industry does it (Graebner, Tiedemann, Schroeder & Mehrmann, ZAMM 96 (2016)):

1. :func:`modal_basis`: the real modes of ``(M, K1)`` up to a cut-off frequency (subspace
   projection; shift-invert Lanczos around 0).
2. :func:`pod_basis`: a parametric basis for sweeps: complex eigenvectors of the full
   quadratic problem at sampled ``(disc_speed, mu)``, real and imaginary parts, optionally with
   the modal basis, compressed by a proper orthogonal decomposition (SVD, relative tolerance).
3. :func:`reduce` then :func:`reduced_eigs` / :func:`reduced_sweep`: ``V^T A V`` for every
   matrix, a dense state-space eigen solve of the small problem, and for EACH eigenvalue its
   backward error in the FULL model (Tisseur, Linear Algebra Appl. 309 (2000))::

       eta = ||(l^2 M + l C + K) V y|| / ((|l|^2 ||M|| + |l| ||C|| + ||K||) ||V y||)

   computed without the full matrices at each point (an R factor of ``[A_i V]`` is kept),
   so a reduced answer that cannot be trusted says so (``trusted = eta <= eta_max``).
   Norms are Frobenius norms of the assembled ``C(v, mu)`` and ``K(v, mu)``, as in the
   sparse and dense solvers (from a table of the matrices' Frobenius inner products).
"""

from __future__ import annotations

import contextlib
import functools
import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._deprecation import renamed_kwargs
from .._threads import honour_thread_limit, thread_limit
from .._validation import InputError
from ..fe.model import FEModel
from .band import DENSE_MAX_DOF, DenseParts, band_eigs, dense_eigs, dense_parts, real_times
from .lu import Backend, PermutedLU, factorize, fill_reducing_order
from .mac import MacTracker

__all__ = [
    "SNAPSHOT_TOL",
    "ReducedModel",
    "as_fe_model",
    "modal_basis",
    "pod_basis",
    "reduce",
    "reduced_eigs",
    "reduced_solve",
    "reduced_sweep",
]

MATRIX_NAMES = ("M", "D1", "DG", "DR", "D4", "K1", "KR", "KGeo")
_DAMPING = ("D1", "DG", "DR", "D4")
_STIFFNESS = ("K1", "KR", "KGeo")


# ----------------------------------------------------------------------------- model adapter


def as_fe_model(matrices: Any, disc_speed_ref: float | None = None, mu_ref: float | None = None,
                f_ref: float | None = None) -> FEModel:
    """An :class:`~squealkit.fe.model.FEModel` from one, or from a mapping of matrices (+ reference
    scalars) or an object with those attributes (validated as every FE model is).

    Parameters
    ----------
    matrices : FEModel, mapping or object
        ``M``, ``K1`` and any of the other FE matrices by name, with ``disc_speed_ref`` (or the
        older ``omega_ref``), ``mu_ref``, ``f_ref`` where given (default 1).
    disc_speed_ref, mu_ref, f_ref : float, optional
        Reference values overriding those of ``matrices``.

    Returns
    -------
    FEModel
    """
    if isinstance(matrices, FEModel) and disc_speed_ref is None and mu_ref is None and f_ref is None:
        return matrices

    def get(name: str, default: Any = None) -> Any:
        if isinstance(matrices, Mapping):
            return matrices.get(name, default)
        return getattr(matrices, name, default)

    mats = {name: get(name) for name in MATRIX_NAMES if get(name) is not None}
    if "M" not in mats or "K1" not in mats:
        raise InputError("FE matrices: M and K1 are required.")
    if disc_speed_ref is None and get("disc_speed_ref") is None:
        disc_speed_ref = get("omega_ref")  # matrices exported before the rename
    refs = {key: float(given if given is not None else get(key, 1.0))
            for key, given in (("disc_speed_ref", disc_speed_ref), ("mu_ref", mu_ref), ("f_ref", f_ref))}
    return FEModel.from_matrices(**mats, **refs)


def _coefficients(model: FEModel, disc_speed: float, mu: float) -> dict[str, tuple[int, float]]:
    """name -> (power of lambda, scalar factor) of each present matrix at (disc_speed, mu)
    (:meth:`~squealkit.fe.model.FEModel.factors`, with M's power 2)."""
    f = model.factors(disc_speed, mu)
    return {name: (2, 1.0) if name == "M" else (1 if name in _DAMPING else 0, f[name]) for name in model.present}


def _one_blas_thread():
    """Serial BLAS for loops of small dense steps (ARPACK): threads there only wait on each other."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - optional
        return contextlib.nullcontext()
    return threadpool_limits(1, user_api="blas")


# ----------------------------------------------------------------------------- modal basis


@honour_thread_limit
def modal_basis(
    matrices: Any,
    *,
    freq_max: float | None = None,
    n_modes: int | None = None,
    return_freq: bool = False,
    lu: str | Backend | None = None,
):
    """Real modes of ``(M, K1)``: the subspace projection basis.

    Parameters
    ----------
    matrices : mapping or FEModel
        ``M`` and ``K1`` (symmetric, ``K1`` positive definite: a restrained model).
    freq_max : float, optional
        Cut-off frequency [Hz]: every mode up to it (Abaqus practice: 1.5-2x the top of the
        band of interest).
    n_modes : int, optional
        Number of modes (the lowest); with ``freq_max`` an upper limit.
    return_freq : bool
        Also return the natural frequencies [Hz].
    lu : str or callable, optional
        LU backend of ``K1`` for the shift-invert Lanczos (:mod:`squealkit.solvers.lu`).

    Returns
    -------
    V : ndarray, shape (n, r)
        Mass-normalised modes (``V.T M V = I``), by increasing frequency.
    freq : ndarray, shape (r,)
        Only with ``return_freq``.
    """
    model = as_fe_model(matrices)
    if freq_max is None and n_modes is None:
        raise InputError("modal_basis: give freq_max (Hz) or n_modes.")
    if freq_max is not None and not (math.isfinite(freq_max) and freq_max > 0):
        raise InputError(f"modal_basis: freq_max={freq_max!r} must be a positive frequency in Hz.")
    n = model.n_dof
    if n_modes is not None and not (1 <= n_modes < n - 1):
        raise InputError(f"modal_basis: n_modes={n_modes!r} must be between 1 and {n - 2}.")
    M, K1 = model.M, model.K1
    if not sp.issparse(K1) or n < 400:
        w, V = sla.eigh(_dense(K1), _dense(M))
        freq = np.sqrt(np.maximum(w, 0.0)) / (2 * math.pi)
    else:
        perm = fill_reducing_order(K1, M)
        factor = factorize(K1, perm, lu=lu)  # nested dissection, diagonal pivots: SuperLU's default fills 4x more
        op = spla.LinearOperator((n, n), matvec=factor.solve, dtype=float)
        k = n_modes if n_modes is not None else 40
        if freq_max is not None:  # as many modes as there are below the cut-off (+2: a doublet on it)
            below = count_below(K1, M, (2 * math.pi * freq_max) ** 2, perm)
            k = min(k, below + 2) if n_modes is not None else below + 2
        while True:
            k = min(k, n - 2)
            w, V = spla.eigsh(K1, k=k, M=M, sigma=0.0, which="LM", OPinv=op)
            order = np.argsort(w)
            w, V = w[order], V[:, order]
            freq = np.sqrt(np.maximum(w, 0.0)) / (2 * math.pi)
            if freq_max is None or freq[-1] > freq_max or k >= n - 2:
                break
            if n_modes is not None and k >= n_modes:
                break
            k = int(k * 1.6 * (freq_max / max(freq[-1], 1e-30)) ** 2) + 10  # modal density ~ f^2 (plates: ~f)
    keep = np.ones(len(freq), dtype=bool)
    if freq_max is not None:
        keep &= freq <= freq_max
    if n_modes is not None:
        keep &= np.arange(len(freq)) < n_modes
    V, freq = V[:, keep], freq[keep]
    # mass-normalise (eigsh/eigh already do, up to rounding)
    V = V / np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    return (V, freq) if return_freq else V


@honour_thread_limit
def count_below(K: Any, M: Any, w2: float, perm: np.ndarray) -> int:
    """Eigenvalues of ``(K, M)`` below ``w2`` (both symmetric, M positive definite), by
    Sylvester's law of inertia: the negative pivots of ``K - w2 M = L D L^T`` (a Sturm count, as
    FE eigensolvers check their modes with).

    SuperLU in the fill-reducing order ``perm`` with every pivot kept on the diagonal (then
    ``U = D L^T``). Without pivoting a tiny pivot can miscount, so the count is only used to size
    the solve; the modes found are checked against the cut-off. The inertia needs the pivots
    themselves, so this is SuperLU whatever the LU backend (:mod:`squealkit.solvers.lu`).

    Parameters
    ----------
    K, M : sparse matrices, shape (n, n)
        Symmetric; M positive definite.
    w2 : float
        The bound [rad^2/s^2] (a circular frequency squared).
    perm : ndarray of int, shape (n,)
        Fill-reducing ordering (:func:`~squealkit.solvers.lu.fill_reducing_order`).

    Returns
    -------
    int
    """
    lu = PermutedLU(K - w2 * M, perm, diag_pivot_thresh=0.0).lu
    return int(np.count_nonzero(lu.U.diagonal() < 0))


def _dense(A: Any) -> np.ndarray:
    return A.toarray() if sp.issparse(A) else np.asarray(A)


# ----------------------------------------------------------------------------- full band solve


# ----------------------------------------------------------------------------- POD basis


#: Convergence tolerance of the snapshot band solves: a POD basis needs eigenvectors far less
#: accurate than machine precision (built-in brake, 33 966 DOFs: 12 % less time than 1e-12,
#: reduced eigenvalues as accurate, 7.9e-8 against 6.5e-8 relative).
SNAPSHOT_TOL = 1e-9


def _snapshot(fe, disc_speed: float, mu: float, band: tuple[float, float], parts: DenseParts | None,
              workers: int | None = None) -> np.ndarray:
    """Right eigenvectors with frequency in ``band`` [Hz]: all modes by LAPACK with the model's
    prepared dense ``parts`` (up to :data:`~squealkit.solvers.band.DENSE_MAX_DOF` DOFs),
    else the sparse band solve (``workers`` walks)."""
    if parts is None:
        return band_eigs(fe, disc_speed, mu, band=band, workers=workers, tol=SNAPSHOT_TOL).vectors
    sol = dense_eigs(fe, disc_speed, mu, parts=parts)
    f = sol.frequency_hz
    return sol.vectors[:, (f >= band[0]) & (f <= band[1])]


@honour_thread_limit
@renamed_kwargs(omegas="disc_speeds")
def pod_basis(
    matrices: Any,
    disc_speeds: Sequence[float],
    mus: Sequence[float],
    *,
    band: tuple[float, float] = (1e3, 16e3),
    tol: float = 1e-7,
    extra: np.ndarray | None = None,
    left: bool = True,
    band_margin: float = 0.15,
    eig_solver: Callable[..., tuple[np.ndarray, np.ndarray]] | None = None,
    return_singular_values: bool = False,
):
    """Parametric reduction basis from eigenvectors at sampled speeds and friction (POD).

    At every sample ``(disc_speed, mu)`` (the grid ``disc_speeds x mus``) the full model's
    eigenvectors with frequency in ``band`` widened by ``band_margin`` are computed; their
    real and imaginary parts (each scaled to unit norm), together with ``extra`` (e.g.
    :func:`modal_basis`) and the left corrections, are compressed by an SVD keeping the
    singular values above ``tol * s_max`` (Graebner et al. 2016, §4).

    Left corrections: friction makes the problem non-symmetric, so its left eigenvectors
    differ from the right ones the snapshots hold, and a Galerkin projection's eigenvalue
    error is the product of how badly the basis holds each (Stewart & Sun, Matrix
    Perturbation Theory, V.2). The static corrections ``K1^-1 A^T E`` of ``extra`` (else of
    the snapshots) for each non-symmetric matrix ``A`` (``KR``, ``DR``) are the first-order
    change of the left eigenvectors under friction; with them the built-in brake at 33 966 DOFs
    has reduced eigenvalues 9x more accurate (1.2e-7 against 1.1e-6 relative) from a basis of
    about the same size (318 against 310 vectors). One sparse LU of ``K1`` (restrained model)
    and a block solve.

    Parameters
    ----------
    matrices : mapping or FEModel
    disc_speeds, mus : sequences of float
        Sample disc speeds [rad/s] and friction coefficients (``omegas=`` is the deprecated
        keyword of ``disc_speeds``).
    band : (float, float)
        Frequency band [Hz] of interest.
    tol : float
        Relative singular value cut-off of the POD.
    extra : ndarray (n, q), optional
        Vectors always included before compression (e.g. a modal basis).
    left : bool
        Add the left corrections (above).
    band_margin : float
        Relative widening of the band for the snapshots (modes just outside the band couple
        into it).
    eig_solver : callable, optional
        ``eig_solver(matrices, disc_speed, mu, band) -> (lam, X)``; default LAPACK (all modes) up to
        :data:`~squealkit.solvers.band.DENSE_MAX_DOF` DOFs, the sparse shift-invert band
        solve :func:`~squealkit.solvers.band.band_eigs` above (to :data:`SNAPSHOT_TOL`;
        samples solved at once, one walk each, up to the thread limit of
        :mod:`squealkit._threads`).
    return_singular_values : bool
        Also return the singular values (all of them, for choosing ``tol``).

    Returns
    -------
    V : ndarray (n, r)
        Orthonormal basis (``V.T V = I``).
    s : ndarray
        Only with ``return_singular_values``.
    """
    model = as_fe_model(matrices)
    speeds, mus = np.atleast_1d(np.asarray(disc_speeds, dtype=float)), np.atleast_1d(np.asarray(mus, dtype=float))
    if speeds.size == 0 or mus.size == 0:
        raise InputError("pod_basis: give at least one sample speed and friction.")
    if not (0 < tol < 1):
        raise InputError(f"pod_basis: tol={tol!r} must be in (0, 1).")
    lo, hi = _validate_band(band)
    wide = (max(lo * (1 - band_margin), 1.0), hi * (1 + band_margin))
    cols = [] if extra is None else [np.asarray(extra, dtype=float)]
    samples = [(float(speed), float(mu)) for speed in speeds for mu in mus]
    if eig_solver is not None:
        snaps = [eig_solver(matrices, speed, mu, wide)[1] for speed, mu in samples]
    else:
        # the dense matrices (and M's Cholesky factor) once for every sample
        parts = dense_parts(model) if model.n_dof <= DENSE_MAX_DOF else None
        workers = min(thread_limit(), len(samples)) if parts is None else 1
        if workers > 1:  # samples side by side, one walk each: no walk waits on the other
            with _one_blas_thread(), ThreadPoolExecutor(max_workers=workers) as pool:
                snaps = list(pool.map(lambda p: _snapshot(model, *p, wide, None, workers=1), samples))
        else:
            snaps = [_snapshot(model, speed, mu, wide, parts) for speed, mu in samples]
    for X in snaps:
        cols += [X.real, X.imag]
    if left:
        cols += _left_corrections(model, cols[0] if extra is not None else np.hstack(cols))
    S = np.hstack(cols)
    S = S / np.maximum(np.linalg.norm(S, axis=0), 1e-300)
    U, s, _ = sla.svd(S, full_matrices=False, lapack_driver="gesvd")
    r = int(np.sum(s > tol * s[0]))
    V = U[:, :r]
    return (V, s) if return_singular_values else V


def _left_corrections(model: FEModel, E: np.ndarray) -> list[np.ndarray]:
    """``K1^-1 A^T E`` for each non-symmetric matrix ``A`` of the model (:func:`pod_basis`)."""
    mats = [sp.csr_matrix(getattr(model, name)) for name in ("KR", "DR") if name in model.present]
    mats = [A for A in mats if spla.norm(A - A.T) > 1e-12 * spla.norm(A)]
    if not mats or E.shape[1] == 0:
        return []
    K1 = sp.csc_matrix(model.K1)
    try:
        lu = factorize(K1)
    except RuntimeError as e:  # SuperLU: exactly singular
        raise InputError(f"pod_basis: K1 is singular ({e}); a free model has no static corrections: "
                         "pass left=False.") from e
    return [lu.solve(np.asarray(A.T @ E)) for A in mats]


def _validate_band(band: tuple[float, float]) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in band)
    except (TypeError, ValueError) as e:
        raise InputError(f"band={band!r} must be two frequencies in Hz (lo, hi).") from e
    if not (0 <= lo < hi and math.isfinite(hi)):
        raise InputError(f"band={band!r} must satisfy 0 <= lo < hi (Hz).")
    return lo, hi


# ----------------------------------------------------------------------------- reduced model


@dataclass(frozen=True)
class ReducedModel:
    """A projected model ``V^T A V`` with what is needed for full-model residuals.

    Attributes
    ----------
    V : ndarray (n, r)
        The basis.
    mats : dict
        Reduced dense matrices (r, r) by name (absent ones omitted).
    disc_speed_ref, mu_ref, f_ref : float
        Reference values of the full model (disc speed [rad/s], friction, ``Fref``).
    gram : ndarray (q, q)
        Frobenius inner products ``<A_i, A_j>`` of the full matrices (names in ``order``):
        ``||sum_i c_i A_i||_F^2 = c^T gram c``.
    R : ndarray (q r, q r)
        Triangular factor of ``[A_1 V, ..., A_q V]`` (names in ``order``):
        ``||sum_i c_i A_i V y|| = ||R (c kron y)||`` exactly, without the full matrices.
    order : tuple of str
    v_orthonormal : bool
    """

    V: np.ndarray
    mats: dict[str, np.ndarray]
    disc_speed_ref: float
    mu_ref: float
    f_ref: float
    gram: np.ndarray
    R: np.ndarray
    order: tuple[str, ...]

    @functools.cached_property
    def projected(self) -> FEModel:
        """The reduced matrices as an FE model of ``n_reduced`` DOFs (same reference values)."""
        return FEModel.from_matrices(**self.mats, disc_speed_ref=self.disc_speed_ref, mu_ref=self.mu_ref,
                                     f_ref=self.f_ref)

    @property
    def omega_ref(self) -> float:
        """Deprecated name of :attr:`disc_speed_ref`."""
        warnings.warn("ReducedModel.omega_ref is deprecated; use disc_speed_ref (same meaning).",
                      DeprecationWarning, stacklevel=2)
        return self.disc_speed_ref

    @property
    def n_reduced(self) -> int:
        return self.V.shape[1]


@honour_thread_limit
def reduce(matrices: Any, V: np.ndarray) -> ReducedModel:
    """Project every matrix on the basis ``V`` (orthonormalised first) and keep residual data.

    Cost: one sparse product per matrix and a QR of an ``n x (q r)`` matrix (q present
    matrices, r basis vectors), done once for a whole sweep.

    Parameters
    ----------
    matrices : FEModel, mapping or object
        The full model (see :func:`as_fe_model`).
    V : ndarray, shape (n, r)
        The basis.

    Returns
    -------
    ReducedModel
    """
    model = as_fe_model(matrices)
    V = np.asarray(V, dtype=float)
    if V.ndim != 2 or V.shape[0] != model.n_dof:
        raise InputError(f"reduce: V has shape {V.shape}, expected ({model.n_dof}, r).")
    # pod_basis' bases are orthonormal already (a QR of 34k x 300 costs 2.7 s)
    Q = V if np.allclose(V.T @ V, np.eye(V.shape[1]), rtol=0, atol=1e-12) else np.linalg.qr(V)[0]
    order = tuple(model.present)
    r = Q.shape[1]
    # [A_1 Q, ..., A_q Q] written once, in the column order LAPACK factorises in place
    # (np.hstack and numpy's qr each copied its 0.5 GB at 34k DOFs: 4 s and more)
    AV = np.empty((Q.shape[0], len(order) * r), order="F")
    red = {}
    for i, name in enumerate(order):
        block = AV[:, i * r:(i + 1) * r]
        block[...] = getattr(model, name) @ Q
        red[name] = Q.T @ block
    (raw, _), _ = sla.qr(AV, mode="raw", overwrite_a=True, check_finite=False)
    R = np.triu(raw[: raw.shape[1]])
    return ReducedModel(Q, red, model.disc_speed_ref, model.mu_ref, model.f_ref, _gram(model, order), R, order)


def _gram(model: FEModel, order: Sequence[str]) -> np.ndarray:
    """Frobenius inner products ``<A_i, A_j> = sum(A_i * A_j)`` of the named matrices."""
    mats = [getattr(model, name) for name in order]
    G = np.zeros((len(mats), len(mats)))
    for i, A in enumerate(mats):
        for j in range(i + 1):
            B = mats[j]
            G[i, j] = G[j, i] = float(A.multiply(B).sum() if sp.issparse(A) else np.vdot(A, _dense(B)))
    return G


@honour_thread_limit
@renamed_kwargs(omega="disc_speed")
def reduced_eigs(
    reduced: ReducedModel,
    disc_speed: float,
    mu: float,
    *,
    band: tuple[float, float] = (1e3, 16e3),
    eta_max: float = 1e-8,
    vectors: bool = False,
) -> dict[str, np.ndarray]:
    """Eigenvalues of the reduced model in ``band`` with each one's full-model backward error.

    Parameters
    ----------
    reduced : ReducedModel
    disc_speed : float
        Disc speed [rad/s] (keyword ``omega=`` deprecated).
    mu : float
        Friction coefficient.
    band : (float, float)
        Frequencies [Hz] kept (positive frequencies only: eigenvalues come in conjugates).
    eta_max : float
        Backward error up to which an eigenvalue is ``trusted``.
    vectors : bool
        Also return the full-model eigenvectors ``V y`` (n, m).

    Returns
    -------
    dict
        ``eigenvalue`` (m,) complex [1/s], ``growth_rate`` [1/s], ``frequency_hz``,
        ``residual`` (backward error), ``trusted`` (bool), and ``vector`` on request.
    """
    lo, hi = _validate_band(band)
    lam, Y, eta = reduced_solve(reduced, disc_speed, mu, lo, hi)
    out = {
        "eigenvalue": lam,
        "growth_rate": lam.real,
        "frequency_hz": lam.imag / (2 * math.pi),
        "residual": eta,
        "trusted": eta <= eta_max,
    }
    if vectors:
        out["vector"] = reduced.V @ Y
    return out


@renamed_kwargs(omega="disc_speed")
def reduced_solve(reduced: ReducedModel, disc_speed: float, mu: float, lo: float, hi: float):
    """Eigenvalues in ``[lo, hi]`` Hz, their unit coordinates ``Y`` in the basis and full-model residuals.

    Parameters
    ----------
    reduced : ReducedModel
    disc_speed : float
        Disc speed [rad/s] (keyword ``omega=`` deprecated).
    mu : float
        Friction coefficient (with the run-out slope added, if any).
    lo, hi : float
        Frequency band [Hz].

    Returns
    -------
    (ndarray, ndarray, ndarray)
        Eigenvalues (k,), their coordinates ``Y`` (r, k) (unit columns) and backward errors (k,).
    """
    coef = _coefficients(reduced.projected, disc_speed, mu)
    r = reduced.n_reduced
    Mr = reduced.mats["M"]
    Cr = np.zeros((r, r))
    Kr = np.zeros((r, r))
    for name, (power, c) in coef.items():
        if power == 1:
            Cr += c * reduced.mats[name]
        elif power == 0:
            Kr += c * reduced.mats[name]
    # M_r = L L^T (V^T M V is positive definite): with y = L^-T u the standard state matrix
    # [0 I; -L^-1 K L^-T  -L^-1 C L^-T] has the same eigenvalues (cheaper than QZ on the pencil)
    L = np.linalg.cholesky(Mr)

    def congruent(A: np.ndarray) -> np.ndarray:
        return sla.solve_triangular(L, sla.solve_triangular(L, A.T, lower=True).T, lower=True)

    A = np.block([[np.zeros((r, r)), np.eye(r)], [-congruent(Kr), -congruent(Cr)]])
    lam, Z = sla.eig(A, check_finite=False, overwrite_a=True)
    f = lam.imag / (2 * math.pi)
    sel = np.isfinite(lam) & (f >= lo) & (f <= hi)
    lam, U = lam[sel], Z[:r, sel]
    order = np.argsort(lam.imag)
    lam, U = lam[order], U[:, order]
    Y = sla.solve_triangular(L, U, lower=True, trans="T")
    Y = Y / np.linalg.norm(Y, axis=0)
    return lam, Y, _reduced_backward_error(reduced, coef, lam, Y)


def _reduced_backward_error(reduced: ReducedModel, coef, lam: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Full-model backward error of each ``(lam_j, V y_j)`` from the R factor (V orthonormal)."""
    r, m = Y.shape
    stacked = np.empty((len(reduced.order) * r, m), dtype=complex)
    weights = np.zeros((3, len(reduced.order)))  # row p: the coefficients of the lambda^p matrix
    for i, name in enumerate(reduced.order):
        power, c = coef[name]
        stacked[i * r:(i + 1) * r] = Y * (c * lam**power)
        weights[power, i] = c
    nK, nC, nM = np.sqrt(np.maximum(np.einsum("pi,ij,pj->p", weights, reduced.gram, weights), 0.0))
    res = np.linalg.norm(real_times(reduced.R, stacked), axis=0)
    return res / ((np.abs(lam) ** 2 * nM + np.abs(lam) * nC + nK) * np.linalg.norm(Y, axis=0))


@honour_thread_limit
@renamed_kwargs(omegas="disc_speeds")
def reduced_sweep(
    reduced: ReducedModel,
    disc_speeds: Sequence[float],
    mus: Sequence[float],
    *,
    band: tuple[float, float] = (1e3, 16e3),
    eta_max: float = 1e-8,
    track: bool = True,
):
    """Reduced eigenvalues over a speed x friction grid, as an ``xarray.Dataset``.

    Parameters
    ----------
    reduced : ReducedModel
        From :func:`reduce`.
    disc_speeds, mus : sequences of float
        Disc speeds [rad/s] and friction coefficients of the grid (``omegas=`` is the deprecated
        keyword of ``disc_speeds``).
    band : (float, float)
        Frequencies [Hz] kept.
    eta_max : float
        Backward error up to which an eigenvalue is ``trusted``.
    track : bool
        Follow each mode across the grid by MAC on its eigenvector, as
        :func:`~squealkit.stability.fe_stability_map` does (the first column along the disc speed,
        then each row along mu; computed in the basis's coordinates, where the MAC is the
        full model's because the basis is orthonormal). Otherwise modes are numbered by
        frequency at each point.

    Returns
    -------
    xarray.Dataset
        Dims ``(rpm, mu, mode)`` (``mode`` a tracked mode, NaN where it is outside the
        band; or, without tracking, the eigenvalues in the band by frequency, padded with
        NaN): ``growth_rate`` [1/s], ``frequency_hz`` [Hz], ``residual`` (full-model
        backward error), ``trusted``; per point ``any_unstable`` (a trusted eigenvalue with
        positive growth rate), ``max_growth_rate`` and ``all_trusted``; coordinates ``rpm``
        and ``disc_speed`` [rad/s] (the disc speed, never ``omega``).
    """
    import xarray as xr

    lo, hi = _validate_band(band)
    speeds = np.atleast_1d(np.asarray(disc_speeds, dtype=float))
    mus = np.atleast_1d(np.asarray(mus, dtype=float))
    tracker = MacTracker()
    results = {}
    with _one_blas_thread():  # many small dense solves: serial BLAS measured 5x faster on 2 shared cores
        column = None
        for i, speed in enumerate(speeds):
            prev = column
            for j, mu in enumerate(mus):
                lam, Y, eta = reduced_solve(reduced, speed, mu, lo, hi)
                if not track:
                    slots = np.arange(lam.size)
                    tracker.n_slots = max(tracker.n_slots, lam.size)
                elif prev is None:
                    slots = tracker.first(lam.size)
                else:
                    slots = tracker.match(prev, lam, Y)
                prev = (slots, lam, Y)
                if j == 0:
                    column = prev
                results[i, j] = (slots, lam, eta)
    m = tracker.n_slots
    shape = (len(speeds), len(mus), m)
    lam_a = np.full(shape, np.nan + 1j * np.nan)
    res = np.full(shape, np.nan)
    for (i, j), (slots, lam, eta) in results.items():
        lam_a[i, j, slots] = lam
        res[i, j, slots] = eta
    valid = ~np.isnan(res)
    trusted = valid & (res <= eta_max)
    gr = lam_a.real
    dims = ("rpm", "mu", "mode")
    ds = xr.Dataset(
        {
            "growth_rate": (dims, gr, {"units": "1/s", "long_name": "growth rate (real part)"}),
            "frequency_hz": (dims, lam_a.imag / (2 * math.pi), {"units": "Hz"}),
            "residual": (dims, res, {"long_name": "full-model backward error"}),
            "trusted": (dims, trusted, {"long_name": f"residual <= {eta_max:g}"}),
            "any_unstable": (dims[:2], np.any(trusted & (np.nan_to_num(gr, nan=-np.inf) > 0), axis=2)),
            "max_growth_rate": (dims[:2], np.max(np.where(valid, gr, -np.inf), axis=2, initial=-np.inf)),
            "all_trusted": (dims[:2], np.all(trusted | ~valid, axis=2)),
        },
        coords={
            "rpm": ("rpm", speeds * 60 / (2 * math.pi), {"units": "1/min", "long_name": "disc speed"}),
            "disc_speed": ("rpm", speeds, {"units": "rad/s", "long_name": "disc speed 2 pi rpm/60"}),
            "mu": ("mu", mus),
            "mode": ("mode", np.arange(m),
                     {"long_name": "mode index (tracked by MAC)" if track else "mode index (by frequency)"}),
        },
        attrs={"kind": "reduced_sweep", "band_hz": [lo, hi], "eta_max": eta_max, "n_reduced": reduced.n_reduced,
               "n_full": reduced.V.shape[0], "tracked": int(track)},
    )
    return ds
