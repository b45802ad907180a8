"""Mode tracking over a 2-D parameter grid, and lock-in (coalescence) detection.

Eigenvalue solvers return the modes of each grid point in an arbitrary order (here:
by frequency). Tracking reorders them so that index k follows one physical branch across
the grid, through crossings and veering: at each step the eigenvalues are matched to a
prediction (linear extrapolation from the two previous points) by the permutation with the
least total squared distance. The first ``mu`` column is tracked along ``mu``, then each
row along ``theta`` from it (rows in parallel).

At an exact coalescence (undamped lock-in: equal omega, sigma = +-s) continuity cannot tell
the branches apart; by convention the lower mode index carries the growing branch there.
"""

from __future__ import annotations

import itertools

import numba as nb
import numpy as np
from numpy.typing import NDArray

from ..solvers.mac import MacTracker as _MacTracker  # noqa: F401  (moved; the old private name kept)
from ._verdicts import _REAL_RTOL, _locked_in

__all__ = ["lock_in", "track_modes"]

_MAX_BRUTE_FORCE = 5
#: relative tolerance for an exact (undamped) coalescence
_LOCK_RTOL = 1e-7


@nb.njit(cache=True, nogil=True)
def _assign_step(pred, cand, perms, out):
    """Write ``cand`` into ``out`` in the order that best matches the prediction ``pred``."""
    n = cand.shape[0]
    if perms.shape[0] > 0:
        best = np.inf
        best_p = 0
        for p in range(perms.shape[0]):
            cost = 0.0
            for k in range(n):
                d = cand[perms[p, k]] - pred[k]
                cost += d.real * d.real + d.imag * d.imag
                if cost >= best:
                    break
            if cost < best:
                best = cost
                best_p = p
        for k in range(n):
            out[k] = cand[perms[best_p, k]]
        return
    # greedy nearest-first assignment for larger n
    used = np.zeros(n, dtype=np.bool_)
    done = np.zeros(n, dtype=np.bool_)
    for _ in range(n):
        best = np.inf
        bk = 0
        bj = 0
        for k in range(n):
            if not done[k]:
                for j in range(n):
                    if not used[j]:
                        d = cand[j] - pred[k]
                        c = d.real * d.real + d.imag * d.imag
                        if c < best:
                            best, bk, bj = c, k, j
        out[bk] = cand[bj]
        used[bj] = True
        done[bk] = True


@nb.njit(cache=True, nogil=True, inline="always")
def _copy(src, dst):
    """``dst[:] = src`` by a loop: an array assignment makes numba compile its shape-mismatch
    message (string formatting, ~10 s on a first run) into every kernel that has one."""
    for k in range(src.shape[0]):
        dst[k] = src[k]


@nb.njit(cache=True, nogil=True)
def _extrapolate(a, b, have_b, out):
    for k in range(a.shape[0]):
        out[k] = 2.0 * a[k] - b[k] if have_b else a[k]


@nb.njit(cache=True, nogil=True)
def _order_locked(row):
    """In each exactly coalesced pair (same omega, sigma = +-s) put +s on the lower index.

    At an exact coalescence of an undamped system continuity cannot tell which branch
    continues which mode; this convention makes the growing branch one whole surface.
    """
    n = row.shape[0]
    for k in range(n):
        for m in range(k + 1, n):
            a = row[k]
            b = row[m]
            scale = max(abs(a), abs(b))
            if abs(a.imag - b.imag) <= _LOCK_RTOL * scale and abs(a.real + b.real) <= _LOCK_RTOL * scale:
                if a.real < b.real:
                    row[k] = b
                    row[m] = a


@nb.njit(cache=True, nogil=True)
def _track_column(col, perms):
    """Track the first grid column (shape (n_mu, n)) along mu."""
    nmu, n = col.shape
    out = np.empty_like(col)
    p1 = np.empty(n, dtype=np.complex128)
    _copy(col[0], out[0])
    _order_locked(out[0])
    for i in range(1, nmu):
        _extrapolate(out[i - 1], out[i - 2] if i > 1 else out[i - 1], i > 1, p1)
        _assign_step(p1, col[i], perms, out[i])
        _order_locked(out[i])
    return out


@nb.njit(cache=True, parallel=True)
def _track_rows(lam, first, perms):
    """Track each row along theta from its tracked first point ``first[i]``, rows in parallel.

    Ties at an exact coalescence are broken by the convention of _order_locked, the same
    way in every row.
    """
    nmu, nth, n = lam.shape
    out = np.empty_like(lam)
    for i in nb.prange(nmu):
        q = np.empty(n, dtype=np.complex128)
        _copy(first[i], out[i, 0])
        for j in range(1, nth):
            _extrapolate(out[i, j - 1], out[i, j - 2] if j > 1 else out[i, j - 1], j > 1, q)
            _assign_step(q, lam[i, j], perms, out[i, j])
            _order_locked(out[i, j])
    return out


@nb.njit(cache=True, parallel=True)
def _carry(lam, val, out_lam, out):
    npts, n = lam.shape
    for i in nb.prange(npts):
        used = np.zeros(n, dtype=np.bool_)
        for k in range(n):
            for j in range(n):
                if not used[j] and (lam[i, j] == out_lam[i, k] or (
                        np.isnan(lam[i, j].real) and np.isnan(out_lam[i, k].real))):
                    used[j] = True
                    out[i, k] = val[i, j]
                    break


