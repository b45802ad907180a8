"""The second-order perturbation estimate of :func:`~squealkit.design.robust_margins`.

After Nobari, Ouyang & Bannister (J. Sound Vib. 338, 2015): the growth rate of every mode as a
quadratic in the parameters,
``sigma(p) ~ sigma0 + g . dp + dp^T H dp / 2``, with ``g`` and ``H`` the first and second
derivatives of the eigenvalue, from the modal expansion over ALL eigenvectors of the
(reduced) model's state-space pencil (no re-solve); then the mean and variance of each growth
rate from the parameters' moments, the probability of ``sigma > 0`` per mode by a normal
approximation, and for the system from the joint normal of all modes' growth rates (their
covariance from the same expansion). Its interval is the range the per-mode probabilities
allow for the system whatever their dependence: ``[max_k P_k, min(1, sum_k P_k)]``.

When the perturbation estimate holds
------------------------------------
The expansion is that of a simple eigenvalue; it fails near a coalescence of two eigenvalues
(an exceptional point: the onset of mode-coupling squeal), where the derivatives grow without
bound. For two modes ``k, l`` and the scatter ``s_i`` of each parameter, the two-mode reduction
of the problem has eigenvalues ``mean +- sqrt((Delta/2)^2 + eps^2 h_kl h_lk)``, whose series in
``x = 4 eps^2 h_kl h_lk / Delta^2`` converges for ``|x| < 1``. Each mode's ``coupling_ratio`` is
the largest ``x`` at three standard deviations, ``36 sum_i s_i^2 |h_i,kl h_i,lk| / |Delta_kl|^2``;
above :data:`COUPLING_MAX` the mode is ``indeterminate`` (its probability NaN, a
:class:`PerturbationWarning`), unless a bound shows it stays stable anyway (``stable_bound``:
nominal growth rate plus three first-order standard deviations plus the three-sigma coupling
shift below zero). A system with an indeterminate mode has a NaN perturbation propensity: never
a silent wrong number. The estimate also assumes small scatter (a few percent): the Monte Carlo
side tells how far it holds.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray

from ._pencil import _gamma, _pencil

__all__ = ["COUPLING_MAX", "PERTURBATION_STATUS", "PerturbationWarning"]

#: Codes of ``perturbation_status``: 0 the expansion holds, 1 beyond it but bounded stable,
#: 2 indeterminate (near a coalescence: the estimate would be wrong).
PERTURBATION_STATUS = ("valid", "stable_bound", "indeterminate")
#: Largest three-sigma coupling ratio (module notes) at which the perturbation estimate is trusted.
COUPLING_MAX = 0.5
#: Step of the central differences of a small model's matrices, in standard deviations.
_FD_STEP = 0.05


class PerturbationWarning(UserWarning):
    """The perturbation estimate does not hold for some mode (near a coalescence of eigenvalues)."""


def _second_order_derivatives(mats: NDArray, first: NDArray, second: NDArray | None = None, *,
                           eigenvalues: NDArray | None = None, gamma: float | None = None) -> dict[str, NDArray]:
    """First and second derivatives of eigenvalues of ``lambda^2 M(p) + lambda C(p) + K(p)``.

    From the modal expansion over all ``2n`` eigenvectors of the companion pencil ``(A, B)``
    (``A = [[0, I], [-K, -C]]``, ``B = diag(I, M)``, scaled), with left eigenvectors ``Y``
    normalised to ``Y^H B X = I``. In modal coordinates the perturbed pencil is
    ``(Lambda + e_i a_i + e_i e_j a_ij / 2, I + e_i b_i + e_i e_j b_ij / 2)`` with
    ``a_i = Y^H A_i X``; as a standard problem ``H = Lambda + e_i h_i + e_i e_j h_ij / 2`` with
    ``h_i = a_i - b_i Lambda`` and ``h_ij = a_ij - b_i a_j - b_j a_i - b_ij Lambda + (b_i b_j + b_j b_i) Lambda``.
    Then (Rayleigh-Schroedinger, simple eigenvalue ``k``)::

        d lambda_k / dp_i = (h_i)_kk
        d2 lambda_k / dp_i dp_j = (h_ij)_kk
                                  + sum_{l != k} ((h_i)_kl (h_j)_lk + (h_j)_kl (h_i)_lk) / (lambda_k - lambda_l)

    exact for the n-DOF problem given (a reduced model's eigenvalues: its whole modal basis).

    Parameters
    ----------
    mats : ndarray, shape (3, n, n)
        ``M, C, K`` at the nominal parameters (real).
    first : ndarray, shape (d, 3, n, n)
        Their derivatives with respect to each of d parameters.
    second : ndarray, shape (d, d, 3, n, n), optional
        Second derivatives (None: the matrices are linear in the parameters).
    eigenvalues : ndarray, shape (m,), optional
        The eigenvalues [1/s] of the modes wanted (e.g. from another solve), each matched to one of
        the pencil's by least total distance; default all ``2n``, in LAPACK's order.
    gamma : float, optional
        Eigenvalue scale of the pencil; default ``sqrt(||K|| / ||M||)``.

    Returns
    -------
    dict
        ``eigenvalues`` (m,) [1/s] (the pencil's, matched), ``first`` (m, d)
        and ``second`` (m, d, d) complex derivatives, ``gap`` (m, 2n) ``lambda_k - lambda_l``
        [1/s] (``inf`` for l = k) and ``coupling`` (d, m, 2n) ``(h_i)_kl (h_i)_lk`` [1/s^2 per
        unit^2] (0 for l = k): the data of the validity check.
    """
    mats = np.asarray(mats, dtype=float)
    first = np.asarray(first, dtype=float)
    n = mats.shape[-1]
    d = first.shape[0]
    g = _gamma(mats) if gamma is None else float(gamma)
    A, B = _pencil(mats, g)
    w, Yl, X = sla.eig(A, B, left=True, right=True)
    norm = np.einsum("ik,ik->k", Yl.conj(), B @ X)
    Y = Yl / norm.conj()  # Y^H B X = I
    if eigenvalues is None:
        sel = np.arange(w.size)
    else:
        from scipy.optimize import linear_sum_assignment

        want = np.atleast_1d(np.asarray(eigenvalues, dtype=complex))
        cost = np.abs(want[:, None] - g * w[None, :])
        rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e300))
        sel = cols[np.argsort(rows)]
    Yb, Xt, Xb = Y[n:], X[:n], X[n:]

    def a_of(dM: NDArray, dC: NDArray, dK: NDArray) -> tuple[NDArray, NDArray]:
        """``Y^H A' X`` and ``Y^H B' X`` of one parameter's matrix derivatives."""
        a = Yb.conj().T @ (-(dK @ Xt) / g**2 - (dC @ Xb) / g)
        b = Yb.conj().T @ (dM @ Xb)
        return a, b

    ab = [a_of(*first[i]) for i in range(d)]
    a = np.array([x[0] for x in ab])
    b = np.array([x[1] for x in ab])
    h = a - b * w[None, None, :]
    m = sel.size
    hr = h[:, sel, :]  # (d, m, 2n): (h_i)_kl
    hc = np.transpose(h[:, :, sel], (0, 2, 1))  # (d, m, 2n): (h_i)_lk
    gap = w[sel][:, None] - w[None, :]
    inv = np.zeros_like(gap)
    off = np.ones(gap.shape, dtype=bool)
    off[np.arange(m), sel] = False
    inv[off] = 1.0 / gap[off]
    dlam = h[:, sel, sel].T  # (m, d)
    t = np.einsum("ikl,jkl,kl->kij", hr, hc, inv)
    br, bc = b[:, sel, :], np.transpose(b[:, :, sel], (0, 2, 1))
    ac = np.transpose(a[:, :, sel], (0, 2, 1))
    ba = np.einsum("ikl,jkl->kij", br, ac)
    bb = np.einsum("ikl,jkl->kij", br, bc)
    wk = w[sel][:, None, None]
    d2 = t + np.transpose(t, (0, 2, 1)) - ba - np.transpose(ba, (0, 2, 1)) + (bb + np.transpose(bb, (0, 2, 1))) * wk
    if second is not None:
        second = np.asarray(second, dtype=float)
        for i in range(d):
            for j in range(d):
                a2, b2 = a_of(*second[i, j])
                d2[:, i, j] += a2[sel, sel] - b2[sel, sel] * w[sel]
    gap_out = np.where(off, gap * g, np.inf)
    return {"eigenvalues": g * w[sel], "first": g * dlam, "second": g * d2, "gap": gap_out,
            "coupling": g**2 * hr * hc * off[None]}


def _growth_statistics(sigma0: NDArray, grad: NDArray, hess: NDArray, std: NDArray, m3: NDArray,
                       m4: NDArray) -> tuple[NDArray, NDArray]:
    """Mean (m,) and covariance (m, m) of ``sigma0 + g.x + x^T H x / 2`` for independent zero-mean x.

    ``E = sigma0 + sum_i H_ii s_i^2 / 2``; ``Cov_kl = sum_i g_ki g_li s_i^2
    + sum_i (g_ki H_l,ii + g_li H_k,ii) mu3_i / 2 + sum_i H_k,ii H_l,ii (mu4_i - s_i^4) / 4
    + sum_{i != j} H_k,ij H_l,ij s_i^2 s_j^2 / 2`` (for a normal: ``mu3 = 0``, ``mu4 = 3 s^4``).
    """
    s2 = std**2
    diag = np.einsum("kii->ki", hess)
    mean = sigma0 + 0.5 * diag @ s2
    cov = (grad * s2) @ grad.T
    cov += 0.5 * ((grad * m3) @ diag.T + (diag * m3) @ grad.T)
    cov += 0.25 * (diag * (m4 - s2**2)) @ diag.T
    w2 = np.outer(s2, s2)
    np.fill_diagonal(w2, 0.0)
    cov += 0.5 * np.einsum("kij,lij,ij->kl", hess, hess, w2)
    return mean, 0.5 * (cov + cov.T)


def _system_probability(mean: NDArray, cov: NDArray, seed: int) -> float:
    """``P(any sigma_k > 0)`` for jointly normal growth rates: ``1 - Phi_m(0; mean, cov)``.

    Modes with a per-mode probability below 1e-12 are left out (they change nothing at the
    integration's accuracy, 1e-6); a tiny ridge keeps a rank-deficient covariance (fewer
    parameters than modes) integrable.
    """
    from scipy import stats

    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.where(std > 0, stats.norm.sf(-mean / np.where(std > 0, std, 1.0)), (mean > 0).astype(float))
    keep = p > 1e-12
    if not keep.any():
        return 0.0
    if keep.sum() == 1 or np.any(p[keep] >= 1.0):
        return float(p[keep].max()) if keep.sum() == 1 else 1.0
    c = cov[np.ix_(keep, keep)]
    c = c + np.eye(c.shape[0]) * 1e-9 * np.max(np.diag(c))
    mvn = stats.multivariate_normal(mean=mean[keep], cov=c, allow_singular=True, seed=seed, abseps=1e-7,
                                    releps=1e-7)
    return float(np.clip(1.0 - mvn.cdf(np.zeros(c.shape[0])), 0.0, 1.0))


def _perturbation(mats: NDArray, first: NDArray, second: NDArray | None, gamma: float, lam0: NDArray,
                  std: NDArray, m3: NDArray, m4: NDArray, tol: float, seed: int) -> dict[str, Any]:
    """The second-order perturbation estimate at the parameters' mean (module notes); a growth rate
    up to ``tol`` [1/s] is neutral, not unstable (as the stability maps count it)."""
    der = _second_order_derivatives(mats, first, second, eigenvalues=lam0, gamma=gamma)
    lam0 = der["eigenvalues"]
    grad, hess = der["first"].real, der["second"].real
    mean, cov = _growth_statistics(lam0.real - tol, grad, hess, std, m3, m4)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    # validity: the two-mode coupling at three standard deviations against the gap (module notes)
    s2 = std**2
    coupling = np.abs(np.einsum("ikl,i->kl", np.abs(der["coupling"]), s2))
    ratio = np.max(36.0 * coupling / np.abs(der["gap"]) ** 2, axis=1, initial=0.0)
    shift = 3.0 * np.sqrt(np.max(coupling, axis=1, initial=0.0))
    sd1 = np.sqrt(np.maximum((grad**2) @ s2, 0.0))
    bound = lam0.real - tol + 3.0 * sd1 + shift
    status = np.where(ratio <= COUPLING_MAX, 0, np.where(bound < 0.0, 1, 2)).astype(np.int8)
    from scipy import stats

    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.where(sd > 0, stats.norm.sf(-mean / np.where(sd > 0, sd, 1.0)), (mean > 0).astype(float))
    p = np.where(status == 1, 0.0, np.where(status == 2, np.nan, p))
    ok = status == 0
    if np.any(status == 2):
        system, low, high = math.nan, math.nan, math.nan
    else:
        system = _system_probability(mean[ok], cov[np.ix_(ok, ok)], seed) if ok.any() else 0.0
        low = float(np.max(p, initial=0.0))
        high = float(min(1.0, np.sum(p)))
    return {"eigenvalues": lam0, "grad": grad, "hess": hess, "mean": mean + tol, "std": sd,
            "probability": p, "status": status, "ratio": ratio, "propensity": system, "ci": (low, high)}


def _fd_derivatives(builder: Callable, payload: Any, p0: NDArray, step: NDArray) -> tuple[NDArray, NDArray]:
    """First and second derivatives of a small model's matrices by central differences.

    ``(A(p + h e_i) - A(p - h e_i)) / 2h``, ``(A(p + h) - 2 A(p) + A(p - h)) / h^2`` and the
    four-point mixed difference; ``h`` a twentieth of each parameter's standard deviation.
    """
    d = p0.size
    E = np.diag(step)
    rows = [p0]
    for i in range(d):
        rows += [p0 + E[i], p0 - E[i]]
    for i in range(d):
        for j in range(i + 1, d):
            rows += [p0 + E[i] + E[j], p0 + E[i] - E[j], p0 - E[i] + E[j], p0 - E[i] - E[j]]
    A = builder(payload, np.array(rows))
    first = np.empty((d, *A.shape[1:]))
    second = np.empty((d, d, *A.shape[1:]))
    for i in range(d):
        up, dn = A[1 + 2 * i], A[2 + 2 * i]
        first[i] = (up - dn) / (2 * step[i])
        second[i, i] = (up - 2 * A[0] + dn) / step[i] ** 2
    k = 1 + 2 * d
    for i in range(d):
        for j in range(i + 1, d):
            pp, pm, mp, mm = A[k:k + 4]
            second[i, j] = second[j, i] = (pp - pm - mp + mm) / (4 * step[i] * step[j])
            k += 4
    return first, second

