"""Compiled kernels of the stability analysis: what the certified roots of a grid say, point by point.

The engine (:mod:`squealkit.solvers.small`) gives the 2n roots of each point and their error
radii; this module reads them in the analysis' words: the point's verdict (:func:`classify_points`:
stable, flutter, divergence, or undecided where only a more accurate solver can tell;
:data:`VERDICTS`), one root per mode in ascending frequency, the most unstable real root never
dropped (:func:`select_modes`), and per mode its growth rate, frequency, damping ratio, whether it
is unstable and whether two modes have locked in (:func:`derived_quantities`).

Moved from ``squealkit/solvers/small/modes.py`` (issue #28: the solvers know no analysis); numba
caches these kernels under this module's path.
"""

from __future__ import annotations

import numba as nb
import numpy as np

#: Verdict codes of a grid point, and their words (:data:`squealkit.stability.VERDICTS`) by code.
STABLE, FLUTTER, DIVERGENCE, INDETERMINATE = 0, 1, 2, 3
VERDICTS = ("stable", "flutter", "divergence", "indeterminate")
#: the point needs a more accurate solver (internal; never in a result)
UNDECIDED = 4


#: Roots within ``ZERO_ROOT_REACH sqrt(2n eps) |lambda|_max`` of zero are zero roots split by
#: rounding (a double zero root of matrices singular to rounding moves about
#: ``sqrt(eps) |lambda|_max``; measured at most 1.06 sqrt(eps) on random 4-DOF models with a
#: rigid-body mode): they decide no verdict.
ZERO_ROOT_REACH = 4.0


@nb.njit(cache=True, nogil=True)
def _classify_row(z, rad, even, rtol):
    """Snap provably real (or, for an even polynomial, imaginary) roots; return the verdict
    and the threshold ``rtol |lambda|_max``.

    The polynomial is real, so a non-real root comes with its conjugate; a root whose
    inclusion disc reaches the real axis and holds no other root (within four radii) is
    therefore real. For an even polynomial (undamped, or gyroscopic and conservative) roots
    also come in pairs +-s, and an isolated root whose disc reaches the imaginary axis is
    imaginary. A point is unstable when a root, and every root whose disc touches its disc,
    lies beyond the threshold by more than its radius; stable when no disc reaches it.
    """
    deg = z.shape[0]
    mag2 = 0.0
    for k in range(deg):
        mag2 = max(mag2, z[k].real * z[k].real + z[k].imag * z[k].imag)
    for k in range(deg):
        r = rad[k]
        near_real = abs(z[k].imag) <= r
        near_imag = even and abs(z[k].real) <= r
        if not (near_real or near_imag):
            continue
        alone = True
        for j in range(deg):
            if j != k:
                d = z[j] - z[k]
                lim = 4.0 * r + rad[j]
                if d.real * d.real + d.imag * d.imag <= lim * lim:
                    alone = False
                    break
        if alone and near_real:
            z[k] = complex(z[k].real, 0.0)
        if alone and near_imag:
            z[k] = complex(0.0, z[k].imag)
    mag = np.sqrt(mag2)
    thr = rtol * mag
    # a root this close to zero is a zero root (a rigid-body mode) split by the rounding of
    # the matrices themselves (a double zero root moves sqrt(eps) |lambda|_max): by its own
    # scale it is neither growing nor decaying, and the other roots decide
    zero_reach = ZERO_ROOT_REACH * np.sqrt(deg * 2.220446049250313e-16) * mag
    possible = False
    best = -np.inf
    real_best = False
    for k in range(deg):
        if z[k].real * z[k].real + z[k].imag * z[k].imag <= zero_reach * zero_reach:
            continue
        if z[k].real + rad[k] > thr:
            possible = True
        lo = z[k].real - rad[k]
        if lo > thr and lo > best:
            sure = True
            for j in range(deg):
                if abs(z[j] - z[k]) <= rad[j] + rad[k] and z[j].real - rad[j] <= thr:
                    sure = False
            if sure:
                best = lo
                real_best = abs(z[k].imag) <= rad[k]
    if best > -np.inf:
        return (DIVERGENCE if real_best else FLUTTER), thr
    if possible:
        return UNDECIDED, thr
    return STABLE, thr


@nb.njit(cache=True, parallel=True)
def classify_points(roots, radii, even, rtol, verdict, thr):
    """Verdict of every point (``STABLE``, ``FLUTTER``, ``DIVERGENCE`` or ``UNDECIDED``)
    and its instability threshold ``thr`` [1/s]; snaps provably real / imaginary roots in
    place (see :func:`_classify_row`). Undecided points need a more accurate solver.
    """
    for i in nb.prange(roots.shape[0]):
        verdict[i], thr[i] = _classify_row(roots[i], radii[i], even[i], rtol)


#: How far [relative to |lambda|_max] rounding can move a double real root off the axis (about
#: sqrt(eps)) with a margin: a root farther off is a mode with a frequency, whatever its radius.
_REAL_SPLIT = 1e-6


