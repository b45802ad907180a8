"""Fit named model quantities to a campaign (step 4 of a correlation).

Objective (minimised)::

    J(q) = misses(q) + over_predictions(q) + misfit(q)

the number of applications the model gets wrong, plus ``misfit`` = the mean squared frequency
error of the matched components in units of the tolerance (below 1: it only breaks ties
between values that get the same applications right). ``J`` is piecewise constant in its
integer part, so with several quantities the optimiser is
:func:`scipy.optimize.differential_evolution` (derivative free, bounded, seeded by ``rng``),
started from the best point of a grid; with one quantity, a scan of the bounds refined by
bisection finds the minimum exactly (no optimiser needed).

The interval the data allows for a quantity is its *profile*: the values at which the
least number of wrong applications (the others re-fitted on a grid: 33 values for one other
quantity, 9 each for more, so a narrow valley of correlated quantities can make an interval
too short) equals the best fit's, contiguous
around the fit, its edges located by bisection. A quantity whose interval spans its whole
bounds is reported *unidentifiable* by this campaign (the data do not constrain it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from .._validation import InputError

__all__ = ["Calibration", "calibrate"]

#: Grid points of a profile scan, and bisection steps on each edge of an interval.
_PROFILE_POINTS = 41
_BISECT = 14


@dataclass(frozen=True)
class Calibration:
    """Fitted quantities with the intervals the campaign allows.

    Attributes
    ----------
    values : dict of str to float
        Best fit of each quantity.
    intervals : dict of str to (float, float)
        Values each quantity may take with as few wrong applications as the best fit (profile).
    bounds : dict of str to (float, float)
        The bounds searched.
    unidentifiable : tuple of str
        Quantities whose interval spans their bounds (the data do not constrain them).
    objective : str
        What was minimised.
    before, after : dict
        Counts (``hits``, ``misses``, ``over_predictions``, ``quiet``) and ``objective`` at the
        starting values and at the fit.
    start : dict of str to float
        The starting values (the model's and the condition map's).
    profiles : xarray.Dataset
        Per quantity ``q_NAME``: the scan (``value_NAME``, ``wrong_NAME``: applications wrong).
    """

    values: dict[str, float]
    intervals: dict[str, tuple[float, float]]
    bounds: dict[str, tuple[float, float]]
    unidentifiable: tuple[str, ...]
    objective: str
    before: dict[str, float]
    after: dict[str, float]
    start: dict[str, float]
    profiles: xr.Dataset

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``{NAME: {value, interval, bounds, identifiable}}`` and the rest.

        Returns
        -------
        dict
        """
        return {
            "quantities": {k: {"value": v, "interval": list(self.intervals[k]), "bounds": list(self.bounds[k]),
                               "identifiable": k not in self.unidentifiable, "start": self.start.get(k)}
                           for k, v in self.values.items()},
            "objective": self.objective, "before": self.before, "after": self.after,
            "unidentifiable": list(self.unidentifiable),
        }


OBJECTIVE = ("misses + over_predictions + mean squared frequency error of the matched components in tolerances "
             "(< 1, a tie-breaker)")


def parse_fit(items: Any) -> dict[str, tuple[float, float]]:
    """``NAME=LO:HI`` strings (or a mapping NAME -> (lo, hi)) into bounds, checked.

    Parameters
    ----------
    items : iterable of str or mapping
        E.g. ``["mu_offset=-0.2:0.2", "damping_scale=0.5:2"]``.

    Returns
    -------
    dict of str to (float, float)

    Raises
    ------
    InputError
        For an item that is not ``NAME=LO:HI`` with finite ``LO < HI``.
    """
    out: dict[str, tuple[float, float]] = {}
    pairs = items.items() if isinstance(items, Mapping) else [(None, x) for x in items]
    for name, spec in pairs:
        if name is None:
            if not isinstance(spec, str) or "=" not in spec:
                raise InputError(f"--fit {spec!r} must be NAME=LO:HI, e.g. mu_offset=-0.2:0.2.")
            name, _, text = spec.partition("=")
            name = name.strip()
            parts = text.split(":")
            if len(parts) != 2:
                raise InputError(f"--fit {spec!r} must be NAME=LO:HI, e.g. mu_offset=-0.2:0.2.")
            try:
                lo, hi = float(parts[0]), float(parts[1])
            except ValueError:
                raise InputError(f"--fit {spec!r}: LO and HI must be numbers.") from None
        else:
            try:
                lo, hi = (float(x) for x in spec)
            except (TypeError, ValueError):
                raise InputError(f"fit[{name!r}]={spec!r} must be (lo, hi).") from None
        if not name:
            raise InputError(f"--fit {spec!r} has no NAME.")
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise InputError(f"--fit {name}: bounds {lo:g}:{hi:g} must be finite with LO < HI.")
        out[str(name)] = (lo, hi)
    if not out:
        raise InputError("Nothing to fit: give at least one NAME=LO:HI.")
    return out


