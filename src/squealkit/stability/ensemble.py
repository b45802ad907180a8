"""Stability of many models at once: an ensemble of parameter sets (e.g. Monte Carlo samples).

:func:`~squealkit.stability.eigenvalues` sweeps one model over a grid. An ensemble stacks the
matrices of S models of the same size, shape ``(S, n, n)``, and one compiled call solves
every model along its own row of friction values; the critical friction of every model is
then bracketed on the grid and bisected, all models together, each step one call. Each
model's numbers depend only on that model, so any split of an ensemble into batches gives
identical results.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._threads import limit_threads, threads_for
from .._validation import InputError, validate_array_finite, validate_finite
from ..models import FrictionModel
from ._kernels import DIVERGENCE, FLUTTER, INDETERMINATE, quadratic_eigvals_stack
from ._solve import lapack_roots, solve_points
from .eigen import _KERNEL_MAX_DOF, UNSTABLE_RTOL, _perms

__all__ = ["ONSET_STATUS", "ModelEnsemble", "ensemble_onset", "ensemble_unstable"]

#: ``status`` codes of :func:`ensemble_onset`.
ONSET_STATUS = {0: "onset", 1: "unstable_at_start", 2: "stable_in_range"}
#: Bisection ends when the bracket is this narrow (absolute, in mu).
_ONSET_TOL = 1e-10


@dataclass(frozen=True)
class ModelEnsemble:
    """The matrices of S models with the same number of DOFs, stacked.

    Attributes
    ----------
    M, C, K0, Kn, Kf : ndarray, shape (S, n, n)
        Mass [kg], damping [N s/m] (zero for an undamped ensemble) and the structural,
        normal-contact and friction parts of the stiffness [N/m] (paper, eq. 4).
    sliding : ndarray of int, shape (S,)
        Sliding direction of each model.
    """

    M: NDArray[np.float64]
    C: NDArray[np.float64]
    K0: NDArray[np.float64]
    Kn: NDArray[np.float64]
    Kf: NDArray[np.float64]
    sliding: NDArray[np.int64]

    @classmethod
    def from_models(cls, models: Sequence[FrictionModel], *, damped: bool = False) -> ModelEnsemble:
        """Stack the matrices of ``models`` (``damped=False`` zeroes C, as in paper eq. 7).

        Examples
        --------
        >>> from squealkit.models import Hoffmann2002
        >>> ens = ModelEnsemble.from_models([Hoffmann2002(k3=k) for k in (7e5, 8e5, 9e5)])
        >>> len(ens), ens.K0.shape
        (3, (3, 2, 2))
        """
        models = list(models)
        if not models:
            raise InputError("An ensemble needs at least one model.")
        n = models[0].n_dof
        if any(m.n_dof != n for m in models):
            raise InputError("All models of an ensemble must have the same number of DOFs.")
        M = np.stack([m.mass_matrix() for m in models]).astype(float)
        C = np.stack([m.damping_matrix() for m in models]).astype(float) if damped else np.zeros_like(M)
        parts = [m.stiffness_parts() for m in models]
        K0, Kn, Kf = (np.stack([p[i] for p in parts]).astype(float) for i in range(3))
        sliding = np.array([m.sliding_direction for m in models], dtype=np.int64)
        return cls(M, C, K0, Kn, Kf, sliding)

    def __len__(self) -> int:
        return self.M.shape[0]

    @property
    def n_dof(self) -> int:
        return self.M.shape[-1]

    def take(self, index: ArrayLike) -> ModelEnsemble:
        """The sub-ensemble of the models at ``index``."""
        i = np.asarray(index)
        return ModelEnsemble(self.M[i], self.C[i], self.K0[i], self.Kn[i], self.Kf[i], self.sliding[i])


def _verdict_rows(ens: ModelEnsemble, mu: NDArray, tan_theta: float) -> NDArray[np.int8]:
    """Verdict code of model s at mu[s, p] (shape (S, P)); that of ``stability_verdict``."""
    S, P = mu.shape
    n = ens.n_dof
    g = np.ascontiguousarray(1.0 - mu * tan_theta)
    e = np.ascontiguousarray(ens.sliding[:, None] * (mu + tan_theta))
    mats = tuple(np.ascontiguousarray(a) for a in (ens.M, ens.C, ens.K0, ens.Kn, ens.Kf))
    which = np.repeat(np.arange(S, dtype=np.int64), P)
    if n > _KERNEL_MAX_DOF:
        K = ens.K0[:, None] + g[..., None, None] * ens.Kn[:, None] + e[..., None, None] * ens.Kf[:, None]
        shape = (S, P, n, n)
        roots, radii = lapack_roots(np.broadcast_to(ens.M[:, None], shape).reshape(-1, n, n),
                                    np.broadcast_to(ens.C[:, None], shape).reshape(-1, n, n), K.reshape(-1, n, n))
        even = None
    else:
        roots = np.empty((S, P, 2 * n), dtype=np.complex128)
        radii = np.empty((S, P, 2 * n))
        even = np.empty((S, P), dtype=np.bool_)
        perms, signs = _perms(n)
        quadratic_eigvals_stack(*mats, g, e, perms, signs, roots, radii, even)
        even = even.reshape(-1)
    _, _, verdict, _ = solve_points(*mats, which, g.reshape(-1), e.reshape(-1),
                                    np.ascontiguousarray(roots.reshape(S * P, 2 * n)),
                                    np.ascontiguousarray(radii.reshape(S * P, 2 * n)), even, UNSTABLE_RTOL)
    return verdict.reshape(S, P)


def _unstable_rows(ens: ModelEnsemble, mu: NDArray, tan_theta: float) -> NDArray[np.bool_]:
    """Whether model s is unstable (flutter, divergence, or indeterminate: never reported
    stable without proof) at mu[s, p]."""
    with limit_threads(threads_for(mu.size)):  # a bisection step of a few models: serial
        v = _verdict_rows(ens, mu, tan_theta)
    return (v == FLUTTER) | (v == DIVERGENCE) | (v == INDETERMINATE)


def _grid(mu: ArrayLike) -> NDArray[np.float64]:
    mu_a = np.atleast_1d(validate_array_finite("mu", mu)).astype(float)
    if mu_a.ndim != 1 or mu_a.size < 1:
        raise InputError("Parameter mu must be a number or a 1-D grid.")
    if mu_a.size > 1 and not np.all(np.diff(mu_a) > 0):
        raise InputError("Parameter mu must be a strictly increasing grid (START < STOP).")
    return mu_a


def _slope(tan_theta: float) -> float:
    return validate_finite("tan_theta", tan_theta)


def ensemble_unstable(ens: ModelEnsemble, mu: ArrayLike, tan_theta: float = 0.0) -> NDArray[np.bool_]:
    """Which models are unstable at each friction coefficient (paper eqs. 7-8).

    The criterion is that of :func:`~squealkit.stability.eigenvalues` and
    :func:`~squealkit.stability.unstable_threshold`: some mode with
    ``sigma > 1e-9 |lambda|_max``.

    Parameters
    ----------
    ens : ModelEnsemble
        S models.
    mu : array_like, shape (P,)
        Friction coefficients, strictly increasing.
    tan_theta : float
        Run-out slope tan(theta), the same for all models.

    Returns
    -------
    ndarray of bool, shape (S, P)

    Examples
    --------
    >>> from squealkit.models import Hoffmann2002
    >>> ens = ModelEnsemble.from_models([Hoffmann2002()])     # flutter above mu = 0.2165
    >>> ensemble_unstable(ens, [0.1, 0.2, 0.3]).tolist()
    [[False, False, True]]
    """
    mu_a = _grid(mu)
    t = _slope(tan_theta)
    return _unstable_rows(ens, np.broadcast_to(mu_a, (len(ens), mu_a.size)), t)


def ensemble_onset(
    ens: ModelEnsemble,
    mu: ArrayLike,
    tan_theta: float = 0.0,
    *,
    unstable: NDArray[np.bool_] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Critical friction of every model: the lowest mu of the grid's range that is unstable.

    The first unstable grid point brackets the onset; bisection on the stability flag then
    narrows the bracket to 1e-10, all models together (a fixed number of steps set by the
    grid, so a model's result never depends on the others). As for
    :func:`~squealkit.stability.critical_friction`, the stable end of the bracket is
    returned. An unstable window narrower than the grid spacing can be missed.

    Parameters
    ----------
    ens : ModelEnsemble
    mu : array_like, shape (P,)
        Strictly increasing friction grid; the search range is ``[mu[0], mu[-1]]``.
    tan_theta : float
        Run-out slope.
    unstable : ndarray of bool, shape (S, P), optional
        :func:`ensemble_unstable` on this grid, if already computed.

    Returns
    -------
    mu_critical : ndarray, shape (S,)
        The onset; ``mu[0]`` for a model unstable at the start of the range and ``mu[-1]``
        for one stable over the whole range (i.e. the onset clipped to the range).
    status : ndarray of int8, shape (S,)
        0 onset in the range, 1 unstable at ``mu[0]``, 2 stable over the range
        (:data:`ONSET_STATUS`).

    Examples
    --------
    Hoffmann's closed-form threshold (``Hoffmann2002.mu_critical_closed_form``):

    >>> from squealkit.models import Hoffmann2002
    >>> models = [Hoffmann2002(k3=k) for k in (7e5, 8e5, 9e5)]
    >>> mu_c, status = ensemble_onset(ModelEnsemble.from_models(models), np.linspace(0, 0.6, 13))
    >>> bool(np.allclose(mu_c, [m.mu_critical_closed_form() for m in models], atol=1e-10))
    True
    """
    mu_a = _grid(mu)
    t = _slope(tan_theta)
    S = len(ens)
    if unstable is None:
        unstable = ensemble_unstable(ens, mu_a, t)
    unstable = np.asarray(unstable, dtype=bool)
    if unstable.shape != (S, mu_a.size):
        raise InputError(f"unstable has shape {unstable.shape}; expected {(S, mu_a.size)}.")
    found = unstable.any(axis=1)
    first = np.argmax(unstable, axis=1)
    status = np.where(~found, 2, np.where(first == 0, 1, 0)).astype(np.int8)
    mu_c = np.where(status == 2, mu_a[-1], mu_a[0]).astype(float)
    idx = np.flatnonzero(status == 0)
    if idx.size:
        a = mu_a[first[idx] - 1]
        b = mu_a[first[idx]]
        sub = ens.take(idx)
        width = float(np.max(np.diff(mu_a)))
        steps = max(1, min(64, math.ceil(math.log2(width / _ONSET_TOL))))
        for _ in range(steps):
            mid = 0.5 * (a + b)
            unst = _unstable_rows(sub, mid[:, None], t)[:, 0]
            a = np.where(unst, a, mid)
            b = np.where(unst, mid, b)
        mu_c[idx] = a
    return mu_c, status