@nb.njit(cache=True, parallel=True)
def select_modes(roots, radii, out, out_err):
    """Pick n of the 2n roots per point, one per conjugate pair, in ascending frequency.

    Of each complex pair the root with Im > 0 is kept. Roots within their error radius of
    the real axis, and within :data:`_REAL_SPLIT` of it, are real (overdamped or divergent
    modes, rigid-body modes): they are
    written with Im = 0 (frequency 0, so first) and the largest of them are kept, so the
    most unstable root is never dropped, whatever the rounding of their imaginary parts.
    ``out_err`` receives the error radius of each kept root.
    """
    npts, deg = roots.shape
    n = out.shape[1]
    nchunks = (npts + 1023) // 1024
    for c in nb.prange(nchunks):
        val = np.empty(deg, dtype=np.complex128)
        re = np.empty(deg, dtype=np.int64)
        up = np.empty(deg, dtype=np.int64)
        for i in range(c * 1024, min(npts, (c + 1) * 1024)):
            n_up = 0
            n_re = 0
            mag = 0.0
            for k in range(deg):
                mag = max(mag, abs(roots[i, k]))
            for k in range(deg):
                z = roots[i, k]
                # real: within its radius of the axis, and no farther than a rounding-split real pair
                # (a radius covering everything, at a near-defective cluster, makes no mode real)
                if abs(z.imag) <= min(radii[i, k], _REAL_SPLIT * mag):
                    val[k] = complex(z.real, 0.0)
                    # insertion by real part, largest first
                    j = n_re
                    while j > 0 and val[re[j - 1]].real < z.real:
                        re[j] = re[j - 1]
                        j -= 1
                    re[j] = k
                    n_re += 1
                elif z.imag > 0.0:
                    val[k] = z
                    # insertion by frequency, lowest first
                    j = n_up
                    while j > 0 and val[up[j - 1]].imag > z.imag:
                        up[j] = up[j - 1]
                        j -= 1
                    up[j] = k
                    n_up += 1
            m = 0
            for j in range(min(n_re, max(0, n - n_up))):
                out[i, m] = val[re[j]]
                out_err[i, m] = radii[i, re[j]]
                m += 1
            for j in range(min(n_up, n - m)):
                out[i, m] = val[up[j]]
                out_err[i, m] = radii[i, up[j]]
                m += 1
            for k in range(m, n):  # never for a consistent set of roots
                out[i, k] = complex(np.nan, np.nan)
                out_err[i, k] = np.inf


#: An eigenvalue with |omega| at most this times |lambda| (or its error radius) is a real root.
_REAL_RTOL = 1e-12


@nb.njit(cache=True)
def _locked_in(sigma, omega, unstable, oscillating, rtol):
    """Whether one point's modes show lock-in (mode coupling).

    Lock-in is two modes whose frequencies have merged while their growth rates split, one of
    them growing: an unstable *oscillating* mode ``k`` (a real root growing is divergence,
    never lock-in) with another mode ``m`` that is nearer to it in frequency than in growth
    rate, ``|omega_k - omega_m| <= max(rtol * max(omega_k, omega_m), |sigma_k - sigma_m|)``.
    Undamped coupling gives equal frequencies and growth rates ``+-sigma``; with
    non-proportional damping the frequencies only approach (the 3-DOF paper model's damped
    pair: 2371 and 2226 Hz at growth rates +62 and -3359 1/s). A lone mode destabilised by
    negative damping, far in frequency from every other, is not locked in.
    """
    n = sigma.shape[0]
    for k in range(n):
        if not (unstable[k] and oscillating[k]):
            continue
        wk = abs(omega[k])
        for m in range(n):
            if m != k:
                wm = abs(omega[m])
                if abs(wk - wm) <= max(rtol * max(wk, wm), abs(sigma[k] - sigma[m])):
                    return True
    return False


@nb.njit(cache=True, parallel=True)
def derived_quantities(lam, err, thr, verdict, lock_rtol):
    """Per-mode and per-point quantities of a stability map in one pass.

    ``lam`` and its error radii ``err`` have shape (npts, n); ``thr`` and ``verdict`` are
    per point. Returns growth rate, omega, damping ratio, the unstable flag per mode (growth
    beyond ``thr`` by more than the error radius), and per point the largest growth rate,
    whether the point is unstable (flutter or divergence) and whether two modes have locked
    in (see :func:`_locked_in`).
    """
    npts, n = lam.shape
    sigma = np.empty((npts, n))
    omega = np.empty((npts, n))
    zeta = np.empty((npts, n))
    unstable = np.empty((npts, n), dtype=np.bool_)
    smax = np.empty(npts)
    any_u = np.empty(npts, dtype=np.bool_)
    locked = np.empty(npts, dtype=np.bool_)
    for i in nb.prange(npts):
        best = -np.inf
        for k in range(n):
            s = lam[i, k].real
            w = lam[i, k].imag
            mag = abs(lam[i, k])
            sigma[i, k] = s
            omega[i, k] = w
            zeta[i, k] = -s / mag if mag > 0.0 else 0.0
            unstable[i, k] = s - err[i, k] > thr[i]
            best = max(best, s)
        smax[i] = best
        any_u[i] = verdict[i] == FLUTTER or verdict[i] == DIVERGENCE
        oscillating = np.empty(n, dtype=np.bool_)
        for k in range(n):
            oscillating[k] = abs(omega[i, k]) > max(err[i, k], _REAL_RTOL * abs(lam[i, k]))
        locked[i] = _locked_in(sigma[i], omega[i], unstable[i], oscillating, lock_rtol)
    return sigma, omega, zeta, unstable, smax, any_u, locked
