"""Robust margins: the probability that a brake squeals when its parameters scatter, two ways.

A brake that is stable at its nominal parameters may squeal when a part is a little stiffer,
a pad a little softer or the friction material a little more aggressive. Given the scatter of
some parameters (independent, each a distribution), :func:`robust_margins` estimates the squeal
propensity at one operating point: the probability that some mode in the band has a positive
growth rate. Two methods, side by side, each with its interval and its cost:

``montecarlo``
    Seeded samples of the parameters; each sample is a small dense eigenproblem. An FE model is
    reduced once, for its nominal parameters (:func:`~squealkit.solvers.reduction.reduce` on a
    POD basis, as :func:`~squealkit.stability.fe_stability_map` builds it): each scattered matrix
    part ``A`` enters as ``V^T A V``, so a sample costs an eigen solve of ``2 r`` unknowns. The
    eigenpairs of a subset of samples are checked by their backward error in the FULL model
    (from the basis' residual factor, no full-size product), which says whether the basis still
    holds the scattered models. The interval is the Clopper-Pearson (exact binomial) one, as in
    :func:`~squealkit.uncertainty.squeal_propensity`.

``perturbation``
    The second-order perturbation estimate (Nobari, Ouyang & Bannister, J. Sound Vib. 338,
    2015): the growth rate of every mode as a quadratic in the parameters,
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

Scatter
-------
``scatter`` maps a name to its distribution:

- FE models (:class:`~squealkit.fe.model.FEModel`): a name is a matrix part (``M``, ``D1``,
  ``DG``, ``DR``, ``D4``, ``K1``, ``KR``, ``KGeo``), the scattered quantity its scale factor,
  nominal 1 (``KR`` scatters the friction coupling, ``K1`` the structure's stiffness).
- Small models (presets, model files): a name is a scalar parameter (``k3``, ``kc``,
  ``alpha_deg``...) as in :mod:`squealkit.uncertainty`.

A value is either a coefficient of variation (``{"KR": 0.05}``: normal, mean the nominal value,
standard deviation 5 % of it), a table ``{"dist": "normal" | "uniform" | "lognormal", "cov": c}``
(a uniform of that coefficient of variation spans ``nominal (1 +- sqrt(3) c)``), or a table in
the form of :mod:`squealkit.uncertainty` (``{"dist": "normal", "mean": ..., "std": ...}``, in
the parameter's unit). The parameters are independent; the nominal point of the perturbation
estimate is their mean.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import scipy.linalg as sla
import xarray as xr
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .. import __version__
from .._threads import honour_thread_limit
from .._validation import InputError, validate_angle, validate_finite, validate_model
from ..uncertainty import DISTRIBUTIONS, UncertainParameter, parse_uncertain, sample_parameters

__all__ = ["COUPLING_MAX", "METHODS", "PERTURBATION_STATUS", "PerturbationWarning", "robust_margins"]

#: The methods of :func:`robust_margins`.
METHODS = ("montecarlo", "perturbation")
#: Codes of ``perturbation_status``: 0 the expansion holds, 1 beyond it but bounded stable,
#: 2 indeterminate (near a coalescence: the estimate would be wrong).
PERTURBATION_STATUS = ("valid", "stable_bound", "indeterminate")
#: Largest three-sigma coupling ratio (module notes) at which the perturbation estimate is trusted.
COUPLING_MAX = 0.5
#: FE models up to this many DOFs are solved whole (basis: the identity) unless a basis is given.
_FULL_MAX_DOF = 200
#: Samples per Monte Carlo task (results never depend on it).
_BATCH = 256
#: Estimated Monte Carlo time [s] below which a given Dask client is not used: shipping the tasks
#: costs more than solving them here (a sample's eigen solve is about 25 (2n)^3 flops, at 1e10 flop/s).
_CLUSTER_MIN_SECONDS = 2.0
#: Samples whose eigenpairs are checked in the full model (the first ones drawn, and the nominal).
_CHECKED = 16
#: Relative growth rate below which a mode counts as neutral, not unstable (as the stability maps).
_UNSTABLE_RTOL = 1e-9
#: Step of the central differences of a small model's matrices, in standard deviations.
_FD_STEP = 0.05


class PerturbationWarning(UserWarning):
    """The perturbation estimate does not hold for some mode (near a coalescence of eigenvalues)."""


# ----------------------------------------------------------------------------- scatter


def _scatter_table(scatter: Mapping[str, Any], nominal: Mapping[str, float]) -> dict[str, dict[str, Any]]:
    """The ``scatter`` entries in the table form of :mod:`squealkit.uncertainty` (module notes)."""
    if not isinstance(scatter, Mapping) or not scatter:
        raise InputError("Parameter scatter must be a non-empty mapping NAME -> coefficient of variation "
                         "(e.g. {'KR': 0.05}) or NAME -> {dist = ..., cov = ...}.")
    table: dict[str, dict[str, Any]] = {}
    for name, spec in scatter.items():
        if name not in nominal:
            continue  # the caller's name check says what is known
        if isinstance(spec, Mapping) and "cov" not in spec:
            table[name] = dict(spec)
            continue
        if isinstance(spec, Mapping):
            spec = dict(spec)
            dist = spec.pop("dist", "normal")
            cov = spec.pop("cov")
            if spec:
                raise InputError(f"Scatter of {name}: with cov= give only dist=, not {', '.join(sorted(spec))}.")
        else:
            dist, cov = "normal", spec
        if isinstance(cov, bool):
            raise InputError(f"Scatter of {name}: cov={cov!r} must be a number.")
        cov = validate_finite(f"scatter of {name} (cov)", cov)
        if not cov > 0:
            raise InputError(f"Scatter of {name}: the coefficient of variation cov={cov!r} must be > 0.")
        if dist not in DISTRIBUTIONS:
            raise InputError(f"Scatter of {name}: unknown dist={dist!r}; known: {', '.join(DISTRIBUTIONS)}.")
        p0 = float(nominal[name])
        if p0 == 0.0:
            raise InputError(f"Scatter of {name}: its nominal value is 0, so a coefficient of variation means "
                             "nothing; give the distribution itself (mean and std).")
        std = cov * abs(p0)
        if dist == "uniform":
            half = math.sqrt(3.0) * std  # a uniform's std is its half-width / sqrt(3)
            table[name] = {"dist": "uniform", "lower": p0 - half, "upper": p0 + half}
        else:
            table[name] = {"dist": dist, "mean": p0, "std": std}
    return table


def _uncertain(table: Mapping[str, Mapping[str, Any]]) -> tuple[UncertainParameter, ...]:
    out = []
    for name, spec in table.items():
        spec = dict(spec)
        dist = spec.pop("dist", None)
        if dist is None:
            raise InputError(f"Scatter of {name}: missing dist (one of {', '.join(DISTRIBUTIONS)}).")
        out.append(UncertainParameter(name, dist, spec))
    return tuple(out)


def _moments(unc: Sequence[UncertainParameter]) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Mean, standard deviation, third and fourth central moments of each parameter."""
    mean, std, m3, m4 = (np.empty(len(unc)) for _ in range(4))
    for j, p in enumerate(unc):
        m, v, skew, kurt = (float(x) for x in p.distribution.stats(moments="mvsk"))
        s = math.sqrt(v)
        mean[j], std[j], m3[j], m4[j] = m, s, skew * s**3, (kurt + 3.0) * s**4
    return mean, std, m3, m4


