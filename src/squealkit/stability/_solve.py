"""The stability verdict: roots, their error radii, and refinement where rounding could decide.

Every grid point goes through up to three solvers, each only where the one before cannot
decide (see :func:`solve_points`):

1. the compiled characteristic-polynomial kernel (n <= 4) with an a-posteriori error radius
   per root (:func:`~squealkit.solvers.small.inclusion_radii`): near a double root, e.g. a
   disc doublet or the lock-in point, the radius grows to the true rounding reach,
   about sqrt(eps) |lambda|, so a doublet split by rounding is never called unstable;
2. LAPACK on the balanced 2n x 2n state matrix, with the Bauer-Fike radius
   ``kappa(X) * c eps ||A||`` (X the computed eigenvectors) — decides semisimple doublets,
   which the polynomial cannot;
3. exact rational arithmetic (:func:`exact_verdict`): the characteristic polynomial of the
   matrices as given, shifted by the threshold, with Routh's array counting the roots
   beyond it and Sturm's sequence the real ones — decides near-defective clusters
   (one-way coupled doublets, rigid-body modes, the lock-in point itself) in about 1 ms;
4. where Routh's array meets a zero (a root exactly on the threshold), the polynomial's
   roots in 50-digit arithmetic (mpmath), with the same inclusion radii at that precision.

A point that none of them decides is ``indeterminate``: its verdict is within rounding of
the data themselves, and no answer is given silently.
"""

from __future__ import annotations

import inspect
import itertools
import math
import warnings
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray

from ..solvers.small import inclusion_radii
from ._verdicts import (
    DIVERGENCE,
    FLUTTER,
    INDETERMINATE,
    STABLE,
    UNDECIDED,
    VERDICTS,
    ZERO_ROOT_REACH,
    classify_points,
    select_modes,
)

__all__ = ["VERDICTS", "IndeterminateWarning", "exact_verdict", "solve_points"]

#: Digits of the high-precision stage.
_MP_DPS = 50
#: Points refined in high precision per call at most; beyond, they stay indeterminate.
MP_MAX_POINTS = 2000
#: Safety factor on the backward error of LAPACK's eigenvalue solver.
_LAPACK_C = 16.0


class IndeterminateWarning(RuntimeWarning):
    """Some verdicts could not be decided (within rounding of the model's own numbers)."""


def _stiffness(K0, Kn, Kf, which, g, e):
    return K0[which] + g[:, None, None] * Kn[which] + e[:, None, None] * Kf[which]


def lapack_roots(M: NDArray, C: NDArray, K: NDArray) -> tuple[NDArray, NDArray]:
    """All 2n eigenvalues of stacks ``M, C, K`` (P, n, n) and their Bauer-Fike error radii.

    The state matrix is balanced by the scale w0 = sqrt(||M^-1 K||) (``y = [x, x'/w0]``) so
    that its norm is about |lambda|. Every exact eigenvalue lies within
    ``kappa(X) ||E||`` of a computed one, with X the computed eigenvectors and E LAPACK's
    backward error (``_LAPACK_C * eps * ||A||``); a defective or nearly defective matrix has
    a huge kappa and so a huge radius.
    """
    P, n, _ = M.shape
    MinvK = np.linalg.solve(M, K)
    MinvC = np.linalg.solve(M, C)
    w0 = np.sqrt(np.maximum(np.linalg.norm(MinvK, axis=(-2, -1)), 1e-300))[:, None, None]
    A = np.zeros((P, 2 * n, 2 * n))
    A[:, :n, n:] = w0 * np.eye(n)
    A[:, n:, :n] = -MinvK / w0
    A[:, n:, n:] = -MinvC
    w, X = np.linalg.eig(A)
    w = w.astype(np.complex128)  # real when every root is real (overdamped)
    radius = np.full(w.shape, np.inf)
    normA = np.linalg.norm(A, axis=(-2, -1))
    with np.errstate(all="ignore"):
        try:
            Xinv = np.linalg.inv(X)
            kappa = np.linalg.norm(X, axis=(-2, -1)) * np.linalg.norm(Xinv, axis=(-2, -1))
        except np.linalg.LinAlgError:
            kappa = np.array([_kappa_one(x) for x in X])
        r = _LAPACK_C * np.finfo(float).eps * normA * kappa
    ok = np.isfinite(r)
    radius[ok] = np.broadcast_to(r[:, None], w.shape)[ok]
    return w, radius


