"""The subspace projection of the commercial FE codes, for the largest brake models.

Abaqus' complex eigenvalue extraction (and MSC Nastran's and ANSYS' "QRDAMP" counterparts)
does not solve the full quadratic problem: it first computes the real modes of the symmetric
undamped system ``(M, K_sym)`` up to a frequency above the band of interest, then projects the
full friction and gyroscopic system ``lambda^2 M + lambda C(omega, mu) + K(omega, mu)`` onto
them and solves the small dense problem (Abaqus Analysis User's Guide, "Complex eigenvalue
extraction"; Graebner et al., ZAMM 96 (2016)). Here:

1. :func:`subspace_basis`: the real modes of ``(M, K_sym)``, ``K_sym = (K1 + K1^T)/2``, up to
   ``freq_max`` (default 1.5 times the band's top), by ARPACK's shift-invert Lanczos
   (``scipy.sparse.linalg.eigsh``) with one sparse factorisation by the chosen LU backend
   (:mod:`squealkit.solvers.lu`; PARDISO's ``L D L^T`` where installed: half SuperLU's memory,
   and one factorisation for both the solves and the count) of ``K_sym - sigma M`` at the middle
   of the range, ``sigma = (2 pi freq_max)^2 / 2``, sized by its inertia (a Sturm count); then every
   matrix of the model projected once, ``V^T A V``. The memory is estimated before any
   factorisation (:func:`~squealkit.solvers.memory.subspace_memory`) and the solve refused in
   one line when it will not fit.
2. :func:`subspace_eigs`: at an operating point, the projected matrices combined and the small
   state-space problem solved densely (LAPACK); every eigenpair in the band is lifted to the
   full model, ``x = V y``, and checked there by its backward error with the full sparse
   matrices (as :func:`~squealkit.solvers.band.band_eigs` reports it), so a basis too poor for
   a mode says so.

The basis depends on the model only, not on the operating point: one basis serves a whole
sweep over disc speed and friction (:class:`~squealkit.stability.fe_sweep.FESolver` with
``method="subspace"``, also on a Dask cluster, where it is sent to each worker once).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .._threads import honour_thread_limit
from .._validation import InputError, validate_finite, validate_model
from ..fe.model import FEModel
from . import lu as _lu
from .band import BAND_HZ, EigenSolution, pencil_backward_errors, validate_band
from .memory import check_fits, memory_limit, subspace_memory

__all__ = ["SubspaceBasis", "subspace_basis", "subspace_eigs"]

#: The real modes reach this many times the band's top by default (Abaqus practice: 1.5-2x).
FREQ_MAX_FACTOR = 1.5

_DAMPING = ("D1", "DR", "DG", "D4")
_STIFFNESS = ("K1", "KR", "KGeo")


@dataclass(frozen=True)
class SubspaceBasis:
    """The real modes of ``(M, K_sym)`` and the model's matrices projected on them.

    Attributes
    ----------
    V : ndarray, shape (n, r)
        Mass-normalised real modes (``V^T M V = I``), by frequency.
    frequency_hz : ndarray, shape (r,)
        Their natural frequencies [Hz].
    freq_max : float
        The cut-off [Hz]: every mode of ``(M, K_sym)`` below it is in ``V``.
    mats : dict of str to ndarray (r, r)
        ``V^T A V`` of every matrix of the model, by name.
    backend : str
        The LU backend that factorised ``K_sym`` (its class name for a callable).
    """

    V: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    freq_max: float
    mats: dict[str, NDArray[np.float64]]
    backend: str

    @property
    def n_modes(self) -> int:
        """Modes in the basis."""
        return self.V.shape[1]


def _symmetric_part(A) -> sp.csr_matrix:
    A = sp.csr_matrix(A)
    return A if _lu._is_symmetric(A) else sp.csr_matrix(0.5 * (A + A.T))


def _factor_and_count(Ks, M, sigma: float, perm, lu, backend: str, before_factor=None):
    """The factorisation of ``Ks - sigma M`` and the modes of ``(Ks, M)`` below ``sigma`` [rad^2/s^2]
    by its inertia (Sylvester): PARDISO's count of negative pivots of its ``L D L^T`` (one
    factorisation for both), else SuperLU's with diagonal pivots and then the backend's own."""
    P = Ks - sigma * M
    if backend == "pardiso":
        f = _lu.PardisoLU(P, perm, symmetric=True, before_factor=before_factor)
        del P
        return f, int(f._iparm[22])  # PARDISO reports the negative eigenvalues of a symmetric indefinite matrix
    from .reduction import count_below

    below = count_below(Ks, M, sigma, perm)
    return _lu.factorize(P, perm, lu=lu), below


def _backend_name(lu, n: int) -> str:
    """``"pardiso"`` or ``"superlu"``: which factorisation a real symmetric matrix of n rows gets."""
    name = _lu.lu_backend() if lu is None else lu
    if name == "auto":
        name = "pardiso" if n >= _lu.PARDISO_MIN_DOF and _lu._available("pardiso") else "superlu"
    return name if isinstance(name, str) else type(name).__name__


@honour_thread_limit
def subspace_basis(model: FEModel, *, freq_max: float, lu: str | _lu.Backend | None = None,
                   tol: float = 1e-10) -> SubspaceBasis:
    """The real modes of ``(M, K_sym)`` up to ``freq_max`` and the model projected on them.

    Parameters
    ----------
    model : FEModel
        M symmetric positive definite; ``K_sym = (K1 + K1^T)/2`` (a free model's rigid modes are
        found too: the factorisation is shifted slightly below zero).
    freq_max : float
        Cut-off [Hz] (for a band up to ``f_hi``, about ``1.5 f_hi``).
    lu : str or callable, optional
        LU backend of ``K_sym`` (:mod:`squealkit.solvers.lu`; default ``"auto"``).
    tol : float
        ARPACK's relative accuracy of the eigenvalues of the real modes.

    Returns
    -------
    SubspaceBasis

    Raises
    ------
    InputError
        When the estimated memory does not fit (:mod:`squealkit.solvers.memory`), naming how
        many modes would.
    """
    validate_model(model, kind="fe")
    freq_max = validate_finite("freq_max", freq_max)
    if not freq_max > 0:
        raise InputError(f"Parameter freq_max={freq_max!r} must be a frequency > 0 Hz.")
    n = model.n_dof
    M = sp.csr_matrix(model.M)
    Ks = _symmetric_part(model.K1)
    backend = _backend_name(lu, n)
    nnz = Ks.nnz
    what = f"The real modes of a model of {n} DOFs"
    if backend == "pardiso":  # the factor's peak as PARDISO predicts it after its analysis (the exact fill)
        def before_factor(nbytes: int) -> None:
            check_fits(subspace_memory(n, nnz, 0, factor_bytes=nbytes), what)
    else:  # the factor estimated first (the Lanczos basis is not allocated yet): refused before any work
        before_factor = None
        check_fits(subspace_memory(n, nnz, 0, backend=backend), what)
    # PARDISO orders by its own METIS (one factorisation here: our ordering would only add the
    # graph's copies, 5 GB at 10^6 DOFs); SuperLU and the count by its pivots need ours
    perm = None if backend == "pardiso" else _lu.fill_reducing_order(Ks, M)
    # one factorisation, at the middle of the wanted range: sigma = w_max^2 / 2, so that the modes
    # nearest it are exactly those of [0, w_max^2] once the farthest found lies above w_max^2;
    # its inertia counts the modes below sigma, from which those below w_max^2 are guessed (Weyl:
    # x 1.41 for plates, x 2.83 for solids) and the guess grown until the farthest is above
    sigma = 0.5 * (2 * math.pi * freq_max) ** 2
    for attempt in range(3):
        try:
            factor, below_mid = _factor_and_count(Ks, M, sigma, perm, lu, backend, before_factor)
            break
        except RuntimeError as e:  # a mode exactly at sigma: move off it
            if attempt == 2:
                raise InputError(f"K1 - sigma M is singular at sigma = {sigma:g} rad^2/s^2: {e}") from e
            sigma *= 1 + 1e-6
    k = min(n - 2, 2 * below_mid + 4)
    if 2 * below_mid >= n - 2:
        raise InputError(f"freq_max={freq_max:g} Hz holds most of the model's {n} modes: a dense solve "
                         "(method='dense') is the way.")
    fb = getattr(factor, "peak_bytes", None)
    need = subspace_memory(n, nnz, k, backend=backend, factor_bytes=fb)
    if need > memory_limit():
        per_mode = subspace_memory(n, nnz, k + 1, backend=backend, factor_bytes=fb) - need
        fits = max(0, int((memory_limit() - subspace_memory(n, nnz, 0, backend=backend, factor_bytes=fb)) / per_mode))
        check_fits(need, f"The subspace basis of about {k} real modes up to {freq_max:g} Hz of a model of {n} DOFs",
                   f"About {fits} modes would fit: lower freq_max or narrow the band.")
    op = spla.LinearOperator((n, n), matvec=factor.solve, matmat=factor.solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(n)  # reproducible: one model, one basis
    while True:
        ncv = min(n - 1, max(2 * k + 1, k + 40))
        # ARPACK's small dense steps on one OpenBLAS thread (threads there wait on each other;
        # 72 s against 53 s of ARPACK's own time at 8 802 DOFs on a busy 2-core machine); MKL's
        # threads (PARDISO's solves) are left as they are
        with threadpool_limits(limits={"openblas": 1}):
            w, V = spla.eigsh(Ks, k=k, M=M, sigma=sigma, which="LM", OPinv=op, ncv=ncv, tol=tol, v0=v0)
        order = np.argsort(w)
        w, V = w[order], V[:, order]
        freq = np.sqrt(np.maximum(w, 0.0)) / (2 * math.pi)
        if freq[-1] > freq_max or k >= n - 2:  # the disc about sigma covers [0, w_max^2]
            break
        k = min(n - 2, int(1.4 * k) + 4)  # the guess was low: more modes
    del factor, op
    keep = freq <= freq_max
    V, freq = np.ascontiguousarray(V[:, keep]), freq[keep]
    V /= np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    mats = {}
    for name in model.present:
        AV = getattr(model, name) @ V  # one n x r product at a time
        mats[name] = V.T @ AV
        del AV
    return SubspaceBasis(V, freq, float(freq_max), mats, backend)


@honour_thread_limit
def subspace_eigs(model: FEModel, disc_speed: float, mu: float, *, tan_theta: float = 0.0,
                  band: tuple[float, float] = BAND_HZ, basis: SubspaceBasis | None = None,
                  freq_max: float | None = None, vectors: bool = True,
                  lu: str | _lu.Backend | None = None) -> EigenSolution:
    """Eigenvalues in ``band`` by the subspace projection, each checked in the full model.

    Parameters
    ----------
    model : FEModel
    disc_speed, mu, tan_theta : float
        Disc speed [rad/s], friction and run-out slope, as for :func:`~squealkit.solvers.band.band_eigs`.
    band : (float, float)
        Frequency band [Hz] (default 1-16 kHz).
    basis : SubspaceBasis, optional
        From :func:`subspace_basis` (of this model), reused across operating points; built here
        up to ``freq_max`` if not given.
    freq_max : float, optional
        Cut-off of a basis built here [Hz] (default :data:`FREQ_MAX_FACTOR` times the band's top).
    vectors : bool
        Return the full-model right eigenvectors ``x = V y`` (n x k complex).
    lu : str or callable, optional
        LU backend of a basis built here.

    Returns
    -------
    EigenSolution
        Eigenvalues in the band (omega_d >= 0) by frequency, their eigenvectors and backward
        errors in the FULL model (a pair above :data:`~squealkit.solvers.band.RESIDUAL_TOL` is
        not to be trusted: widen ``freq_max``).

    Examples
    --------
    >>> f = 100.0 * np.arange(1, 41)    # 40 undamped oscillators of 100 Hz to 4 kHz
    >>> m = FEModel.from_matrices(M=sp.eye(40).tocsr(), K1=sp.diags((2 * np.pi * f) ** 2).tocsr())
    >>> sol = subspace_eigs(m, 10.0, 0.3, band=(950.0, 1350.0), freq_max=2000.0)
    >>> np.round(sol.frequency_hz, 6).tolist(), bool(sol.residuals.max() < 1e-12)
    ([1000.0, 1100.0, 1200.0, 1300.0], True)
    """
    validate_model(model, kind="fe")
    lo, hi = validate_band(band)
    if basis is None:
        basis = subspace_basis(model, freq_max=FREQ_MAX_FACTOR * hi if freq_max is None else freq_max, lu=lu)
    elif basis.V.shape[0] != model.n_dof:
        raise InputError(f"The basis has {basis.V.shape[0]} DOFs, the model {model.n_dof}: build it from this model.")
    lam, Y = _projected_eigs(model, basis, disc_speed, mu, tan_theta, lo, hi)
    M = model.mass_matrix()
    C = model.damping_matrix(disc_speed, mu, tan_theta)
    K = model.stiffness_matrix(disc_speed, mu, tan_theta)
    X_all = []
    res = np.empty(lam.size)
    step = max(1, int(2**28 // (16 * max(model.n_dof, 1))))  # lift 256 MB of vectors at a time
    for a in range(0, lam.size, step):
        X = basis.V @ Y[:, a:a + step]
        X /= np.linalg.norm(X, axis=0)
        res[a:a + step] = pencil_backward_errors(M, C, K, lam[a:a + step], X)
        if vectors:
            X_all.append(X)
    X = np.concatenate(X_all, axis=1) if vectors and X_all else (np.zeros((model.n_dof, 0), complex) if vectors
                                                                 else None)
    return EigenSolution(lam, X, res)


def _projected_eigs(model: FEModel, basis: SubspaceBasis, disc_speed, mu, tan_theta, lo, hi):
    """Eigenvalues in ``[lo, hi]`` Hz (omega_d >= 0) of the projected problem and their coordinates
    (r x k), by the state matrix congruent through ``V^T M V = L L^T``
    (as :func:`~squealkit.solvers.reduction.reduced_solve`)."""
    f = model.factors(disc_speed, mu, tan_theta)
    r = basis.n_modes
    if r == 0:
        return np.zeros(0, complex), np.zeros((0, 0), complex)
    Cr = np.zeros((r, r))
    Kr = np.zeros((r, r))
    for name, A in basis.mats.items():
        if name in _DAMPING and f.get(name, 0.0):
            Cr += f[name] * A
        elif name in _STIFFNESS and f.get(name, 0.0):
            Kr += f[name] * A
    L = np.linalg.cholesky(basis.mats["M"])

    def congruent(A):
        return sla.solve_triangular(L, sla.solve_triangular(L, A.T, lower=True).T, lower=True)

    A = np.block([[np.zeros((r, r)), np.eye(r)], [-congruent(Kr), -congruent(Cr)]])
    lam, Z = sla.eig(A, check_finite=False, overwrite_a=True)
    freq = lam.imag / (2 * math.pi)
    sel = np.isfinite(lam) & (freq >= lo) & (freq <= hi)
    lam, U = lam[sel], Z[:r, sel]
    order = np.lexsort((lam.real, lam.imag))
    Y = sla.solve_triangular(L, U[:, order], lower=True, trans="T")
    return lam[order], Y