# ----------------------------------------------------------------------------- the parametric problem
#
# Every model becomes ``lambda^2 M(p) + lambda C(p) + K(p)`` in n (reduced) unknowns, with the
# matrices of a batch of parameter rows from a module-level builder (pickled to Dask workers):
# ``builder(payload, X) -> (S, 3, n, n)`` (M, C, K per row).


def _linear_matrices(payload: tuple[NDArray, NDArray], X: NDArray) -> NDArray:
    """``fixed + sum_j X_j parts_j`` (an FE model's scale factors): shape (S, 3, n, n)."""
    fixed, parts = payload
    return fixed[None] + np.einsum("sd,dkij->skij", X, parts)


def _model_matrices(payload: tuple, X: NDArray) -> NDArray:
    """``M, C, K`` of a small model at each parameter row (:func:`~squealkit.uncertainty.squeal_propensity`'s
    samples: ``model.replace``, or the rig's model)."""
    from ..stability.modes import _parts, _stiffness
    from ..uncertainty import _sample_models

    model, names, mu, t, damped = payload
    out = []
    for m in _sample_models(model, names, X):
        M, C, K0, Kn, Kf = _parts(m, damped)
        out.append((M, C, _stiffness(m, K0, Kn, Kf, mu, t)))
    return np.asarray(out, dtype=float)


def _gamma(mats: NDArray) -> float:
    """Eigenvalue scale ``sqrt(||K|| / ||M||)`` (Fan, Lin & Van Dooren 2004): O(1) blocks of the pencil."""
    nm, nk = np.linalg.norm(mats[0]), np.linalg.norm(mats[2])
    return math.sqrt(nk / nm) if nk > 0 and nm > 0 else 1.0


