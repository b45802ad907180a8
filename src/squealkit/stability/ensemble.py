"""Stability of many models at once: an ensemble of parameter sets (e.g. Monte Carlo samples).

:func:`~squealkit.stability.eigenvalues` sweeps one model over a grid. An ensemble stacks the
matrices of S models of the same size, shape ``(S, n, n)``, and one compiled call solves
every model along its own row of friction values; the critical friction of every model is
then bracketed on the grid and bisected, all models together, each step one call. Each
model's numbers depend only on that model, so any split of an ensemble into batches gives
identical results.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._deprecation import keyword_only
from .._threads import honour_thread_limit, limit_threads, threads_for
from .._validation import InputError, validate_array_finite, validate_finite
from ..models import FrictionModel
from ._verdicts import DIVERGENCE, FLUTTER, INDETERMINATE
from ._windows import ONSET_STATUS, SCAN_POINTS, find_windows
from .eigen import _TAN_THETA_WHY, _solve_models, check_magnitudes

#: Default relative width to which :func:`ensemble_onset` locates onsets that double
#: precision cannot decide.
ONSET_RTOL = 1e-6

__all__ = ["ONSET_STATUS", "ModelEnsemble", "ensemble_onset", "ensemble_unstable"]


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
    Knx, Kfx : ndarray, shape (S, n, n), optional
        Slope parts of the contact (consistent kinematics, ``FrictionModel.slope_parts``);
        None for the paper's kinematics.
    """

    M: NDArray[np.float64]
    C: NDArray[np.float64]
    K0: NDArray[np.float64]
    Kn: NDArray[np.float64]
    Kf: NDArray[np.float64]
    sliding: NDArray[np.int64]
    Knx: NDArray[np.float64] | None = None
    Kfx: NDArray[np.float64] | None = None

    @classmethod
    def from_models(cls, models: Sequence[FrictionModel], *, damped: bool = False) -> ModelEnsemble:
        """Stack the matrices of ``models`` (``damped=False`` zeroes C, as in paper eq. 7).

        Parameters
        ----------
        models : sequence of FrictionModel
            S models with the same number of DOFs.
        damped : bool, default False
            Keep each model's damping matrix.

        Returns
        -------
        ModelEnsemble

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
        check_magnitudes(M, C, K0, Kn, Kf)
        if not any(m.slope_coupled for m in models):
            return cls(M, C, K0, Kn, Kf, sliding)
        slope = [m.slope_parts() for m in models]
        Knx, Kfx = (np.stack([p[i] for p in slope]).astype(float) for i in range(2))
        return cls(M, C, K0, Kn, Kf, sliding, Knx, Kfx)

    def __len__(self) -> int:
        return self.M.shape[0]

    @property
    def n_dof(self) -> int:
        return self.M.shape[-1]

    def take(self, index: ArrayLike) -> ModelEnsemble:
        """The sub-ensemble of the models at ``index``.

        Parameters
        ----------
        index : array_like of int or bool
            Which models (any NumPy index along the first axis).

        Returns
        -------
        ModelEnsemble
        """
        i = np.asarray(index)
        slope = (None, None) if self.Knx is None else (self.Knx[i], self.Kfx[i])
        return ModelEnsemble(self.M[i], self.C[i], self.K0[i], self.Kn[i], self.Kf[i], self.sliding[i], *slope)

    def contact_parts(self, tan_theta: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(Kn(t), Kf(t))`` of every model at the slope ``tan_theta`` (see ``FrictionModel.contact_parts``).

        Parameters
        ----------
        tan_theta : float
            Run-out slope [1].

        Returns
        -------
        Kn, Kf : ndarray, shape (S, n, n)
        """
        if self.Knx is None:
            return self.Kn, self.Kf
        st = (self.sliding * tan_theta)[:, None, None]
        return self.Kn + st * self.Knx, self.Kf + st * self.Kfx


def _solve_rows(ens: ModelEnsemble, which: NDArray, mu: NDArray, tan_theta: NDArray | float,
                high_precision: bool = True) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """``(lam, err, verdict, thr)`` of model ``which[p]`` at ``mu[p]`` (flat arrays), as
    :func:`~squealkit.stability.eigen._solve_grid` does for one model."""
    which = np.ascontiguousarray(which, dtype=np.int64)
    mu = np.asarray(mu, dtype=float)
    g = np.ascontiguousarray(1.0 - mu * tan_theta)
    e = np.ascontiguousarray(ens.sliding[which] * (mu + tan_theta))
    mats = tuple(np.ascontiguousarray(a) for a in (ens.M, ens.C, ens.K0, *ens.contact_parts(tan_theta)))
    with limit_threads(threads_for(which.size)):  # a search step of a few models: serial
        return _solve_models(mats, which, g, e, high_precision)