def carry_along(lam: NDArray, values: NDArray, lam_tracked: NDArray) -> NDArray:
    """Reorder per-mode ``values`` (same shape as ``lam``) as tracking reordered ``lam``.

    ``lam_tracked`` holds the same eigenvalues as ``lam`` at each point, permuted.
    """
    n = lam.shape[-1]
    out = np.empty(values.shape, dtype=values.dtype)
    _carry(np.ascontiguousarray(lam.reshape(-1, n)), np.ascontiguousarray(values.reshape(-1, n)),
           np.ascontiguousarray(lam_tracked.reshape(-1, n)), out.reshape(-1, n))
    return out


def _perms_for(n: int) -> NDArray[np.int64]:
    if n <= _MAX_BRUTE_FORCE:
        return np.array(list(itertools.permutations(range(n))), dtype=np.int64)
    return np.empty((0, n), dtype=np.int64)


def track_column(col: NDArray[np.complexfloating]) -> NDArray[np.complex128]:
    """Track the first grid column, shape ``(n_mu, n_mode)``, along mu (see :func:`track_modes`)."""
    col = np.ascontiguousarray(col, dtype=np.complex128)
    return _track_column(col, _perms_for(col.shape[-1]))


def track_rows(lam: NDArray[np.complexfloating], first: NDArray[np.complexfloating]) -> NDArray[np.complex128]:
    """Track the rows of ``lam`` (shape ``(n_mu, n_theta, n_mode)``) along theta.

    ``first`` (shape ``(n_mu, n_mode)``) is the tracked first column, from
    :func:`track_column`; it must hold the same eigenvalues as ``lam[:, 0]``. Rows are
    independent, so a grid may be tracked in blocks of rows with identical results.
    """
    lam = np.ascontiguousarray(lam, dtype=np.complex128)
    first = np.ascontiguousarray(first, dtype=np.complex128)
    return _track_rows(lam, first, _perms_for(lam.shape[-1]))


def track_modes(lam: NDArray[np.complexfloating]) -> NDArray[np.complex128]:
    """Reorder eigenvalues so each mode index follows one branch over the grid.

    Parameters
    ----------
    lam : ndarray, shape (n_mu, n_theta, n_mode)
        Eigenvalues (one per conjugate pair) in any order at each grid point.

    Returns
    -------
    ndarray, same shape
        Tracked eigenvalues; at ``[0, 0]`` the order of the input is kept.
    """
    lam = np.ascontiguousarray(lam, dtype=np.complex128)  # a no-op for kernel output
    return track_rows(lam, track_column(lam[:, 0]))


def lock_in(
    omega: NDArray[np.floating],
    growth_rate: NDArray[np.floating],
    *,
    rtol: float = 1e-3,
    unstable_threshold: float = 0.0,
) -> NDArray[np.bool_]:
    """Where two modes have locked in (mode coupling): frequencies merged, growth rates split, one growing.

    A point is locked in when an unstable oscillating mode ``k`` has another mode ``m`` nearer
    to it in frequency than in growth rate, ``|omega_k - omega_m| <= max(rtol * max(omega_k,
    omega_m), |sigma_k - sigma_m|)``: the undamped pair ``+-sigma`` at one frequency, or its
    damped counterpart whose frequencies only approach. A growing real root (divergence) and a
    lone mode destabilised by negative damping are not lock-in. The flag of
    :func:`~squealkit.stability.stability_map`, which also uses each root's error radius.

    Parameters
    ----------
    omega, growth_rate : ndarray, shape (..., n_mode)
        Imaginary and real parts of the eigenvalues [rad/s, 1/s].
    rtol : float
        Relative frequency tolerance for coalescence, the least the criterion accepts.
    unstable_threshold : float or ndarray
        Growth rate above which a mode counts as unstable [1/s].

    Returns
    -------
    ndarray of bool, shape (...)

    Examples
    --------
    >>> bool(lock_in(np.array([100.0, 100.0]), np.array([5.0, -5.0])))
    True
    >>> bool(lock_in(np.array([0.0, 0.0]), np.array([5.0, -3.0])))  # divergence
    False
    """
    w = np.asarray(omega, dtype=float)
    s = np.asarray(growth_rate, dtype=float)
    w, s = np.broadcast_arrays(w, s)
    lead = w.shape[:-1]
    thr = np.broadcast_to(np.asarray(unstable_threshold, dtype=float), lead)[..., None]
    unstable = s > thr
    oscillating = np.abs(w) > _REAL_RTOL * np.hypot(w, s)
    flat = (-1, w.shape[-1])
    out = [_locked_in(*rows, float(rtol)) for rows in zip(
        np.ascontiguousarray(s.reshape(flat)), np.ascontiguousarray(w.reshape(flat)),
        np.ascontiguousarray(unstable.reshape(flat)), np.ascontiguousarray(oscillating.reshape(flat)),
        strict=True)]
    return np.array(out, dtype=bool).reshape(lead)