def _state_eigvals(mats: NDArray, gamma: float) -> NDArray:
    """All ``2n`` eigenvalues of each ``(M, C, K)`` of a batch (S, 3, n, n): shape (S, 2n).

    The state matrix ``[[0, I], [-M^-1 K / g^2, -M^-1 C / g]]`` of ``lambda = g nu`` (scaled), one
    LAPACK ``geev`` each (no vectors).
    """
    S, _, n, _ = mats.shape
    MK = np.linalg.solve(mats[:, 0], np.concatenate([mats[:, 2] / gamma**2, mats[:, 1] / gamma], axis=2))
    A = np.zeros((S, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :] = -MK
    return gamma * np.linalg.eigvals(A)


def _pencil(mats: NDArray, gamma: float) -> tuple[NDArray, NDArray]:
    """The scaled companion pencil ``A - nu B`` of one ``(M, C, K)``: ``A = [[0, I], [-K/g^2, -C/g]]``,
    ``B = diag(I, M)``; its eigenvector is ``[x; nu x]`` and ``lambda = g nu``."""
    n = mats.shape[-1]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -mats[2] / gamma**2
    A[n:, n:] = -mats[1] / gamma
    B = np.eye(2 * n)
    B[n:, n:] = mats[0]
    return A, B


def _in_band(lam: NDArray, lo: float, hi: float) -> NDArray[np.bool_]:
    f = lam.imag / (2 * math.pi)
    return np.isfinite(lam) & (f >= lo) & (f <= hi)


def _threshold(lam: NDArray) -> NDArray:
    """Growth rate above which a mode is unstable, per row: ``1e-9 max |lambda|`` (as the stability maps)."""
    return _UNSTABLE_RTOL * np.max(np.abs(np.where(np.isfinite(lam), lam, 0.0)), axis=-1)


# ----------------------------------------------------------------------------- Monte Carlo


def _mc_chunk(task: tuple) -> tuple[NDArray, NDArray, NDArray]:
    """One batch of samples (a Dask task): whether each is unstable in the band, its largest growth
    rate in the band, and the eigenvalue of each nominal mode (matched by least total distance)."""
    from scipy.optimize import linear_sum_assignment

    builder, payload, X, lam0, lo, hi, gamma = task
    # many small eigen solves: serial BLAS (threads on 2 busy cores: 12x slower, measured at 2r = 272)
    with threadpool_limits(1, user_api="blas"):
        lam = _state_eigvals(builder(payload, X), gamma)
    band = _in_band(lam, lo, hi)
    tol = _threshold(lam)
    growth = np.where(band, lam.real, -np.inf)
    unstable = np.any(growth > tol[:, None], axis=1)
    matched = np.empty((X.shape[0], lam0.size), dtype=complex)
    for s in range(X.shape[0]):
        cost = np.abs(lam0[:, None] - lam[s][None, :]) / np.maximum(np.abs(lam0[:, None]), 1e-300)
        rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e300))
        matched[s, rows] = lam[s, cols]
    return unstable, growth.max(axis=1, initial=-np.inf), matched


def _montecarlo(builder: Callable, payload: Any, X: NDArray, lam0: NDArray, lo: float, hi: float, gamma: float,
                batch_size: int, client: Any) -> tuple[NDArray, NDArray, NDArray]:
    from ..scale import map_tasks

    starts = list(range(0, X.shape[0], batch_size))
    tasks = [(builder, payload, X[a:a + batch_size], lam0, lo, hi, gamma) for a in starts]
    # small work never pays for a cluster: one batch, or seconds of work, run here
    n2 = 2 * lam0.size if payload is None else 2 * np.shape(builder(payload, X[:1]))[-1]
    seconds = X.shape[0] * 25.0 * n2**3 / 1e10
    use = client if len(tasks) > 1 and seconds >= _CLUSTER_MIN_SECONDS else None
    unstable = np.empty(X.shape[0], dtype=bool)
    top = np.empty(X.shape[0])
    matched = np.empty((X.shape[0], lam0.size), dtype=complex)
    for i, (u, g, m) in map_tasks(_mc_chunk, tasks, client=use, name="squealkit-robust-margins"):
        a = starts[i]
        unstable[a:a + u.size], top[a:a + u.size], matched[a:a + u.size] = u, g, m
    return unstable, top, matched


def _clopper_pearson(k: int, n: int, confidence: float) -> tuple[float, float]:
    from scipy import stats

    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


# ----------------------------------------------------------------------------- perturbation


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


