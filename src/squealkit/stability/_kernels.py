"""Compiled kernels: eigenvalues of quadratic eigenproblems over large grids.

For ``(M s^2 + C s + K) x = 0`` with small n the eigenvalues are the 2n roots of the
characteristic polynomial ``det(M s^2 + C s + K)``. Per grid point we

1. expand the determinant (Leibniz formula over the n! permutations; each entry is a
   quadratic in s),
2. scale s by the geometric mean of the root moduli so the monic polynomial has O(1) roots,
3. find all roots at once by the Aberth-Ehrlich iteration (cubically convergent, Gauss-
   Seidel updates), warm-started from the neighbouring grid point's roots,
4. fall back to LAPACK (``eigvals`` of the companion matrix) at any point where the
   iteration does not converge.

Grid points are processed in chunks in parallel; each chunk starts cold from LAPACK.
This replaces a generic ``geev`` call per 2n x 2n state matrix (tens of microseconds of
call overhead and Hessenberg reduction) by a few hundred flops per point.
"""

from __future__ import annotations

import itertools

import numba as nb
import numpy as np

_MAX_ITER = 60
# No fast-math: with it, a freshly compiled kernel and the same kernel loaded from numba's
# cache gave results differing in the last bits, so a Dask worker (cache) and the process
# that compiled could disagree. Strict IEEE arithmetic costs no measurable speed here.
#: relative tolerance of the Vieta check of warm-started roots
_TOL_VIETA = 1.0e-10
#: a correction this small is rounding noise
_TOL_ROUNDING = 1.0e-14
#: a correction this small, after a superlinear step, leaves an error ~ its cube
_TOL_FAST = 1.0e-6
#: at acceptance the Newton step may exceed the Aberth step by at most this factor (plus
#: _TOL_NEWTON): near a double root Newton's step is about half of the Aberth step, while a
#: guess held off a root by the repulsion term alone has a Newton step many times larger
_NEWTON_RATIO = 4.0
_TOL_NEWTON = 1.0e-12


def permutations_table(n: int) -> tuple[np.ndarray, np.ndarray]:
    """All permutations of ``range(n)`` and their signs, for the Leibniz formula."""
    perms = np.array(list(itertools.permutations(range(n))), dtype=np.int64)
    signs = np.empty(len(perms), dtype=np.float64)
    for i, p in enumerate(perms):
        inv = sum(1 for a in range(n) for b in range(a + 1, n) if p[a] > p[b])
        signs[i] = -1.0 if inv % 2 else 1.0
    return perms, signs


@nb.njit(cache=True, nogil=True)
def _charpoly(M, C, K, perms, signs, out, tmp_a, tmp_b):
    """Coefficients (ascending powers) of det(M s^2 + C s + K) into ``out`` (length 2n+1)."""
    n = M.shape[0]
    for i in range(2 * n + 1):
        out[i] = 0.0
    for p in range(perms.shape[0]):
        # product of the quadratics M[i,pi] s^2 + C[i,pi] s + K[i,pi], i = 0..n-1
        tmp_a[0] = 1.0
        deg = 0
        for i in range(n):
            j = perms[p, i]
            k0 = K[i, j]
            c1 = C[i, j]
            m2 = M[i, j]
            if k0 == 0.0 and c1 == 0.0 and m2 == 0.0:
                deg = -1
                break
            for d in range(deg + 3):
                tmp_b[d] = 0.0
            for d in range(deg + 1):
                a = tmp_a[d]
                tmp_b[d] += a * k0
                tmp_b[d + 1] += a * c1
                tmp_b[d + 2] += a * m2
            deg += 2
            for d in range(deg + 1):
                tmp_a[d] = tmp_b[d]
        if deg < 0:
            continue
        s = signs[p]
        for d in range(deg + 1):
            out[d] += s * tmp_a[d]


@nb.njit(cache=True, nogil=True)
def _companion_roots(b, roots):
    """Roots of the monic polynomial sum b[k] z^k (b[deg] = 1) by LAPACK on its companion."""
    deg = b.shape[0] - 1
    A = np.zeros((deg, deg), dtype=np.complex128)
    for i in range(1, deg):
        A[i, i - 1] = 1.0
    for i in range(deg):
        A[i, deg - 1] = -b[i]
    w = np.linalg.eigvals(A)
    for i in range(deg):
        roots[i] = w[i]


