"""Every unstable window along a one-parameter path through the stability map.

Used by :func:`~squealkit.stability.critical_friction` (path: friction mu at a fixed slope),
:func:`~squealkit.stability.runout_tolerance` (path: slope at a fixed mu) and
:func:`~squealkit.stability.ensemble_onset` (path: mu, one row per model). All rows of a
batch are searched together, each step one vectorised eigenvalue call:

1. **Scan.** ``scan`` points from ``x0`` to ``x1`` per row, in one call.
2. **Candidates.** A window narrower than the scan spacing leaves no unstable scan point,
   but it announces itself on the stable points around it: two modes that lock in come
   close in frequency first (the gap between frequency-adjacent eigenvalues, or between a
   root and its conjugate for divergence, has a local minimum), and a damped mode that
   crosses the axis rises first (the largest growth rate has a local maximum). Every such
   resolved local extremum of the scan is a candidate. Likewise a stable gap narrower than
   the scan spacing between two windows (flutter and flutter, or flutter and divergence)
   announces itself on the unstable points around it: the largest growth rate has a local
   minimum there.
3. **Golden-section search** of each candidate's indicator on the two scan intervals around
   it, all candidates together; a point it visits that is not stable (for a gap candidate:
   that is stable) is a sample inside a window (a gap).
4. **Bisection** of every change between stable and not stable among the sorted samples,
   all brackets together, to 1e-13 relative.

A window's points are ``unstable`` (flutter or divergence) or, where no solver can decide
within the rounding of the model's own numbers, ``indeterminate``; a window whose samples
are all indeterminate is reported as such, never as stable.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ._verdicts import DIVERGENCE, FLUTTER, INDETERMINATE, STABLE

#: ``evaluate(rows, x, high_precision=True) -> (verdict, lam, thr)``: the verdict code, the
#: modes (P, n) and the growth-rate threshold of row ``rows[p]`` at path parameter ``x[p]``;
#: without ``high_precision`` what LAPACK cannot decide comes back indeterminate.
Evaluator = Callable[[NDArray[np.int64], NDArray[np.float64]], tuple[NDArray, NDArray, NDArray]]

#: Outcome of an onset search along a path, by code; one vocabulary for
#: :func:`~squealkit.stability.critical_friction`, ensembles and Monte Carlo.
#: ``unstable_at_start``: not stable at the path's start (mu = 0 for ``critical``: unstable
#: without friction); ``stable_in_range``: no onset up to the path's end (a censored
#: sample); ``indeterminate``: the first window's verdicts are all within rounding.
ONSET_STATUS = ("onset", "unstable_at_start", "stable_in_range", "indeterminate")

#: Default scan points per row.
SCAN_POINTS = 401
#: Candidates refined per row at most (the most pronounced extrema first).
_MAX_CANDIDATES = 24
_GOLDEN_STEPS = 60
_BISECT_STEPS = 64
#: Bisection ends when a bracket is this narrow, relative to max(1, |x|): far below any
#: physical meaning, and above the ~1e-15 where every step near a lock-in point would
#: need the 50-digit solver.
_BISECT_RTOL = 1e-13
#: By default a bisection point that double precision cannot decide is decided exactly
#: (about 0.3 ms); with ``rounding_rtol`` > 0 it ends its bracket instead once the bracket
#: is narrower than that (relative), the boundary then being known to about that.
_ROUNDING_RTOL = 0.0
#: A local extremum of an indicator (relative to |lambda|_max) counts when it is deeper than this.
_DEPTH = 1e-8
_INV_PHI = (np.sqrt(5.0) - 1.0) / 2.0


@dataclass(frozen=True)
class Windows:
    """Result of :func:`find_windows` for B rows.

    Attributes
    ----------
    start_unstable : ndarray of bool, shape (B,)
        Whether the path's first point ``x0`` is not stable.
    row, near, far : ndarray, shape (W,)
        One entry per window, rows ascending and windows in path order within a row: the
        window runs from ``near`` to ``far`` along the path. An end not followed by a
        stable point is the path's end (or start).
    unstable : ndarray of bool, shape (W,)
        True when some point of the window is unstable for sure (flutter or divergence);
        False when all its points are indeterminate.
    """

    start_unstable: NDArray[np.bool_]
    row: NDArray[np.int64]
    near: NDArray[np.float64]
    far: NDArray[np.float64]
    unstable: NDArray[np.bool_]

    def of_row(self, b: int) -> list[tuple[float, float, bool]]:
        """The windows of row ``b`` as ``(low, high, unstable)``, ascending in value."""
        sel = np.flatnonzero(self.row == b)
        out = [(float(min(self.near[i], self.far[i])), float(max(self.near[i], self.far[i])),
                bool(self.unstable[i])) for i in sel]
        return sorted(out)

    def first(self, n_rows: int) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """Per row, the first window's ``(near end, far end, unstable)``, NaN where none.

        ``near end`` is the end met first along the path.
        """
        near = np.full(n_rows, np.nan)
        far = np.full(n_rows, np.nan)
        unst = np.zeros(n_rows, dtype=bool)
        rows, idx = np.unique(self.row, return_index=True)
        if rows.size:
            near[rows] = self.near[idx]
            far[rows] = self.far[idx]
            unst[rows] = self.unstable[idx]
        return near, far, unst


def _indicators(lam: NDArray, thr: NDArray) -> NDArray[np.float64]:
    """Per point, quantities that have a local minimum next to a window (P, n + 1).

    Column 0: minus the growth margin ``max sigma - thr``; column 1: twice the lowest
    frequency (the gap to its own conjugate: divergence); then the gaps between
    frequency-adjacent modes (lock-in); the last column is the growth margin itself (its
    local minimum among unstable points announces a stable gap). All relative to |lambda|_max.
    """
    scale = np.max(np.abs(lam), axis=-1)
    scale = np.where(scale > 0, scale, 1.0)
    order = np.lexsort((lam.real, lam.imag), axis=-1)
    s = np.take_along_axis(lam, order, axis=-1)
    cols = [-(np.max(lam.real, axis=-1) - thr), 2.0 * np.abs(s[:, 0].imag)]
    cols.extend(np.abs(s[:, 1:] - s[:, :-1]).T)
    cols.append(-cols[0])
    return np.stack(cols, axis=-1) / scale[:, None]


#: Scan points per batch of rows: bounds the memory of a search over very many rows.
_BATCH_POINTS = 1 << 20


def find_windows(evaluate: Evaluator, x0: NDArray, x1: NDArray, *, scan: int = SCAN_POINTS,
                 rounding_rtol: float = _ROUNDING_RTOL, first_only: bool = False) -> Windows:
    """All windows where the system is not stable on the paths ``x0[b] -> x1[b]``.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(rows, x) -> (verdict, lam, thr)`` for flat arrays ``rows``, ``x``.
    x0, x1 : ndarray, shape (B,)
        Start and end of each row's path (``x1 < x0`` searches downwards).
    scan : int
        Scan points per row (>= 3).
    rounding_rtol : float
        Accept a boundary to this relative width where double precision cannot decide
        (0: always decide, exactly).
    first_only : bool
        Only the first window of each row is wanted (an onset): candidates past the first
        scan point that is not stable are not searched, and the first window's far end is
        its last sample that is not stable, not a located boundary.
    """
    x0 = np.asarray(x0, dtype=float)
    x1 = np.asarray(x1, dtype=float)
    B = x0.shape[0]
    N = max(3, int(scan))
    rows_per = max(1, _BATCH_POINTS // N)
    if B <= rows_per:
        return _find_windows(evaluate, x0, x1, N, rounding_rtol, first_only)
    parts = []
    for a in range(0, B, rows_per):
        b = min(B, a + rows_per)

        def sub(rows, x, high_precision=True, a=a):
            return evaluate(rows + a, x, high_precision=high_precision)

        w = _find_windows(sub, x0[a:b], x1[a:b], N, rounding_rtol, first_only)
        parts.append(Windows(w.start_unstable, w.row + a, w.near, w.far, w.unstable))
    return Windows(*(np.concatenate([getattr(w, f) for w in parts])
                     for f in ("start_unstable", "row", "near", "far", "unstable")))


def _find_windows(evaluate: Evaluator, x0: NDArray, x1: NDArray, N: int, rounding_rtol: float,
                  first_only: bool) -> Windows:
    """:func:`find_windows` for one batch of rows."""
    B = x0.shape[0]
    u = np.linspace(0.0, 1.0, N)
    xs = x0[:, None] + (x1 - x0)[:, None] * u[None, :]
    rows = np.repeat(np.arange(B, dtype=np.int64), N)
    verdict, lam, thr = evaluate(rows, xs.ravel())
    verdict = verdict.reshape(B, N)
    ind = _indicators(lam, thr).reshape(B, N, -1)

    # 2. candidates: resolved local minima of an indicator with three stable points around
    mid, left, right = ind[:, 1:-1], ind[:, :-2], ind[:, 2:]
    depth = np.maximum(left, right) - mid
    stable3 = (verdict[:, :-2] == STABLE) & (verdict[:, 1:-1] == STABLE) & (verdict[:, 2:] == STABLE)
    uns = (verdict == FLUTTER) | (verdict == DIVERGENCE)
    unstable3 = uns[:, :-2] & uns[:, 1:-1] & uns[:, 2:]
    around = np.repeat(stable3[..., None], ind.shape[-1], axis=-1)
    around[..., -1] = unstable3  # the growth margin's minimum among unstable points: a stable gap?
    is_min = (mid <= left) & (mid <= right) & (depth > _DEPTH) & around
    # the most pronounced (relative depth) first, at most _MAX_CANDIDATES per row
    score = np.full(depth.shape, -1.0)
    np.divide(depth, np.abs(mid) + depth, out=score, where=is_min)  # depth > 0 where is_min
    flat = score.reshape(B, -1)
    k = min(_MAX_CANDIDATES, flat.shape[1])
    top = np.argsort(-flat, axis=1)[:, :k]
    keep = np.take_along_axis(flat, top, axis=1) > 0
    cb, cj = np.nonzero(keep)
    pos = top[cb, cj]
    ci = pos // ind.shape[-1] + 1  # scan index of the candidate
    ck = pos % ind.shape[-1]  # indicator
    # a stable gap between the last two (first two) scan points: the growth margin falls to the end
    g = ind[..., -1]
    end_b, end_i = [], []
    for i, j in ((N - 1, N - 2), (0, 1)):
        b_ = np.flatnonzero(uns[:, i] & uns[:, j] & (g[:, i] < g[:, j]))
        end_b.append(b_)
        end_i.append(np.full(b_.size, i))
    cb = np.concatenate([cb, *end_b])
    ci = np.concatenate([ci, *end_i])
    ck = np.concatenate([ck, np.full(cb.size - ck.size, ind.shape[-1] - 1)])
    if first_only:
        # a window past the first non-stable scan point cannot come first
        not_stable = verdict != STABLE
        first_bad = np.where(not_stable.any(axis=1), np.argmax(not_stable, axis=1), N)
        before = ci + 1 < first_bad[cb]
        cb, ci, ck = cb[before], ci[before], ck[before]
    found_x, found_v = _golden(evaluate, cb.astype(np.int64), ck, xs[cb, np.maximum(ci - 1, 0)],
                               xs[cb, np.minimum(ci + 1, N - 1)])

    # 3. samples: the scan plus the non-stable points found by the golden search
    hit = np.isfinite(found_x)
    sx = [xs.ravel(), found_x[hit]]
    sr = [rows, cb[hit].astype(np.int64)]
    sv = [verdict.ravel(), found_v[hit].astype(verdict.dtype)]
    sx_a, sr_a, sv_a = np.concatenate(sx), np.concatenate(sr), np.concatenate(sv)
    sign = np.where(x1 >= x0, 1.0, -1.0)
    order = np.lexsort((sign[sr_a] * sx_a, sr_a))  # by row, then along the path
    sx_a, sr_a, sv_a = sx_a[order], sr_a[order], sv_a[order]
    bad = sv_a != STABLE
    if first_only:
        # keep each row's samples up to the end of its first run of non-stable ones
        row_start = np.concatenate([[True], sr_a[1:] != sr_a[:-1]])
        grp = np.cumsum(row_start) - 1

        def row_cumsum(x: NDArray) -> NDArray:
            c = np.cumsum(x)
            return c - (c - x)[row_start][grp]

        seen_bad = row_cumsum(bad) > 0
        keep_s = row_cumsum(seen_bad & ~bad) == 0
        sx_a, sr_a, sv_a, bad = sx_a[keep_s], sr_a[keep_s], sv_a[keep_s], bad[keep_s]

    # 4. bisect every stable <-> not-stable change between consecutive samples of a row
    same_row = sr_a[1:] == sr_a[:-1]
    change = same_row & (bad[1:] != bad[:-1])
    j = np.flatnonzero(change)
    a, b = _bisect(evaluate, sr_a[j], sx_a[j], sx_a[j + 1], bad[j], rounding_rtol)
    # the boundary reported: the stable side's end of the rounding-level bracket
    boundary = np.where(bad[j], b, a)

    # 5. assemble windows: runs of not-stable samples, bounded by the boundaries found
    w_row, w_near, w_far, w_uns = [], [], [], []
    starts = np.flatnonzero(np.concatenate([[True], ~same_row | (bad[1:] != bad[:-1])]))
    ends = np.concatenate([starts[1:], [sx_a.size]])
    bnd = dict(zip(j.tolist(), boundary.tolist(), strict=True))
    for s0, s1 in zip(starts.tolist(), ends.tolist(), strict=True):
        if not bad[s0]:
            continue
        r = int(sr_a[s0])
        near = bnd.get(s0 - 1, sx_a[s0]) if s0 > 0 and sr_a[s0 - 1] == r else sx_a[s0]
        far = bnd.get(s1 - 1, sx_a[s1 - 1]) if s1 < sx_a.size and sr_a[s1] == r else sx_a[s1 - 1]
        v = sv_a[s0:s1]
        w_row.append(r)
        w_near.append(near)
        w_far.append(far)
        w_uns.append(bool(np.any((v == FLUTTER) | (v == DIVERGENCE))))
    start_unstable = verdict[:, 0] != STABLE
    return Windows(
        start_unstable,
        np.asarray(w_row, dtype=np.int64),
        np.asarray(w_near, dtype=float),
        np.asarray(w_far, dtype=float),
        np.asarray(w_uns, dtype=bool),
    )


def _golden(evaluate: Evaluator, rows: NDArray, kind: NDArray, a: NDArray, d: NDArray) -> NDArray:
    """Golden-section minimisation of indicator ``kind`` of each row on ``[a, d]``.

    Returns, per candidate, the first visited point that is not stable (NaN if none) and
    its verdict code; for a candidate of the last indicator (the growth margin, searched
    among unstable points) the first visited point that is stable.
    """
    found = np.full(rows.shape[0], np.nan)
    found_v = np.full(rows.shape[0], STABLE, dtype=np.int8)
    if rows.size == 0:
        return found, found_v
    a, d = np.minimum(a, d).astype(float), np.maximum(a, d).astype(float)
    pick = np.arange(rows.size)

    def f(idx: NDArray, x: NDArray) -> NDArray:
        v, lam, thr = evaluate(rows[idx], x)
        ind = _indicators(lam, thr)
        val = ind[np.arange(idx.size), kind[idx]]
        bad = np.where(kind[idx] == ind.shape[-1] - 1, v == STABLE, v != STABLE)
        new = bad & np.isnan(found[idx])
        found[idx[new]] = x[new]
        found_v[idx[new]] = v[new]
        return val

    x1 = d - _INV_PHI * (d - a)
    x2 = a + _INV_PHI * (d - a)
    f1 = f(pick, x1)
    f2 = f(pick, x2)
    for _ in range(_GOLDEN_STEPS):
        active = np.isnan(found) & (d - a > 8 * np.finfo(float).eps * np.maximum(1.0, np.abs(a)))
        if not active.any():
            break
        idx = np.flatnonzero(active)
        left = f1[idx] < f2[idx]  # minimum in [a, x2]
        # shrink
        na = np.where(left, a[idx], x1[idx])
        nd = np.where(left, x2[idx], d[idx])
        keep_x = np.where(left, x1[idx], x2[idx])
        keep_f = np.where(left, f1[idx], f2[idx])
        new_x = np.where(left, nd - _INV_PHI * (nd - na), na + _INV_PHI * (nd - na))
        new_f = f(idx, new_x)
        a[idx], d[idx] = na, nd
        x1[idx] = np.where(left, new_x, keep_x)
        f1[idx] = np.where(left, new_f, keep_f)
        x2[idx] = np.where(left, keep_x, new_x)
        f2[idx] = np.where(left, keep_f, new_f)
    return found, found_v


def _bisect(evaluate: Evaluator, rows: NDArray, a: NDArray, b: NDArray, a_bad: NDArray,
            rounding_rtol: float) -> tuple[NDArray, NDArray]:
    """Narrow brackets ``[a, b]`` whose ends differ in stability to rounding level."""
    a = np.asarray(a, dtype=float).copy()
    b = np.asarray(b, dtype=float).copy()
    if a.size == 0:
        return a, b
    done = np.zeros(a.size, dtype=bool)
    for _ in range(_BISECT_STEPS):
        active = ~done & (np.abs(b - a) > _BISECT_RTOL * np.maximum(1.0, np.abs(a)))
        if not active.any():
            break
        idx = np.flatnonzero(active)
        m = 0.5 * (a[idx] + b[idx])
        v, _, _ = evaluate(rows[idx], m, high_precision=False)
        und = v == INDETERMINATE
        scale = np.maximum(1.0, np.abs(m))
        wide = und & (np.abs(b[idx] - a[idx]) > rounding_rtol * scale)
        if wide.any():
            # the undecided zone around a boundary is tiny: split elsewhere in the bracket
            # first, and go to high precision only where that is undecided too
            w = np.flatnonzero(wide)
            m[w] = a[idx[w]] + 0.3 * (b[idx[w]] - a[idx[w]])
            v[w] = evaluate(rows[idx[w]], m[w], high_precision=False)[0]
            still = w[v[w] == INDETERMINATE]
            if still.size:
                v[still] = evaluate(rows[idx[still]], m[still])[0]
        done[idx[und & ~wide]] = True
        go = ~(und & ~wide)
        same = (v != STABLE) == a_bad[idx]
        a[idx] = np.where(go & same, m, a[idx])
        b[idx] = np.where(go & ~same, m, b[idx])
    return a, b