def _modes_in_band(lam: NDArray, lo: float, hi: float) -> NDArray[np.intp]:
    """Indices of the eigenvalues in the band, by frequency."""
    idx = np.flatnonzero(_in_band(lam, lo, hi))
    return idx[np.lexsort((-lam.real[idx], lam.imag[idx]))]


# ----------------------------------------------------------------------------- the two model kinds


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


def _fe_setup(model: Any, disc_speed: float, mu_e: float, unc: Sequence[UncertainParameter],
              band: tuple[float, float] | None, basis: Any) -> dict[str, Any]:
    """Reduced parts of an FE model at the operating point, and its basis."""
    from ..solvers import reduction
    from ..solvers.band import BAND_HZ

    f = model.factors(disc_speed, mu_e)
    f["M"] = 1.0
    scattered = [p.name for p in unc]
    if isinstance(basis, str) and basis == "auto":
        basis = "identity" if model.n_dof <= _FULL_MAX_DOF else "pod"
    if isinstance(basis, str):
        if basis not in ("identity", "pod"):
            raise InputError(f"Parameter basis={basis!r} must be 'auto', 'identity', 'pod' or an (n, r) array.")
        kind = basis
    else:
        kind = "given"
    if band is None:
        band = (0.0, math.inf) if kind == "identity" else BAND_HZ
    if kind == "identity":
        V = np.eye(model.n_dof)
    elif kind == "pod":
        if not math.isfinite(band[1]):
            raise InputError("A POD basis needs a finite band=(lo, hi) [Hz].")
        # friction samples spanning three standard deviations of the friction parts' scale
        spread = max([3 * p.distribution.std() for p in unc if p.name in ("KR", "DR")] + [0.0])
        mus = np.unique([mu_e * (1 - spread), mu_e, mu_e * (1 + spread)])
        modal = reduction.modal_basis(model, freq_max=1.25 * band[1])
        V = np.asarray(reduction.pod_basis(model, [disc_speed], mus, band=band, extra=modal))
    else:
        V = np.asarray(basis, dtype=float)
        if V.ndim != 2 or V.shape[0] != model.n_dof or not np.all(np.isfinite(V)):
            raise InputError(f"Parameter basis must be a finite {model.n_dof} x r array, got shape {V.shape}.")
    reduced = reduction.reduce(model, V)
    r = reduced.n_reduced
    power = {name: 2 if name == "M" else (1 if name in ("D1", "DG", "DR", "D4") else 0) for name in reduced.order}
    slot = {2: 0, 1: 1, 0: 2}
    fixed = np.zeros((3, r, r))
    parts = np.zeros((len(scattered), 3, r, r))
    for name in reduced.order:
        term = f[name] * reduced.mats[name]
        if name in scattered:
            parts[scattered.index(name), slot[power[name]]] = term
        else:
            fixed[slot[power[name]]] += term
    return {"payload": (fixed, parts), "reduced": reduced, "factors": f, "power": power, "band": band,
            "basis": kind}


def _residuals(setup: dict[str, Any], names: Sequence[str], rows: NDArray, gamma: float, lo: float,
               hi: float) -> NDArray:
    """Largest full-model backward error of the band's eigenpairs at each parameter row."""
    from ..solvers.reduction import _reduced_backward_error

    reduced, f, power = setup["reduced"], setup["factors"], setup["power"]
    mats = _linear_matrices(setup["payload"], rows)
    out = np.zeros(rows.shape[0])
    n = mats.shape[-1]
    for s in range(rows.shape[0]):
        A, B = _pencil(mats[s], gamma)
        w, Z = sla.eig(A, B)
        lam = gamma * w
        keep = _in_band(lam, lo, hi)
        if not keep.any():
            continue
        Y = Z[:n, keep]
        Y = Y / np.linalg.norm(Y, axis=0)
        scale = dict(zip(names, rows[s], strict=True))
        coef = {name: (power[name], f[name] * scale.get(name, 1.0)) for name in reduced.order}
        out[s] = float(np.max(_reduced_backward_error(reduced, coef, lam[keep], Y)))
    return out


def _operating_point(model: Any, rpm: float | None, disc_speed: float | None) -> tuple[float, float]:
    """``(rpm, disc_speed)`` of an FE model from exactly one of them."""
    from ..fe.model import rpm_to_disc_speed

    if (rpm is None) == (disc_speed is None):
        raise InputError("Give the disc speed of an FE model as rpm= or disc_speed= (one of them).")
    if rpm is not None:
        rpm = validate_finite("rpm", rpm)
        return rpm, float(rpm_to_disc_speed(rpm))
    disc_speed = validate_finite("disc_speed", disc_speed)
    return disc_speed * 60.0 / (2 * math.pi), disc_speed