@nb.njit(cache=True, nogil=True, inline="always")
def _horner(b, z):
    """p(z) and p'(z) of the polynomial with ascending real coefficients ``b``."""
    deg = b.shape[0] - 1
    p = complex(b[deg])
    dp = 0j
    for d in range(deg - 1, -1, -1):
        dp = dp * z + p
        p = p * z + b[d]
    return p, dp


@nb.njit(cache=True, nogil=True)
def _aberth(b, z):
    """Refine all roots ``z`` of the monic polynomial ``b`` in place; True if converged.

    Stops when the largest relative correction is at rounding level, or when it is small
    and shrank superlinearly from the sweep before (cubic convergence: the error left is
    then about its cube). Near a multiple root convergence is only linear and the loop
    goes on until rounding level or ``_MAX_ITER``.
    """
    deg = b.shape[0] - 1
    prev = np.inf
    for _ in range(_MAX_ITER):
        worst = 0.0
        newton = 0.0
        for k in range(deg):
            zk = z[k]
            p, dp = _horner(b, zk)
            if p == 0j:
                continue
            ratio = p / dp if dp != 0j else complex(np.inf)
            acc = 0j
            for j in range(deg):
                if j != k:
                    diff = zk - z[j]
                    if diff == 0j:
                        return False
                    acc += 1.0 / diff
            w = ratio / (1.0 - ratio * acc)
            if not (np.isfinite(w.real) and np.isfinite(w.imag)):
                return False
            z[k] = zk - w
            mag = abs(z[k])
            mag = mag if mag > 1e-300 else 1.0
            rel = abs(w) / mag
            if rel > worst:
                worst = rel
            rel_newton = abs(ratio) / mag
            if rel_newton > newton:
                newton = rel_newton
        if worst <= _TOL_ROUNDING or (worst <= _TOL_FAST and worst <= prev * prev):
            # A root, even a multiple one, has Newton and Aberth steps of one size; where the
            # Aberth repulsion alone keeps the step small (a trap, not a root), they differ.
            return newton <= _NEWTON_RATIO * worst + _TOL_NEWTON
        prev = worst
    return False


@nb.njit(cache=True, nogil=True)
def _aberth_conj(b, u):
    """Aberth-Ehrlich on the n upper-half-plane roots ``u`` of a real polynomial of degree 2n.

    The other n roots are the conjugates, so only n polynomial evaluations are needed per
    sweep; the conjugates enter the Aberth sum directly. Returns False (caller falls back
    to the general iteration) if a root approaches the real axis or anything goes wrong.
    """
    n = u.shape[0]
    prev = np.inf
    for _ in range(_MAX_ITER):
        worst = 0.0
        newton = 0.0
        for k in range(n):
            zk = u[k]
            p, dp = _horner(b, zk)
            if p == 0j:
                continue
            if dp == 0j:
                return False
            ratio = p / dp
            acc = 1.0 / (zk - zk.conjugate())
            for j in range(n):
                acc += 1.0 / (zk - u[j].conjugate())
                if j != k:
                    diff = zk - u[j]
                    if diff == 0j:
                        return False
                    acc += 1.0 / diff
            w = ratio / (1.0 - ratio * acc)
            if not (np.isfinite(w.real) and np.isfinite(w.imag)):
                return False
            znew = zk - w
            mag = abs(znew)
            if not znew.imag > 1e-9 * mag:
                return False
            u[k] = znew
            rel = abs(w) / mag
            if rel > worst:
                worst = rel
            rel_newton = abs(ratio) / mag
            if rel_newton > newton:
                newton = rel_newton
        if worst <= _TOL_ROUNDING or (worst <= _TOL_FAST and worst <= prev * prev):
            return newton <= _NEWTON_RATIO * worst + _TOL_NEWTON
        prev = worst
    return False


