"""The Monte Carlo estimate of :func:`~squealkit.design.robust_margins`: seeded samples of the parameters, each a
small dense eigenproblem of the (reduced) model, in batches that may run on a Dask cluster.

Per sample:

- whether some mode in the band grows (the system's verdict: no mode identity needed);
- each nominal mode's eigenvalue in the sample, the modes matched by ONE assignment
  (``scipy.optimize.linear_sum_assignment``) of least total cost ``1 - MAC + |lambda_0 - lambda| / |lambda_0|``:
  the shape decides, the eigenvalue breaks ties (as :class:`~squealkit.solvers.mac.MacTracker`). By the
  eigenvalue alone, a near-degenerate pair (a brake disc's doublet) whose frequencies cross in a sample swaps
  its two modes. A match that a swap with another candidate would change by less than
  :data:`_AMBIGUOUS` (in units of ``1 - MAC``) is *ambiguous*: two candidates of near-equal score, as in a
  doublet whose two shapes the scatter mixes half and half. Its growth rate is then NaN, not a pick; its
  stability verdict stands only if every near-equal candidate has the same one;
- for a reduced FE model, the largest full-model backward error of the band's eigenpairs, from the basis'
  residual factor (no full-size product: a small fraction of the sample's eigen solve), so every sample is
  checked, not a subset.

The interval of the share of unstable samples is the Clopper-Pearson (exact binomial) one.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .._validation import InputError
from ..solvers.mac import mac
from ..uncertainty import UncertainParameter
from ._pencil import _in_band, _linear_matrices, _state_eig, _threshold

#: Estimated Monte Carlo time [s] below which a given Dask client is not used: shipping the tasks
#: costs more than solving them here (a sample's eigen solve is about 25 (2n)^3 flops, at 1e10 flop/s).
_CLUSTER_MIN_SECONDS = 2.0
#: A match is ambiguous when giving it to another candidate (or swapping it with another mode's) costs less
#: than this, in units of ``1 - MAC``: MACs of about 0.55 and 0.45 to the two members of a pair.
_AMBIGUOUS = 0.2


def _match_modes(lam0: NDArray, X0: NDArray, lam: NDArray, X: NDArray) -> tuple[NDArray, NDArray]:
    """Match nominal modes to a sample's by shape and eigenvalue, with the near-equal alternatives.

    Parameters
    ----------
    lam0 : ndarray, shape (m,)
        Nominal eigenvalues [1/s].
    X0 : ndarray, shape (n, m)
        Their unit eigenvectors.
    lam : ndarray, shape (c,)
        The sample's candidate eigenvalues [1/s].
    X : ndarray, shape (n, c)
        Their unit eigenvectors (in the same coordinates: a reduced model's, where the MAC is the full
        model's because the basis is orthonormal).

    Returns
    -------
    cols : ndarray of int, shape (m,)
        The candidate of each nominal mode (-1: none left, fewer candidates than modes).
    alternatives : ndarray of bool, shape (m, c)
        ``[k, j]``: candidate ``j`` (not ``cols[k]``) scores within :data:`_AMBIGUOUS` of the match
        (a free candidate by its own cost, another mode's by the cost of the swap); a row with any True
        is an ambiguous match.
    """
    m, c = lam0.size, lam.size
    cols = np.full(m, -1, dtype=np.intp)
    alternatives = np.zeros((m, c), dtype=bool)
    if m == 0 or c == 0:
        return cols, alternatives
    from scipy.optimize import linear_sum_assignment

    with np.errstate(invalid="ignore", divide="ignore"):
        cost = (1.0 - mac(X0, X)) + np.abs(lam0[:, None] - lam[None, :]) / np.maximum(np.abs(lam0[:, None]), 1e-300)
    cost = np.where(np.isfinite(cost), cost, 1e300)
    rows, picked = linear_sum_assignment(cost)
    cols[rows] = picked
    done = cols >= 0
    own = np.where(done, cost[np.arange(m), np.maximum(cols, 0)], np.inf)
    alternatives = cost - own[:, None] < _AMBIGUOUS  # a free candidate nearly as good
    taken = cols[done]
    alternatives[:, taken] = False
    if taken.size > 1:  # another mode's candidate: the cost of swapping the two matches
        D = cost[np.ix_(done, taken)]
        swap = D + D.T - own[done][:, None] - own[done][None, :]
        np.fill_diagonal(swap, np.inf)
        sub = alternatives[done]
        sub[:, taken] = swap < _AMBIGUOUS
        alternatives[done] = sub
    return cols, alternatives


def _mc_chunk(task: tuple) -> dict[str, NDArray]:
    """One batch of samples (a Dask task): ``unstable`` and ``top`` (the largest growth rate in the band) per
    sample; per sample and nominal mode the matched eigenvalue (NaN where ambiguous), ``ambiguous`` and
    ``verdict`` (1 unstable, 0 stable, -1 indeterminate); ``residual`` per sample (NaN: not checked)."""
    builder, payload, X, lam0, X0, tol0, lo, hi, gamma, check = task
    # many small eigen solves: serial BLAS (threads on 2 busy cores: 12x slower, measured at 2r = 272)
    with threadpool_limits(1, user_api="blas"):
        lam, vec = _state_eig(builder(payload, X), gamma)
    S, m = X.shape[0], lam0.size
    band = _in_band(lam, lo, hi)
    tol = _threshold(lam)
    growth = np.where(band, lam.real, -np.inf)
    out = {"unstable": np.any(growth > tol[:, None], axis=1), "top": growth.max(axis=1, initial=-np.inf),
           "matched": np.full((S, m), np.nan + 0j), "ambiguous": np.zeros((S, m), dtype=bool),
           "verdict": np.full((S, m), -1, dtype=np.int8), "residual": np.full(S, np.nan)}
    for s in range(S):
        cand = np.flatnonzero(np.isfinite(lam[s]) & (lam[s].imag >= 0))
        if check is not None:
            out["residual"][s] = _sample_residual(check, X[s], lam[s], vec[s], band[s])
        if cand.size == 0:
            out["ambiguous"][s] = True
            continue
        cols, alt = _match_modes(lam0, X0, lam[s, cand], vec[s][:, cand])
        found = cols >= 0
        grows = lam[s, cand].real > tol0
        ambiguous = alt.any(axis=1)
        agree = ~np.any(alt & (grows[None, :] != grows[np.maximum(cols, 0)][:, None]), axis=1)
        out["matched"][s, found & ~ambiguous] = lam[s, cand[cols[found & ~ambiguous]]]
        out["ambiguous"][s] = ambiguous | ~found
        out["verdict"][s] = np.where(found & agree, grows[np.maximum(cols, 0)], -1)
    return out


def _sample_residual(check: tuple, row: NDArray, lam: NDArray, x: NDArray, keep: NDArray) -> float:
    """Largest full-model backward error of the pairs ``keep`` of one sample: ``check = (reduced, factors, power,
    names)`` of :func:`~squealkit.design.robust._fe_setup` (the basis' residual factor: no full-size product)."""
    from ..solvers.reduction import _reduced_backward_error

    if not keep.any():
        return 0.0
    reduced, f, power, names = check
    scale = dict(zip(names, row, strict=True))
    coef = {name: (power[name], f[name] * scale.get(name, 1.0)) for name in reduced.order}
    return float(np.max(_reduced_backward_error(reduced, coef, lam[keep], x[:, keep])))


def _residual_check(setup: Mapping[str, Any], names: Sequence[str]) -> tuple | None:
    """The payload of :func:`_sample_residual` for an FE set-up (None for a small model: solved whole)."""
    if setup.get("reduced") is None:
        return None
    return setup["reduced"], setup["factors"], setup["power"], tuple(names)


def _nominal_residual(setup: Mapping[str, Any], names: Sequence[str], row: NDArray, gamma: float, lo: float,
                      hi: float) -> float:
    """Largest full-model backward error of the band's eigenpairs at the nominal row."""
    lam, x = _state_eig(_linear_matrices(setup["payload"], row[None]), gamma)
    return _sample_residual(_residual_check(setup, names), row, lam[0], x[0], _in_band(lam[0], lo, hi))


def _montecarlo(builder: Callable, payload: Any, X: NDArray, lam0: NDArray, X0: NDArray, tol0: float, lo: float,
                hi: float, gamma: float, check: tuple | None, batch_size: int, client: Any) -> dict[str, NDArray]:
    """:func:`_mc_chunk` over all samples, in batches of ``batch_size`` (on ``client`` when it pays)."""
    from ..scale import map_tasks

    starts = list(range(0, X.shape[0], batch_size))
    tasks = [(builder, payload, X[a:a + batch_size], lam0, X0, tol0, lo, hi, gamma, check) for a in starts]
    # small work never pays for a cluster: one batch, or seconds of work, run here
    n2 = 2 * np.shape(builder(payload, X[:1]))[-1]
    seconds = X.shape[0] * 25.0 * n2**3 / 1e10
    use = client if len(tasks) > 1 and seconds >= _CLUSTER_MIN_SECONDS else None
    parts: list[dict[str, NDArray]] = [{}] * len(tasks)
    for i, part in map_tasks(_mc_chunk, tasks, client=use, name="squealkit-robust-margins"):
        parts[i] = part
    return {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}


def _montecarlo_summary(mc: Mapping[str, NDArray], lam0: NDArray, confidence: float) -> dict[str, Any]:
    """Per mode: mean and standard deviation of the growth rate (NaN for a mode with an ambiguous match in some
    sample: its distribution is not defined), the share of samples in which it grows (NaN if a verdict is
    indeterminate); the system's share with its interval. Warns of ambiguous matches."""
    import math
    import warnings

    growth = mc["matched"].real
    verdict = mc["verdict"]
    samples = growth.shape[0]
    k = int(mc["unstable"].sum())
    with np.errstate(invalid="ignore"):
        probability = np.where(np.any(verdict < 0, axis=0), np.nan, np.mean(verdict == 1, axis=0))
    ambiguous = mc["ambiguous"].sum(axis=0)
    if ambiguous.any():
        bad = np.flatnonzero(ambiguous)
        which = "; ".join(f"the mode at {lam0[i].imag / (2 * math.pi):.6g} Hz in {ambiguous[i]}" for i in bad)
        warnings.warn(f"The Monte Carlo match of a nominal mode is ambiguous (two candidates of near-equal shape and "
                      f"eigenvalue: a near-degenerate pair whose shapes the scatter mixes) for {which} of {samples} "
                      "samples: its sampled growth rate there, its mean and its standard deviation are NaN "
                      "(indeterminate), and so is its probability where the candidates disagree on stability. The "
                      "system's propensity does not depend on the match.", UserWarning, stacklevel=4)
    return {"mean": growth.mean(axis=0), "std": growth.std(axis=0, ddof=1),
            "probability": probability, "propensity": k / samples, "ci": _clopper_pearson(k, samples, confidence),
            "unstable": mc["unstable"], "top": mc["top"], "growth": growth, "ambiguous": mc["ambiguous"],
            "residual": mc["residual"]}


def _clopper_pearson(k: int, n: int, confidence: float) -> tuple[float, float]:
    from scipy import stats

    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


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