def _kappa_one(X: NDArray) -> float:
    try:
        return float(np.linalg.norm(X) * np.linalg.norm(np.linalg.inv(X)))
    except np.linalg.LinAlgError:
        return np.inf


def mp_roots(M: NDArray, C: NDArray, K: NDArray, scale: float, dps: int = _MP_DPS) -> tuple[NDArray, NDArray]:
    """All 2n roots of det(M s^2 + C s + K) in ``dps``-digit arithmetic, with error radii.

    The coefficients come from the determinant at 2n+1 points on the circle of radius
    ``scale`` (an inverse discrete Fourier transform, exact to the working precision); each
    coefficient's error is bounded by ``tol max|p| / scale^d``, and :func:`inclusion_radii`
    turns that into a radius per root, to which the rounding of each root to a double is
    added. The matrices are taken exactly as given (doubles).
    """
    import mpmath

    n = M.shape[0]
    deg = 2 * n
    N = deg + 1
    with mpmath.workdps(dps):
        Mm, Cm, Km = (mpmath.matrix(a.tolist()) for a in (M, C, K))
        R = mpmath.mpf(scale)
        vals = []
        nodes = []
        for k in range(N):
            s = R * mpmath.expjpi(mpmath.mpf(2 * k) / N)
            nodes.append(s)
            vals.append(mpmath.det(s * s * Mm + s * Cm + Km))
        pmax = max(abs(v) for v in vals)
        coef = []
        for d in range(N):
            acc = mpmath.mpc(0)
            for k in range(N):
                acc += vals[k] * mpmath.expjpi(-mpmath.mpf(2 * k * d) / N)
            coef.append(acc / N / R**d)
        coef = [mpmath.re(c) for c in coef]  # a real polynomial
        lead = coef[deg]
        if lead == 0:
            return np.full(deg, np.nan + 0j), np.full(deg, np.inf)
        try:
            # mpmath >= 1.4 takes ascending coefficients (asc=True), older ones descending only
            asc = "asc" in inspect.signature(mpmath.polyroots).parameters
            z = mpmath.polyroots(coef if asc else coef[::-1], maxsteps=400, extraprec=4 * dps,
                                 **({"asc": True} if asc else {}))
        except mpmath.libmp.NoConvergence:
            return np.full(deg, np.nan + 0j), np.full(deg, np.inf)
        tol = mpmath.mpf(10) ** (-dps + 4) * N * pmax
        err_at = np.array([float(sum(tol * (abs(zk) / R) ** d for d in range(N))) for zk in z])
        roots = np.array([complex(zk) for zk in z])
        # the roots are returned in doubles: their discs must also cover that rounding
        # (about eps |z|), else a disc of 1e-40 around a rounded centre misses its root
        rounding = np.array([float(abs(zk - mpmath.mpc(r))) for zk, r in zip(z, roots, strict=True)])
    radius = np.empty(deg)
    inclusion_radii(roots, float(lead), err_at, radius, np.empty(deg, dtype=np.bool_))
    radius += np.nextafter(rounding, np.inf)
    return roots, radius