def _score(evaluate: Callable[[dict[str, float]], Any], values: dict[str, float]) -> tuple[float, int, dict]:
    m = evaluate(values)
    wrong = int(m.attrs["misses"] + m.attrs["over_predictions"])
    return wrong + min(float(m.attrs["frequency_misfit"]), 0.999), wrong, m


def _counts(m: Any, j: float) -> dict[str, float]:
    return {k: int(m.attrs[k]) for k in ("hits", "misses", "over_predictions", "quiet")} | {"objective": j}


#: Points per free quantity of the grid on which the others are re-fitted along a profile.
_REFIT_POINTS = 9


def _fit_others(evaluate, names, bounds, fixed: dict[str, float], rng, start: dict[str, float], *,
                search: bool = False):
    """Best J over the quantities not in ``fixed``, with them fixed: on a grid of
    :data:`_REFIT_POINTS` per free quantity (a profile point), or with ``search`` by
    differential evolution started from the best of that grid (the fit)."""
    free = [n for n in names if n not in fixed]
    if not free:
        j, w, _ = _score(evaluate, dict(fixed))
        return j, w, dict(fixed)
    import itertools

    best = (math.inf, 0, dict(fixed))
    # one other quantity: a fine grid (correlated quantities leave a narrow valley); more: a coarse one
    points = 4 * (_REFIT_POINTS - 1) + 1 if len(free) == 1 else _REFIT_POINTS
    axes = [np.linspace(*bounds[n], points) for n in free]
    for combo in itertools.product(*axes):
        vals = {**fixed, **dict(zip(free, map(float, combo), strict=True))}
        j, w, _ = _score(evaluate, vals)
        if j < best[0]:
            best = (j, w, vals)
    if not search:
        return best
    from scipy.optimize import differential_evolution

    def f(x):
        return _score(evaluate, {**fixed, **dict(zip(free, x, strict=True))})[0]

    x0 = np.array([best[2][n] for n in free])
    r = differential_evolution(f, [bounds[n] for n in free], seed=rng, polish=False, maxiter=12, popsize=6,
                               tol=0.0, x0=x0, init="sobol")
    vals = {**fixed, **dict(zip(free, map(float, r.x), strict=True))}
    j, w, _ = _score(evaluate, vals)
    return (j, w, vals) if j <= best[0] else best