@nb.njit(cache=True, nogil=True)
def _vieta_ok(b, z, m, conj):
    """Whether the roots z[:m] (with their conjugates when ``conj``) are all of monic ``b``'s roots.

    Checks the first two elementary symmetric functions against the coefficients (Vieta):
    two approximations that converged onto one root, leaving another out (possible when a
    warm start sits at a double root), change them by far more than rounding, while they
    stay well-conditioned when the roots themselves are not (near a double root).
    """
    deg = b.shape[0] - 1
    e1 = 0.0 + 0.0j
    p2 = 0.0 + 0.0j
    mag = 0.0
    for k in range(m):
        zk = z[k]
        if conj:
            e1 += 2.0 * zk.real
            p2 += 2.0 * (zk * zk).real
            mag += 2.0 * abs(zk)
        else:
            e1 += zk
            p2 += zk * zk
            mag += abs(zk)
    e2 = 0.5 * (e1 * e1 - p2)
    tol = _TOL_VIETA * max(mag, 1.0)
    return abs(e1 + b[deg - 1]) <= tol and abs(e2 - b[deg - 2]) <= tol * max(mag, 1.0)


@nb.njit(cache=True, nogil=True)
def _solve_chunk(M, C, K0, Kn, Kf, g, e, perms, signs, roots, start, stop):
    n = M.shape[0]
    deg = 2 * n
    K = np.empty((n, n))
    a = np.empty(deg + 1)
    b = np.empty(deg + 1)
    tmp_a = np.empty(deg + 3)
    tmp_b = np.empty(deg + 3)
    z = np.empty(deg, dtype=np.complex128)
    u = np.empty(n, dtype=np.complex128)
    pw = np.empty(deg + 1)
    w0 = 1.0
    have_scale = False
    n_guess = 0
    n_conj = 0
    n_fallback = 0
    for idx in range(start, stop):
        gi = g[idx]
        ei = e[idx]
        for r in range(n):
            for c in range(n):
                K[r, c] = K0[r, c] + gi * Kn[r, c] + ei * Kf[r, c]
        _charpoly(M, C, K, perms, signs, a, tmp_a, tmp_b)
        lead = a[deg]
        if not have_scale:
            # scale s = w0 z so that the monic polynomial in z has unit geometric-mean
            # roots; one scale per chunk (roots vary little between neighbours)
            c0 = abs(a[0])
            w0 = (c0 / abs(lead)) ** (1.0 / deg) if c0 > 0.0 else 1.0
            for d in range(deg + 1):
                pw[d] = w0 ** (d - deg)
            have_scale = True
        for d in range(deg):
            b[d] = a[d] * pw[d] / lead
        b[deg] = 1.0
        # fast path: only the n upper roots, predicted from the previous points
        converged = False
        if n_conj > 0:
            for k in range(n):
                zk = roots[idx - 1, k]
                if n_conj > 1:
                    zk = 2.0 * zk - roots[idx - 2, k]
                u[k] = zk / w0
            if _aberth_conj(b, u) and _vieta_ok(b, u, n, True):
                for k in range(n):
                    roots[idx, k] = u[k] * w0
                    roots[idx, n + k] = u[k].conjugate() * w0
                n_conj += 1
                n_guess += 1
                continue
        if n_guess > 0:
            for k in range(deg):
                zk = roots[idx - 1, k]
                if n_guess > 1:
                    zk = 2.0 * zk - roots[idx - 2, k]
                z[k] = zk / w0
            converged = _aberth(b, z) and _vieta_ok(b, z, deg, False)
        if not converged:
            _companion_roots(b, z)
            converged = _aberth(b, z)
            n_fallback += 1
            if not converged:
                _companion_roots(b, z)
        # store with the upper roots first when every root is complex (enables the fast path)
        n_up = 0
        for k in range(deg):
            if z[k].imag > 1e-9 * abs(z[k]):
                u[n_up % n] = z[k]
                n_up += 1
        if n_up == n:
            for k in range(n):
                roots[idx, k] = u[k] * w0
                roots[idx, n + k] = u[k].conjugate() * w0
            n_conj = 1
        else:
            for k in range(deg):
                roots[idx, k] = z[k] * w0
            n_conj = 0
        n_guess += 1
    return n_fallback