def solve_points(
    M: NDArray, C: NDArray, K0: NDArray, Kn: NDArray, Kf: NDArray, which: NDArray,
    g: NDArray, e: NDArray, roots: NDArray, radii: NDArray, even: NDArray | None, rtol: float,
    *, high_precision: bool = True, out: tuple[NDArray, NDArray, NDArray, NDArray] | None = None,
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Verdict of every point from its roots, refining where the roots cannot decide.

    Parameters
    ----------
    M, C, K0, Kn, Kf : ndarray, shape (S, n, n)
        Stacked model matrices; point i uses model ``which[i]`` with
        ``K = K0 + g[i] Kn + e[i] Kf``.
    roots : ndarray, shape (P, 2n)
        All roots of every point (modified: snapped, refined).
    radii : ndarray, shape (P, 2n)
        Their error radii.
    even : ndarray of bool, shape (P,), or None
        Where the characteristic polynomial is even in s, from the compiled kernel; None
        for roots from LAPACK (then computed here, and LAPACK is not asked again).
    rtol : float
        A point is unstable when a growth rate exceeds ``rtol |lambda|_max``.
    high_precision : bool
        Run the exact and 50-digit stages; without, what LAPACK cannot decide is indeterminate.
    out : tuple of ndarray, optional
        ``(lam, err, verdict, thr)`` to write the results into (C-contiguous, shapes as
        returned), so that a grid's blocks land in place without copies.

    Returns
    -------
    lam, err : ndarray, shape (P, n)
        One root per mode (see :func:`~squealkit.stability._verdicts.select_modes`) and its
        error radius [1/s].
    verdict : ndarray of int8, shape (P,)
        Codes into :data:`VERDICTS`.
    thr : ndarray, shape (P,)
        Growth rate [1/s] above which the point counts as unstable.
    """
    P, deg = roots.shape
    n = deg // 2
    from_kernel = even is not None
    if not from_kernel:
        even = _even_structure(M, C, K0, Kn, Kf, which, g, e)
    if out is None:
        out = (np.empty((P, n), dtype=np.complex128), np.empty((P, n)), np.empty(P, dtype=np.int8), np.empty(P))
    lam, err, verdict, thr = out
    classify_points(roots, radii, even, rtol, verdict, thr)
    todo = np.flatnonzero(verdict == UNDECIDED)
    if todo.size:
        _refine(M, C, K0, Kn, Kf, which, g, e, roots, radii, even, rtol, verdict, thr, todo,
                lapack=from_kernel, high_precision=high_precision)
    select_modes(roots, radii, lam, err)
    return lam, err, verdict, thr


def _even_structure(M, C, K0, Kn, Kf, which, g, e) -> NDArray[np.bool_]:
    """Where det(M s^2 + C s + K) is even in s: C = 0, or C skew and K symmetric."""
    Cw = C[which]
    c_zero = ~np.any(Cw != 0.0, axis=(-2, -1))
    c_skew = ~np.any(Cw != -np.swapaxes(Cw, -1, -2), axis=(-2, -1))
    out = c_zero.copy()
    check = np.flatnonzero(c_skew & ~c_zero)
    if check.size:
        K = _stiffness(K0, Kn, Kf, which[check], g[check], e[check])
        out[check] = ~np.any(K != np.swapaxes(K, -1, -2), axis=(-2, -1))
    return out


def _refine(M, C, K0, Kn, Kf, which, g, e, roots, radii, even, rtol, verdict, thr, todo, *, lapack,
            high_precision=True) -> None:
    """LAPACK (unless the roots came from it), then high precision, at the undecided points
    ``todo`` (in place)."""
    for start in range(0, todo.size if lapack else 0, 4096):
        idx = todo[start:start + 4096]
        K = _stiffness(K0, Kn, Kf, which[idx], g[idx], e[idx])
        w, r = lapack_roots(M[which[idx]], C[which[idx]], K)
        v = np.empty(idx.size, dtype=np.int8)
        t = np.empty(idx.size)
        w = np.ascontiguousarray(w)
        classify_points(w, r, even[idx], rtol, v, t)
        # LAPACK's roots replace the kernel's where they decide, or bound every root tighter:
        # its Bauer-Fike radius is one for all roots, and at a near-defective cluster (a
        # one-way coupled doublet, a rigid-body mode) it covers every root, where the
        # kernel's per-root radii still tell the other modes' frequencies (issue 30)
        take = (v != UNDECIDED) | (r.max(axis=1) < radii[idx].max(axis=1))
        roots[idx[take]] = w[take]
        radii[idx[take]] = r[take]
        verdict[idx] = v
        thr[idx] = t
    left = todo[verdict[todo] == UNDECIDED] if high_precision else todo[:0]
    # exact rational arithmetic decides almost every point that is left (about 1 ms each)
    hard = []
    for i in left:
        s_ = which[i]
        mag = float(np.nanmax(np.abs(roots[i]))) if np.isfinite(roots[i]).any() else 0.0
        reach = ZERO_ROOT_REACH * math.sqrt(roots.shape[1] * np.finfo(float).eps) * mag
        v = exact_verdict(M[s_], C[s_], K0[s_] + g[i] * Kn[s_] + e[i] * Kf[s_], thr[i], zero_reach=reach)
        if v is None:
            hard.append(i)
        else:
            verdict[i] = v
    left = np.asarray(hard, dtype=np.int64)
    if left.size > MP_MAX_POINTS:
        warnings.warn(
            f"{left.size} points are within rounding of the stability limit; the first "
            f"{MP_MAX_POINTS} were decided in {_MP_DPS}-digit arithmetic, the rest are reported "
            "indeterminate.", IndeterminateWarning, stacklevel=4)
    for i in left[:MP_MAX_POINTS]:
        s_ = which[i]
        K = K0[s_] + g[i] * Kn[s_] + e[i] * Kf[s_]
        scale = float(np.nanmax(np.abs(roots[i]))) if np.isfinite(roots[i]).any() else 1.0
        z, r = mp_roots(M[s_], C[s_], K, max(scale, 1e-300) * 1.5)
        if not np.all(np.isfinite(z)):
            verdict[i] = INDETERMINATE
            continue
        z = np.ascontiguousarray(z[None, :])
        r = np.ascontiguousarray(r[None, :])
        v = np.empty(1, dtype=np.int8)
        t = np.empty(1)
        classify_points(z, r, even[i:i + 1], rtol, v, t)
        roots[i] = z[0]
        radii[i] = r[0]
        verdict[i] = INDETERMINATE if v[0] == UNDECIDED else v[0]
        thr[i] = t[0]
    verdict[verdict == UNDECIDED] = INDETERMINATE


# --- exact verdict: rational arithmetic on the characteristic polynomial ----------------------

def _int_matrices(*mats: NDArray) -> tuple[list[list[int]], ...]:
    """The matrices as exact integers, all scaled by one common power of two."""
    parts = [np.frexp(np.asarray(m, dtype=float)) for m in mats]  # x = f 2^e, 0.5 <= |f| < 1
    mant = [(f * 2.0**53).astype(np.int64) for f, _ in parts]  # exact: 53-bit integers
    low = min(int(e.min()) for _, e in parts) - 53
    return tuple(
        [[int(a) << (int(b) - 53 - low) for a, b in zip(mr, er, strict=True)] for mr, er in zip(m, e, strict=True)]
        for m, (_, e) in zip(mant, parts, strict=True)
    )


def _det(a: list[list[int]]) -> int:
    """Determinant of an integer matrix (Bareiss: fraction-free, exact)."""
    a = [row[:] for row in a]
    n = len(a)
    sign, prev = 1, 1
    for k in range(n - 1):
        if a[k][k] == 0:
            piv = next((i for i in range(k + 1, n) if a[i][k] != 0), None)
            if piv is None:
                return 0
            a[k], a[piv] = a[piv], a[k]
            sign = -sign
        for i in range(k + 1, n):
            for j in range(k + 1, n):
                a[i][j] = (a[i][j] * a[k][k] - a[i][k] * a[k][j]) // prev
        prev = a[k][k]
    return sign * a[n - 1][n - 1]


def _shifted_char_poly(M: NDArray, C: NDArray, K: NDArray, h: float) -> list[int]:
    """Integer coefficients (lowest degree first) of a positive multiple of
    ``det(M (u + h)^2 + C (u + h) + K)``, exactly, for the doubles as given.

    The determinant is evaluated at the integers u = 0..2n (Bareiss, exact) with
    h = H / 2^q; Newton's forward differences are then integers and ``(2n)! p(u)`` an
    integer polynomial.
    """
    n = M.shape[0]
    deg = 2 * n
    Mi, Ci, Ki = _int_matrices(M, C, K)
    hf = Fraction(float(h))
    H, Q = hf.numerator, hf.denominator
    ys = []
    for u in range(deg + 1):
        x = u * Q + H  # (u + h) = x / Q
        a = [[Mi[i][j] * x * x + Ci[i][j] * x * Q + Ki[i][j] * Q * Q for j in range(n)] for i in range(n)]
        ys.append(_det(a))
    diffs = [ys[0]]
    row = ys
    for _ in range(deg):
        row = [b - a for a, b in itertools.pairwise(row)]
        diffs.append(row[0])
    # sum_k diffs[k] * u (u - 1) ... (u - k + 1) * (deg! / k!)
    poly = [0] * (deg + 1)
    falling = [1]  # u (u - 1) ... (u - k + 1), lowest first
    fact_ratio = math.factorial(deg)
    for k in range(deg + 1):
        w = diffs[k] * (fact_ratio // math.factorial(k))
        for i, c in enumerate(falling):
            poly[i] += w * c
        falling = [(falling[i - 1] if i > 0 else 0) - k * (falling[i] if i < len(falling) else 0)
                   for i in range(len(falling) + 1)]
    return poly


def _right_half_plane_roots(p: list[int]) -> int | None:
    """Roots of p with positive real part (Routh's array, fraction-free: each new row is
    scaled by the positive factor |pivot|); None where a zero pivot needs the special
    cases (a root on the axis, or a pair symmetric about it)."""
    a = p[::-1]  # highest degree first
    while a and a[0] == 0:
        a = a[1:]
    if len(a) < 2:
        return 0
    top, bot = a[0::2], a[1::2]
    bot = bot + [0] * (len(top) - len(bot))
    first = [top[0]]
    for _ in range(len(a) - 1):
        if bot[0] == 0:
            return None
        first.append(bot[0])
        sgn = 1 if bot[0] > 0 else -1
        nxt = [sgn * (bot[0] * top[j + 1] - top[0] * (bot[j + 1] if j + 1 < len(bot) else 0))
               for j in range(len(top) - 1)]
        nxt = nxt + [0] * (len(bot) - len(nxt))
        g = math.gcd(*nxt) if any(nxt) else 1
        top, bot = bot, [x // g for x in nxt]
    return sum((x > 0) != (y > 0) for x, y in itertools.pairwise(first))


def _positive_real_roots(p: list[int]) -> int | None:
    """Distinct real roots of p in (0, inf) (Sturm's sequence with sign-preserving
    pseudo-remainders, in integers); None if p(0) = 0."""
    if p[0] == 0:
        return None

    def trim(q):
        while len(q) > 1 and q[-1] == 0:
            q = q[:-1]
        return q

    def neg_prem(u, v):
        """-(c u mod v) for a positive c that makes the division exact."""
        lc, sgn = abs(v[-1]), (1 if v[-1] > 0 else -1)
        while len(u) >= len(v) and any(u):
            f = u[-1]
            shift = len(u) - len(v)
            u = [x * lc for x in u]
            for k in range(len(v)):  # the leading term cancels: f |lc| - f sgn lc = 0
                u[k + shift] -= f * sgn * v[k]
            u = trim(u[:-1]) if len(u) > 1 else [0]
        g = math.gcd(*u) if any(u) else 1
        return [-(x // g) for x in trim(u)]

    seq = [trim(p[:]), trim([k * p[k] for k in range(1, len(p))])]
    while len(seq[-1]) > 1:
        r = neg_prem(seq[-2], seq[-1])
        if not any(r):
            break
        seq.append(r)

    def changes(vals):
        s_ = [v for v in vals if v != 0]
        return sum((x > 0) != (y > 0) for x, y in itertools.pairwise(s_))

    return changes([q[0] for q in seq]) - changes([q[-1] for q in seq])


def exact_verdict(M: NDArray, C: NDArray, K: NDArray, thr: float, *, zero_reach: float = 0.0) -> int | None:
    """The verdict in exact rational arithmetic, or None where it needs a special case.

    The matrices are taken exactly as the doubles they are; the characteristic polynomial
    is computed exactly (integer determinants, Newton interpolation) and shifted by the
    threshold, ``s = u + thr``; Routh's array then counts the roots with ``Re s > thr`` and
    Sturm's sequence the real ones among them. No rounding anywhere: a disc doublet split
    by 1e-10, or an exact one, is decided like any other point.

    With ``zero_reach`` > ``thr`` (the reach of a zero root split by the rounding of the
    matrices, see :data:`~squealkit.stability._verdicts.ZERO_ROOT_REACH`), the roots beyond
    ``zero_reach`` decide; where the only roots beyond ``thr`` lie within ``zero_reach``
    they may be a rigid-body mode's rounding, and the point is indeterminate.
    """
    def count(h: float) -> tuple[list[int], int | None]:
        p = _shifted_char_poly(M, C, K, h)
        if p[-1] < 0:
            p = [-x for x in p]
        return p, _right_half_plane_roots(p)

    p, unstable = count(thr)
    if unstable is None:
        return None
    if unstable and zero_reach > thr:
        p_far, far = count(zero_reach)
        if far is None:
            return None
        if far == 0:
            return INDETERMINATE
        p, unstable = p_far, far
    if unstable == 0:
        return STABLE
    real = _positive_real_roots(p)
    if real is None:
        return None
    return DIVERGENCE if real > 0 else FLUTTER
