"""The Monte Carlo estimate of :func:`~squealkit.design.robust_margins`: seeded samples of the parameters, each a
small dense eigenproblem of the (reduced) model, in batches that may run on a Dask cluster; the full-model
backward error of reduced eigenpairs; the Clopper-Pearson interval of the share of unstable samples."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy.linalg as sla
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .._validation import InputError
from ..uncertainty import UncertainParameter
from ._pencil import _in_band, _linear_matrices, _pencil, _state_eigvals, _threshold

#: Estimated Monte Carlo time [s] below which a given Dask client is not used: shipping the tasks
#: costs more than solving them here (a sample's eigen solve is about 25 (2n)^3 flops, at 1e10 flop/s).
_CLUSTER_MIN_SECONDS = 2.0


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