def _methods(method: str | Sequence[str]) -> tuple[str, ...]:
    chosen = (method,) if isinstance(method, str) else tuple(method)
    bad = [m for m in chosen if m not in METHODS]
    if not chosen or bad:
        raise InputError(f"Parameter method={method!r}: give one or both of {', '.join(map(repr, METHODS))}.")
    return tuple(m for m in METHODS if m in chosen)


def _positive_int(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < minimum:
        raise InputError(f"Parameter {name}={value!r} must be an integer >= {minimum}.")
    return int(value)


# ----------------------------------------------------------------------------- entry point


@honour_thread_limit
def robust_margins(
    model: Any,
    rpm: float | None = None,
    mu: float | None = None,
    theta: float = 0.0,
    *,
    disc_speed: float | None = None,
    scatter: Mapping[str, Any],
    samples: int = 1000,
    method: str | Sequence[str] = METHODS,
    band: tuple[float, float] | None = None,
    damped: bool | None = None,
    basis: Any = "auto",
    seed: int = 0,
    confidence: float = 0.95,
    eta_max: float | None = None,
    batch_size: int = _BATCH,
    client: Any = None,
) -> xr.Dataset:
    """Squeal propensity under parameter scatter: Monte Carlo and second-order perturbation.

    See the module notes for the two methods, the validity of the perturbation estimate and the
    forms of ``scatter``.

    Parameters
    ----------
    model : FEModel or FrictionModel
        An FE brake (its matrix parts scatter) or a small model (its parameters scatter).
    rpm : float, optional
        Disc speed [rev/min] of an FE model (or ``disc_speed``); not for small models.
    mu : float, optional
        Friction coefficient; default the FE model's ``mu_ref`` (required for small models).
    theta : float
        Run-out incline [rad]: ``mu_e = mu + tan(theta)`` (paper eq. 6).
    disc_speed : float, optional
        Disc speed [rad/s] of an FE model, instead of ``rpm``.
    scatter : mapping
        Name -> coefficient of variation, or ``{dist, cov}``, or ``{dist, mean, std | lower, upper}``
        (module notes). FE: matrix parts (scale factors, nominal 1); small models: parameters.
    samples : int
        Monte Carlo samples (>= 2).
    method : str or sequence of str
        ``"montecarlo"``, ``"perturbation"`` or both (default).
    band : (float, float), optional
        Frequency band [Hz] of the modes that count. Default: every mode of a model solved whole
        (a small model, an FE model up to 200 DOFs), 1-16 kHz for a reduced FE model.
    damped : bool, optional
        Small models: include the damping matrix (as :func:`~squealkit.uncertainty.squeal_propensity`).
    basis : {"auto", "identity", "pod"} or ndarray (n, r)
        FE models: the reduction basis. ``"auto"``: the whole model up to 200 DOFs, else a POD
        basis at the operating point (the real modes to 1.25 times the band's top, the complex modes
        at the nominal friction and three standard deviations of the ``KR``/``DR`` scale either
        side, and the left corrections).
    seed : int
        Seed of the draw (``numpy.random.SeedSequence``): the same result whatever ``batch_size``
        or ``client``.
    confidence : float
        Level of the Monte Carlo interval, in (0, 1).
    eta_max : float, optional
        Full-model backward error up to which a reduced eigenpair is trusted (default
        :data:`~squealkit.solvers.band.RESIDUAL_TOL`).
    batch_size : int
        Monte Carlo samples per task.
    client : distributed.Client, optional
        Run the Monte Carlo batches on this Dask cluster (:mod:`squealkit.scale`); a single batch,
        or work estimated under 2 s, runs here (shipping it would cost more than solving it).

    Returns
    -------
    xarray.Dataset
        ``kind = "robust_margins"``. Over ``mode`` (the nominal modes in the band, by frequency):
        ``frequency_hz`` [Hz], ``growth_rate`` [1/s] (at the parameters' mean); over
        ``(estimator, mode)`` (``estimator`` the methods run, named as in ``method``; not called
        ``method``, which is a keyword of ``Dataset.sel``): ``growth_rate_mean``, ``growth_rate_std``
        [1/s] and ``probability_unstable`` (Monte Carlo: each sample's eigenvalue matched to the
        nominal mode by least total distance); over ``estimator``: ``propensity``, ``propensity_ci_lower``,
        ``propensity_ci_upper`` and ``cost_seconds``. With the perturbation estimate:
        ``growth_rate_sensitivity`` (mode, parameter) [1/s per unit], ``perturbation_status``
        (codes of :data:`PERTURBATION_STATUS`) and ``coupling_ratio`` (mode). With Monte Carlo:
        ``parameter_value`` (sample, parameter), ``max_growth_rate`` and ``unstable`` (sample),
        ``sampled_growth_rate`` (sample, mode). ``attrs``: the operating point, band, scatter,
        seed, basis, ``n_reduced``, the largest full-model backward error of the checked samples
        ``max_residual`` and ``trusted``.

    Raises
    ------
    InputError
        For an unknown name in ``scatter``, an option that does not apply to the model's kind,
        a sampled value outside its range (a scale <= 0), or a bad number.

    Warns
    -----
    PerturbationWarning
        A mode is beyond the perturbation estimate's reach (its propensity is NaN).
    UserWarning
        The reduced basis does not hold the scattered models (``trusted`` is 0).

    Examples
    --------
    The paper's pin-on-disc rig (Lv et al. 2013) at mu = 0.35, just below its onset, with the
    contact stiffness and two dampers scattering by 10 %: the two estimates agree.

    >>> from squealkit.models import get_preset
    >>> ds = robust_margins(get_preset("lv2013"), mu=0.35, scatter={"kc": 0.1, "c1": 0.1, "c2": 0.1},
    ...                     samples=2000, damped=True, seed=1)
    >>> ds.propensity.values.round(2).tolist()   # Monte Carlo, perturbation
    [0.16, 0.15]
    """
    from ..fe.model import FEModel
    from ..solvers.band import RESIDUAL_TOL, validate_band

    validate_model(model)
    methods = _methods(method)
    samples = _positive_int("samples", samples, 2)
    batch_size = _positive_int("batch_size", batch_size, 1)
    seed = _positive_int("seed", seed, 0)
    theta = validate_angle("theta", theta)
    tan_t = math.tan(theta)
    confidence = validate_finite("confidence", confidence)
    if not 0.0 < confidence < 1.0:
        raise InputError(f"Parameter confidence={confidence!r} must lie strictly between 0 and 1.")
    eta_max = RESIDUAL_TOL if eta_max is None else validate_finite("eta_max", eta_max)
    if band is not None:
        band = validate_band(band)
    is_fe = isinstance(model, FEModel)
    t_setup = time.perf_counter()
    if is_fe:
        if damped is not None:
            raise InputError("Parameter damped applies to small models; an FE model's damping is its D parts.")
        rpm, disc_speed = _operating_point(model, rpm, disc_speed)
        mu = model.mu_ref if mu is None else validate_finite("mu", mu)
        mu_e = mu + tan_t
        known = {name: 1.0 for name in model.present}
        for name in scatter if isinstance(scatter, Mapping) else ():
            if name not in known:
                raise InputError(f"Unknown scatter name {name!r} for an FE model; its matrix parts: "
                                 f"{', '.join(model.present)}.")
        unc = _uncertain(_scatter_table(scatter, known))
        setup = _fe_setup(model, disc_speed, mu_e, unc, band, basis)
        band = setup["band"]
        builder, payload = _linear_matrices, setup["payload"]
        units = ["1"] * len(unc)
    else:
        from ..models._base import resolve_damped

        if rpm is not None or disc_speed is not None:
            raise InputError(f"A small model ({model.kind!r}) has no disc speed: rpm and disc_speed apply to FE "
                             "models.")
        if not (isinstance(basis, str) and basis == "auto"):
            raise InputError("Parameter basis applies to FE models; a small model is solved whole.")
        if mu is None:
            raise InputError("Give the friction coefficient mu of a small model.")
        mu = validate_finite("mu", mu)
        damped = resolve_damped(model, damped)
        info = model.parameter_info()
        nominal = {}
        for name in scatter if isinstance(scatter, Mapping) else ():
            base = name[:-4] if name.endswith("_deg") and name not in info else name
            if base in info:
                v = float(getattr(model, base))
                nominal[name] = math.degrees(v) if base != name else v
        table = _scatter_table(scatter, nominal)
        unc = parse_uncertain({k: table.get(k, v) for k, v in scatter.items()}, model)
        names = [(p.model_parameter, p.is_degrees) for p in unc]
        builder, payload = _model_matrices, (model, names, mu, tan_t, damped)
        setup = {"basis": "identity", "reduced": None}
        band = (0.0, math.inf) if band is None else band
        units = ["deg" if p.is_degrees else info[p.model_parameter]["unit"] for p in unc]
    lo, hi = band
    mean_p, std_p, m3, m4 = _moments(unc)
    nominal_mats = builder(payload, mean_p[None])[0]
    gamma = _gamma(nominal_mats)
    lam_all = _state_eigvals(nominal_mats[None], gamma)[0]
    modes = _modes_in_band(lam_all, lo, hi)
    lam0 = lam_all[modes]
    tol = float(_threshold(lam_all[None])[0])
    setup_seconds = time.perf_counter() - t_setup

    # small dense solves one after another: serial BLAS (threads on busy cores: 12x slower, measured)
    with threadpool_limits(1, user_api="blas"):
        results: dict[str, dict[str, Any]] = {}
        X = None
        checked = np.zeros(0)
        if "montecarlo" in methods:
            t0 = time.perf_counter()
            X = sample_parameters(unc, samples, np.random.default_rng(np.random.SeedSequence(seed)))
            _check_scatter_samples(unc, X, model, is_fe)
            unstable, top, matched = _montecarlo(builder, payload, X, lam0, lo, hi, gamma, batch_size, client)
            if is_fe:
                rows = np.vstack([mean_p[None], X[:_CHECKED]])
                checked = _residuals(setup, [p.name for p in unc], rows, gamma, lo, hi)
            k = int(unstable.sum())
            growth = matched.real
            results["montecarlo"] = {
                "mean": growth.mean(axis=0), "std": growth.std(axis=0, ddof=1),
                "probability": np.mean(growth > tol, axis=0), "propensity": k / samples,
                "ci": _clopper_pearson(k, samples, confidence), "unstable": unstable, "top": top, "growth": growth,
                "seconds": time.perf_counter() - t0}
        if "perturbation" in methods:
            t0 = time.perf_counter()
            if is_fe:
                first, second = setup["payload"][1], None
            else:
                first, second = _fd_derivatives(builder, payload, mean_p, _FD_STEP * std_p)
            pert = _perturbation(nominal_mats, first, second, gamma, lam0, std_p, m3, m4, tol, seed)
            pert["seconds"] = time.perf_counter() - t0
            results["perturbation"] = pert
            bad = np.flatnonzero(pert["status"] == 2)
            if bad.size:
                freqs = ", ".join(f"{x:.6g}" for x in lam0[bad].imag / (2 * math.pi))
                warnings.warn(f"The perturbation estimate does not hold for the modes at {freqs} Hz: they lie "
                              f"near a coalescence of eigenvalues (coupling ratio above {COUPLING_MAX:g}); their "
                              "probability and the system's perturbation propensity are NaN. Use the Monte Carlo "
                              "result.",
                              PerturbationWarning, stacklevel=2)
    max_res = float(checked.max(initial=0.0))
    trusted = bool(max_res <= eta_max)
    if not trusted:
        warnings.warn(f"The reduced basis does not hold the scattered models: the largest full-model backward "
                      f"error of the checked samples is {max_res:.3g} (above eta_max={eta_max:g}); pass a richer "
                      "basis= or a narrower scatter.", UserWarning, stacklevel=2)
    return _dataset(model, unc, units, methods, results, lam0, X, mean_p, std_p, attrs={
        "rpm": rpm if is_fe else math.nan, "disc_speed": disc_speed if is_fe else math.nan, "mu": mu,
        "theta": theta, "tan_theta": tan_t, "band_hz": [lo, hi], "seed": seed,
        "samples": samples if "montecarlo" in methods else 0,
        "confidence": confidence, "basis": setup["basis"],
        "n_reduced": int(nominal_mats.shape[-1]),
        "n_full": int(model.n_dof),
        "residual_checked": int(checked.size), "max_residual": max_res, "eta_max": eta_max,
        "trusted": int(trusted), "setup_seconds": setup_seconds, "damped": int(bool(damped)) if not is_fe else 1})


def _check_scatter_samples(unc: Sequence[UncertainParameter], X: NDArray, model: Any, is_fe: bool) -> None:
    """Every sampled value in its range: an FE scale factor > 0, a small model's parameter as
    :mod:`squealkit.uncertainty` checks it."""
    if not is_fe:
        from ..uncertainty import _check_samples

        _check_samples(unc, X, model)
        return
    for j, p in enumerate(unc):
        bad = ~(X[:, j] > 0)
        if bad.any():
            raise InputError(f"Scatter of {p.name}: {int(bad.sum())} of {X.shape[0]} sampled scale factors are <= 0 "
                             f"(e.g. {X[bad, j][0]:.6g}); use a narrower distribution or a lognormal.")


def _dataset(model: Any, unc: Sequence[UncertainParameter], units: Sequence[str], methods: tuple[str, ...],
             results: dict[str, dict[str, Any]], lam0: NDArray, X: NDArray | None, mean_p: NDArray,
             std_p: NDArray, *, attrs: dict[str, Any]) -> xr.Dataset:
    m = lam0.size
    per_mode = {k: np.array([results[meth][k] for meth in methods]).reshape(len(methods), m)
                for k in ("mean", "std", "probability")}
    ci = np.array([results[meth]["ci"] for meth in methods], dtype=float).reshape(len(methods), 2)
    data: dict[str, Any] = {
        "frequency_hz": ("mode", lam0.imag / (2 * math.pi), {"units": "Hz", "long_name": "frequency (nominal)"}),
        "growth_rate": ("mode", lam0.real, {"units": "1/s", "long_name": "growth rate (nominal: the mean "
                                                                         "parameters)"}),
        "growth_rate_mean": (("estimator", "mode"), per_mode["mean"],
                             {"units": "1/s", "long_name": "mean growth rate"}),
        "growth_rate_std": (("estimator", "mode"), per_mode["std"],
                            {"units": "1/s", "long_name": "standard deviation of the growth rate"}),
        "probability_unstable": (("estimator", "mode"), per_mode["probability"],
                                 {"units": "1", "long_name": "probability that the mode grows"}),
        "propensity": ("estimator", [results[meth]["propensity"] for meth in methods],
                       {"units": "1", "long_name": "probability that some mode in the band grows"}),
        "propensity_ci_lower": ("estimator", ci[:, 0], {"units": "1", "long_name": "lower end of the interval"}),
        "propensity_ci_upper": ("estimator", ci[:, 1], {"units": "1", "long_name": "upper end of the interval"}),
        "cost_seconds": ("estimator", [results[meth]["seconds"] for meth in methods],
                         {"units": "s", "long_name": "wall time of the method (after the common set-up)"}),
        "distribution_mean": ("parameter", mean_p, {"long_name": "distribution mean (unit: parameter_unit)"}),
        "distribution_std": ("parameter", std_p, {"long_name": "distribution standard deviation"}),
    }
    if "perturbation" in results:
        pert = results["perturbation"]
        data |= {
            "growth_rate_sensitivity": (("mode", "parameter"), pert["grad"],
                                        {"units": "1/s per unit of the parameter",
                                         "long_name": "first derivative of the growth rate"}),
            "perturbation_status": ("mode", pert["status"],
                                    {"flag_values": " ".join(str(i) for i in range(len(PERTURBATION_STATUS))),
                                     "flag_meanings": " ".join(PERTURBATION_STATUS)}),
            "coupling_ratio": ("mode", pert["ratio"],
                               {"units": "1", "long_name": "three-sigma coupling to the nearest eigenvalue "
                                f"(the estimate holds up to {COUPLING_MAX:g})"}),
        }
    if "montecarlo" in results:
        mc = results["montecarlo"]
        data |= {
            "parameter_value": (("sample", "parameter"), X, {"long_name": "sampled value (unit: parameter_unit)"}),
            "unstable": ("sample", mc["unstable"], {"long_name": "some mode in the band grows"}),
            "max_growth_rate": ("sample", mc["top"], {"units": "1/s", "long_name": "largest growth rate in the band"}),
            "sampled_growth_rate": (("sample", "mode"), mc["growth"],
                                    {"units": "1/s", "long_name": "growth rate of the nominal mode in the sample"}),
        }
    ci_method = {"montecarlo": "clopper-pearson", "perturbation": "bounds of the per-mode probabilities"}
    ds = xr.Dataset(
        data,
        coords={
            "estimator": ("estimator", np.array(methods, dtype=object)),
            "mode": ("mode", np.arange(m)),
            "parameter": ("parameter", np.array([p.name for p in unc], dtype=object)),
            "parameter_unit": ("parameter", np.array(units, dtype=object)),
            **({"sample": ("sample", np.arange(X.shape[0]))} if X is not None else {}),
        },
        attrs={
            "kind": "robust_margins",
            "title": "Robust margins: squeal propensity under parameter scatter",
            **attrs,
            "theta_deg": math.degrees(attrs["theta"]),
            "ci_method": json.dumps({meth: ci_method[meth] for meth in methods}),
            "coupling_max": COUPLING_MAX,
            "scatter": json.dumps([p.to_dict() for p in unc]),
            "model": model.to_json(),
            "model_kind": model.kind,
            "reference": "Nobari, Ouyang & Bannister, J. Sound Vib. 338 (2015): second-order perturbation of "
                         "complex eigenvalues; Clopper-Pearson interval of the Monte Carlo share",
            "squealkit_version": __version__,
        },
    )
    return ds