def calibrate(evaluate: Callable[[dict[str, float]], Any], bounds: Mapping[str, tuple[float, float]],
              start: Mapping[str, float], *, rng: np.random.Generator | None = None) -> Calibration:
    """Fit quantities within bounds to a campaign, with the interval each may take (profile).

    Parameters
    ----------
    evaluate : callable
        ``evaluate(values) -> xarray.Dataset`` with attributes ``misses``, ``over_predictions``,
        ``hits``, ``quiet`` and ``frequency_misfit`` (:func:`~squealkit.correlate.match.match_modes`
        of the model with ``values`` applied).
    bounds : mapping of str to (float, float)
        Quantity name -> (lo, hi).
    start : mapping of str to float
        Starting (current) value of each quantity.
    rng : numpy.random.Generator, optional
        Seeds the optimiser (default: seed 0, reproducible).

    Returns
    -------
    Calibration
    """
    rng = np.random.default_rng(0) if rng is None else rng
    names = list(bounds)
    start = {n: float(start[n]) for n in names}
    j0, _, m0 = _score(evaluate, start)
    before = _counts(m0, j0)
    profiles: dict[str, Any] = {}
    grids: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    # profile scans first: with one quantity they are the fit
    for n in names:
        lo, hi = bounds[n]
        grid = np.linspace(lo, hi, _PROFILE_POINTS if len(names) == 1 else 21)
        js, ws = np.empty(grid.size), np.empty(grid.size, dtype=int)
        for i, v in enumerate(grid):
            js[i], ws[i], _ = _fit_others(evaluate, names, bounds, {n: float(v)}, rng, start)
        grids[n] = (grid, js, ws)
    if len(names) == 1:
        n = names[0]
        grid, js, ws = grids[n]
        i = int(np.argmin(js))
        best = {n: float(grid[i])}
    else:
        _, _, best = _fit_others(evaluate, names, bounds, {}, rng, start, search=True)
        # a profile grid point may beat the optimiser: take the best seen
        for n in names:
            grid, js, ws = grids[n]
            i = int(np.argmin(js))
            if js[i] < _score(evaluate, best)[0]:
                best = _fit_others(evaluate, names, bounds, {n: float(grid[i])}, rng, start)[2]
    j1, w1, m1 = _score(evaluate, best)
    intervals: dict[str, tuple[float, float]] = {}
    unident = []
    bisect = _BISECT if len(names) == 1 else 6
    for n in names:
        grid, js, ws = grids[n]
        wmin = min(int(ws.min()), w1)
        ok = ws <= wmin
        k = int(np.argmin(np.abs(grid - best[n])))
        if not ok[k]:  # the fit between grid points: the nearest grid point that is as good
            cand = np.flatnonzero(ok)
            k = int(cand[np.argmin(np.abs(grid[cand] - best[n]))]) if cand.size else k
        a = b = k
        while a > 0 and ok[a - 1]:
            a -= 1
        while b < grid.size - 1 and ok[b + 1]:
            b += 1

        def good(v: float, n: str = n, wmin: int = wmin) -> bool:
            return _fit_others(evaluate, names, bounds, {n: v}, rng, start)[1] <= wmin

        lo_v = float(grid[a])
        if a > 0:  # bisection between the last bad and the first good grid point
            bad_v, good_v = float(grid[a - 1]), lo_v
            for _ in range(bisect):
                mid = 0.5 * (bad_v + good_v)
                bad_v, good_v = (bad_v, mid) if good(mid) else (mid, good_v)
            lo_v = good_v
        hi_v = float(grid[b])
        if b < grid.size - 1:
            good_v, bad_v = hi_v, float(grid[b + 1])
            for _ in range(bisect):
                mid = 0.5 * (bad_v + good_v)
                good_v, bad_v = (mid, bad_v) if good(mid) else (good_v, mid)
            hi_v = good_v
        # (the re-fit on a grid can miss a narrow valley: the fit itself is always allowed)
        intervals[n] = (min(lo_v, best[n]), max(hi_v, best[n]))
        if a == 0 and b == grid.size - 1:
            unident.append(n)
        if len(names) == 1 and lo_v <= best[n] <= hi_v:
            best[n] = 0.5 * (lo_v + hi_v) if n in unident else best[n]
        profiles[f"value_{n}"] = (f"q_{n}", grid)
        profiles[f"wrong_{n}"] = (f"q_{n}", ws, {"long_name": "applications wrong (others re-fitted)"})
    if len(names) == 1:
        # the centre of the interval when the objective is flat across it (no frequency information)
        n = names[0]
        j_c, _, _ = _score(evaluate, {n: 0.5 * sum(intervals[n])})
        if n not in unident and j_c <= j1:
            best = {n: 0.5 * sum(intervals[n])}
        j1, w1, m1 = _score(evaluate, best)
    return Calibration(values={n: float(best[n]) for n in names}, intervals=intervals,
                       bounds={n: tuple(map(float, bounds[n])) for n in names}, unidentifiable=tuple(unident),
                       objective=OBJECTIVE, before=before, after=_counts(m1, j1), start=start,
                       profiles=xr.Dataset(profiles))