def _verdict_rows(ens: ModelEnsemble, mu: NDArray, tan_theta: float) -> NDArray[np.int8]:
    """Verdict code of model s at mu[s, p] (shape (S, P)); that of ``stability_verdict``."""
    S, P = mu.shape
    which = np.repeat(np.arange(S, dtype=np.int64), P)
    return _solve_rows(ens, which, mu.reshape(-1), tan_theta)[2].reshape(S, P)


def _unstable_rows(ens: ModelEnsemble, mu: NDArray, tan_theta: float) -> NDArray[np.bool_]:
    """Whether model s is unstable (flutter, divergence, or indeterminate: never reported
    stable without proof) at mu[s, p]."""
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


@honour_thread_limit
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def ensemble_unstable(ens: ModelEnsemble, mu: ArrayLike, *, tan_theta: float = 0.0) -> NDArray[np.bool_]:
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


@honour_thread_limit
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def ensemble_onset(
    ens: ModelEnsemble,
    mu: ArrayLike,
    *,
    tan_theta: float = 0.0,
    rtol: float = ONSET_RTOL,
) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Critical friction of every model: the start of its first unstable window in the range.

    The search is that of :func:`~squealkit.stability.critical_friction` (a scan, a search of
    every near-coalescence and growth-rate peak, so windows narrower than the scan are not
    missed, then bisection to rounding level), all models together, each step one call; a
    model's result depends only on that model.

    Parameters
    ----------
    ens : ModelEnsemble
    mu : array_like, shape (P,)
        Strictly increasing friction grid; the search range is ``[mu[0], mu[-1]]`` (the
        scan has ``P`` points, at least 51 and at most 401).
    tan_theta : float
        Run-out slope.
    rtol : float
        Where double precision cannot decide the verdict (near a lock-in onset the roots
        are double, and rounding blurs the boundary over ~1e-8 to 1e-7 of mu), the onset is located
        to this width (relative to max(1, mu)) instead of deciding each point in exact arithmetic (about
        0.3 ms each). The default, 1e-6, is far below any parameter's uncertainty and makes
        a Monte Carlo sample several times cheaper (2048 samples of the paper's rig:
        0.9 s instead of 6.6 s of CPU time); 0 locates every onset exactly, as
        :func:`~squealkit.stability.critical_friction` does.

    Returns
    -------
    mu_critical : ndarray, shape (S,)
        The onset; NaN where it lies outside the range: below ``mu[0]`` (unstable at the
        start) or above ``mu[-1]`` (stable over the range: a censored sample).
    status : ndarray of int8, shape (S,)
        Codes of :data:`~squealkit.stability.ONSET_STATUS`: 0 onset in the range, 1
        unstable at ``mu[0]``, 2 stable over the range, 3 indeterminate (the first
        window's verdicts are all within rounding; ``mu_critical`` is its start).

    Examples
    --------
    Hoffmann's closed-form threshold (``Hoffmann2002.mu_critical_closed_form``):

    >>> from squealkit.models import Hoffmann2002
    >>> models = [Hoffmann2002(k3=k) for k in (7e5, 8e5, 9e5)]
    >>> mu_c, status = ensemble_onset(ModelEnsemble.from_models(models), np.linspace(0, 0.6, 13))
    >>> bool(np.allclose(mu_c, [m.mu_critical_closed_form() for m in models], rtol=0, atol=1e-6))
    True
    """
    mu_a = _grid(mu)
    t = _slope(tan_theta)
    rtol = validate_finite("rtol", rtol)
    if not 0.0 <= rtol < 1e-3:
        raise InputError(f"Parameter rtol={rtol!r} must lie in [0, 1e-3).")
    S = len(ens)

    def evaluate(rows: NDArray, x: NDArray, high_precision: bool = True):
        lam, _err, verdict, thr = _solve_rows(ens, rows, x, t, high_precision)
        return verdict, lam, thr

    scan = int(np.clip(mu_a.size, 51, SCAN_POINTS))
    win = find_windows(evaluate, np.full(S, mu_a[0]), np.full(S, mu_a[-1]), scan=scan, rounding_rtol=rtol,
                       first_only=True)
    near, _far, first_unstable = win.first(S)
    status = np.where(np.isfinite(near), np.where(first_unstable, 0, 3), 2).astype(np.int8)
    status[win.start_unstable] = 1
    mu_c = np.where((status == 0) | (status == 3), near, np.nan)
    return mu_c, status