@nb.njit(cache=True, parallel=True)
def quadratic_eigvals(M, C, K0, Kn, Kf, g, e, perms, signs, roots, chunk, row):
    """All 2n eigenvalues of ``M s^2 + C s + K`` with ``K = K0 + g[i] Kn + e[i] Kf``.

    Fills ``roots`` (shape (len(g), 2n)); returns the number of cold (LAPACK) starts.
    The points are rows of ``row`` points each; every row is solved in pieces of at most
    ``chunk`` points from its start, each piece warm-starting point by point from a cold
    first point. So a row's eigenvalues depend only on that row, not on which other rows
    share the call: any split of a grid into blocks of rows gives identical numbers.
    """
    npts = g.shape[0]
    nrows = (npts + row - 1) // row
    per_row = (row + chunk - 1) // chunk
    nchunks = nrows * per_row
    counts = np.zeros(nchunks, dtype=np.int64)
    for c in nb.prange(nchunks):
        r0 = (c // per_row) * row
        start = r0 + (c % per_row) * chunk
        stop = min(npts, r0 + row, start + chunk)
        if start < stop:
            counts[c] = _solve_chunk(M, C, K0, Kn, Kf, g, e, perms, signs, roots, start, stop)
    return counts.sum()


@nb.njit(cache=True, parallel=True)
def select_modes(roots, out):
    """Pick n of the 2n roots per point, one per conjugate pair, lowest frequency first.

    Of each complex pair the root with Im > 0 is kept; of real roots (overdamped or
    divergent modes) the largest, so the most unstable root is never dropped. Sorting by
    imaginary part descending (ties by real part descending) and taking the first n does
    exactly that; the n are then written in ascending frequency.
    """
    npts, deg = roots.shape
    n = out.shape[1]
    for i in nb.prange(npts):
        r = roots[i].copy()
        for a in range(1, deg):  # insertion sort, deg is tiny
            key = r[a]
            j = a - 1
            while j >= 0 and (
                r[j].imag < key.imag or (r[j].imag == key.imag and r[j].real < key.real)
            ):
                r[j + 1] = r[j]
                j -= 1
            r[j + 1] = key
        for k in range(n):
            out[i, k] = r[n - 1 - k]


@nb.njit(cache=True, parallel=True)
def derived_quantities(lam, unstable_rtol, lock_rtol):
    """Per-mode and per-point quantities of a stability map in one pass.

    ``lam`` has shape (npts, n). Returns growth rate, omega, damping ratio, the unstable
    flag per mode, and per point the largest growth rate, whether any mode is unstable
    and whether two modes have locked in (frequencies within ``lock_rtol``, one unstable).
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
        mag_max = 0.0
        for k in range(n):
            mag_max = max(mag_max, abs(lam[i, k]))
        thr = unstable_rtol * mag_max
        best = -np.inf
        anyu = False
        for k in range(n):
            s = lam[i, k].real
            w = lam[i, k].imag
            mag = abs(lam[i, k])
            sigma[i, k] = s
            omega[i, k] = w
            zeta[i, k] = -s / mag if mag > 0.0 else 0.0
            u = s > thr
            unstable[i, k] = u
            anyu = anyu or u
            best = max(best, s)
        smax[i] = best
        any_u[i] = anyu
        lk = False
        for k in range(n):
            for m in range(k + 1, n):
                if unstable[i, k] or unstable[i, m]:
                    wk = omega[i, k]
                    wm = omega[i, m]
                    if abs(wk - wm) <= lock_rtol * max(abs(wk), abs(wm)):
                        lk = True
        locked[i] = lk
    return sigma, omega, zeta, unstable, smax, any_u, locked


@nb.njit(cache=True, parallel=True)
def quadratic_eigvals_stack(M, C, K0, Kn, Kf, g, e, perms, signs, roots):
    """All 2n eigenvalues for a stack of S models, each over its own row of P points.

    ``M``, ``C``, ``K0``, ``Kn``, ``Kf`` have shape (S, n, n); ``g`` and ``e`` (S, P);
    ``roots`` (S, P, 2n) is filled. Each model's row is solved on its own, from a cold first
    point and then warm-started point by point, so a model's eigenvalues depend only on it
    and its row, never on the rest of the stack.
    """
    nmod = g.shape[0]
    npts = g.shape[1]
    # start as a plain int64 (a literal 0 would compile a second specialization of
    # _solve_chunk beside the one quadratic_eigvals uses)
    start = npts - npts
    for s in nb.prange(nmod):
        _solve_chunk(M[s], C[s], K0[s], Kn[s], Kf[s], g[s], e[s], perms, signs, roots[s], start, npts)
