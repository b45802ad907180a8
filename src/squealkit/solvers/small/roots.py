"""Compiled kernels: eigenvalues of quadratic eigenproblems over large grids.

For ``(M s^2 + C s + K) x = 0`` with small n the eigenvalues are the 2n roots of the
characteristic polynomial ``det(M s^2 + C s + K)``. Per grid point we

1. expand the determinant (Leibniz formula over the n! permutations; each entry is a
   quadratic in s). Over a grid of one model the expansion is done once, as a polynomial in
   s and the contact factors g, e (:func:`charpoly_table`), and evaluated per point,
2. scale s by the geometric mean of the root moduli so the monic polynomial has O(1) roots,
3. find all roots at once by the Aberth-Ehrlich iteration (cubically convergent, Gauss-
   Seidel updates), warm-started from the neighbouring grid point's roots,
4. fall back to LAPACK (``eigvals`` of the companion matrix) at any point where the
   iteration does not converge.

Grid points are processed in chunks in parallel; each chunk starts cold from LAPACK.
This replaces a generic ``geev`` call per 2n x 2n state matrix (tens of microseconds of
call overhead and Hessenberg reduction) by a few hundred flops per point.

Every root leaves with an a-posteriori error radius from the kernel's own rounding
(:func:`inclusion_radii`); what the roots mean (a verdict per point, one root per mode,
growth rates and lock-in) is the stability analysis' reading of them, in :mod:`squealkit.stability._verdicts`.
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
def charpoly_table(M, C, K0, Kn, Kf, perms, signs):
    """det(M s^2 + C s + K0 + g Kn + e Kf) as a polynomial in (s, g, e), once per model.

    Returns ``T`` of shape (2n+1, n+1, n+1) with ``det = sum T[d, i, j] s^d g^i e^j``
    (``i + j <= n``), by the Leibniz formula on entries that are polynomials in all three
    variables. A grid of contact factors (g, e) then costs (n+1)(n+2)/2 (2n+1) multiply-adds
    per point instead of a Leibniz expansion per point. Rounding: every coefficient is a
    signed sum of products of entries, so its error is bounded by a few eps times the same
    sum in absolute values, which :func:`_radii_range` accounts for.
    """
    n = M.shape[0]
    deg = 2 * n
    T = np.zeros((deg + 1, n + 1, n + 1))
    ta = np.zeros((deg + 3, n + 2, n + 2))
    tb = np.zeros((deg + 3, n + 2, n + 2))
    for p in range(perms.shape[0]):
        ta[:, :, :] = 0.0
        ta[0, 0, 0] = 1.0
        for r in range(n):
            c = perms[p, r]
            m2 = M[r, c]
            c1 = C[r, c]
            k0 = K0[r, c]
            kn = Kn[r, c]
            kf = Kf[r, c]
            tb[:, :, :] = 0.0
            # degrees so far: s <= 2r, g + e <= r
            for d in range(2 * r + 1):
                for i in range(r + 1):
                    for j in range(r + 1 - i):
                        a = ta[d, i, j]
                        if a == 0.0:
                            continue
                        tb[d, i, j] += a * k0
                        tb[d + 1, i, j] += a * c1
                        tb[d + 2, i, j] += a * m2
                        tb[d, i + 1, j] += a * kn
                        tb[d, i, j + 1] += a * kf
            ta, tb = tb, ta  # no array copy: numba compiles its shape-mismatch message (~10 s) for one
        sg = signs[p]
        for d in range(deg + 1):
            for i in range(n + 1):
                for j in range(n + 1 - i):
                    T[d, i, j] += sg * ta[d, i, j]
    return T


@nb.njit(cache=True, nogil=True, inline="always")
def _eval_table(T, gi, ei, gp, ep, out):
    """Coefficients (ascending powers of s) of the table ``T`` at contact factors (gi, ei)."""
    n = gp.shape[0] - 1
    gp[0] = 1.0
    ep[0] = 1.0
    for i in range(1, n + 1):
        gp[i] = gp[i - 1] * gi
        ep[i] = ep[i - 1] * ei
    for d in range(T.shape[0]):
        acc = 0.0
        for i in range(n + 1):
            row = 0.0
            for j in range(n + 1 - i):
                row += T[d, i, j] * ep[j]
            acc += row * gp[i]
        out[d] = acc


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


@nb.njit(cache=True, nogil=True, inline="always")
def _div(a, d):
    """a / d for complex numbers, without the overflow guards of the general division: the
    kernel's numbers are O(1) (scaled polynomial), and an underflowing |d|^2 gives a
    non-finite result that the callers treat as failure."""
    den = d.real * d.real + d.imag * d.imag
    return complex((a.real * d.real + a.imag * d.imag) / den, (a.imag * d.real - a.real * d.imag) / den)


@nb.njit(cache=True, nogil=True)
def _aberth_conj(b, u):
    """Aberth-Ehrlich on the n upper-half-plane roots ``u`` of a real polynomial of degree 2n.

    The other n roots are the conjugates, so only n polynomial evaluations are needed per
    sweep; the conjugates enter the Aberth sum directly. Returns False (caller falls back
    to the general iteration) if a root approaches the real axis or anything goes wrong.
    The same stopping rule as :func:`_aberth`, on squared magnitudes (no square roots in
    the loop: this is the kernel's hot path).
    """
    n = u.shape[0]
    prev2 = np.inf
    one = 1.0 + 0.0j
    for _ in range(_MAX_ITER):
        worst2 = 0.0
        newton2 = 0.0
        for k in range(n):
            zk = u[k]
            p, dp = _horner(b, zk)
            if p == 0j:
                continue
            if dp == 0j:
                return False
            ratio = _div(p, dp)
            acc = _div(one, complex(0.0, 2.0 * zk.imag))
            for j in range(n):
                acc += _div(one, zk - u[j].conjugate())
                if j != k:
                    diff = zk - u[j]
                    if diff == 0j:
                        return False
                    acc += _div(one, diff)
            w = _div(ratio, 1.0 - ratio * acc)
            if not (np.isfinite(w.real) and np.isfinite(w.imag)):
                return False
            znew = zk - w
            mag2 = znew.real * znew.real + znew.imag * znew.imag
            if not (znew.imag > 0.0 and znew.imag * znew.imag > 1e-18 * mag2):
                return False
            u[k] = znew
            rel2 = (w.real * w.real + w.imag * w.imag) / mag2
            if rel2 > worst2:
                worst2 = rel2
            rn2 = (ratio.real * ratio.real + ratio.imag * ratio.imag) / mag2
            if rn2 > newton2:
                newton2 = rn2
        if worst2 <= _TOL_ROUNDING * _TOL_ROUNDING or (worst2 <= _TOL_FAST * _TOL_FAST and worst2 <= prev2 * prev2):
            return np.sqrt(newton2) <= _NEWTON_RATIO * np.sqrt(worst2) + _TOL_NEWTON
        prev2 = worst2
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
def _solve_chunk(M, C, K0, Kn, Kf, g, e, perms, signs, table, Knx, Kfx, st, roots, start, stop):
    """Roots of points ``start:stop``; the polynomial from ``table`` (see
    :func:`charpoly_table`) when it is not empty, else by the Leibniz formula per point.

    With slope parts (``st`` not empty: consistent contact kinematics), point i has
    ``K = K0 + g Kn + e Kf + st[i] (g Knx + e Kfx)`` (``st = s tan(theta)``), still warm-started
    along the row.
    """
    n = M.shape[0]
    use_table = table.shape[0] > 0
    has_slope = st.shape[0] > 0
    gp = np.empty(n + 1)
    ep = np.empty(n + 1)
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
        if use_table:
            _eval_table(table, gi, ei, gp, ep, a)
        else:
            for r in range(n):
                for c in range(n):
                    K[r, c] = K0[r, c] + gi * Kn[r, c] + ei * Kf[r, c]
            if has_slope:
                sti = st[idx]
                for r in range(n):
                    for c in range(n):
                        K[r, c] += sti * (gi * Knx[r, c] + ei * Kfx[r, c])
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
def quadratic_eigvals(M, C, K0, Kn, Kf, g, e, perms, signs, table, Knx, Kfx, st, roots, radii, even, chunk, row):
    """All 2n eigenvalues of ``M s^2 + C s + K`` with ``K = K0 + g[i] Kn + e[i] Kf``.

    Fills ``roots`` (shape (len(g), 2n)), their error radii ``radii`` and the flag ``even``
    (see :func:`_radii_range`); returns the number of cold (LAPACK) starts.
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
            counts[c] = _solve_chunk(M, C, K0, Kn, Kf, g, e, perms, signs, table, Knx, Kfx, st, roots, start, stop)
            _radii_range(M, C, K0, Kn, Kf, g, e, perms, signs, table, Knx, Kfx, st, roots, radii, even, start, stop)
    return counts.sum()


_EPS = 2.220446049250313e-16


@nb.njit(cache=True, nogil=True)
def inclusion_radii(z, lead, err_at, radius, member, pairs=False):
    """A-posteriori error radius of each computed root ``z`` of a polynomial with leading
    coefficient ``lead``, whose value is uncertain by ``err_at[k]`` at ``z[k]``.

    A perturbation of size ``delta`` moves the roots of a cluster of m close roots by about
    ``(delta / (|lead| prod_{j outside} |z - z_j|))^(1/m)``: for a simple root this is the
    classical ``delta / |p'(z)|``; near a double or multiple root (doublets, lock-in) the
    m-th root makes the radius as large as rounding can really move the roots. A cluster is
    grown until no other root lies within twice its radius. ``member`` is a boolean work
    array of length ``len(z)``. With ``pairs`` the second half of ``z`` holds the
    conjugates of the first, whose radii are the same.
    """
    deg = z.shape[0]
    half = deg // 2
    alead = abs(lead)
    for k in range(half if pairs else deg):
        zk = z[k]
        # the common case first: a simple root, no other root within twice its radius
        prod2 = 1.0
        near2 = np.inf
        for j in range(deg):
            if j != k:
                d = zk - z[j]
                d2 = d.real * d.real + d.imag * d.imag
                prod2 *= d2
                near2 = min(near2, d2)
        prod = alead * np.sqrt(prod2)
        if prod > 0.0 and err_at[k] < np.inf:
            r = err_at[k] / prod
            if 4.0 * r * r < near2:
                radius[k] = r
                if pairs:
                    radius[half + k] = r
                continue
        for j in range(deg):
            member[j] = j == k
        m = 1
        r = 0.0
        for _ in range(deg):
            prod2 = 1.0
            for j in range(deg):
                if not member[j]:
                    d = zk - z[j]
                    prod2 *= d.real * d.real + d.imag * d.imag
            prod = abs(lead) * np.sqrt(prod2)
            if prod > 0.0 and err_at[k] < np.inf:
                r = err_at[k] / prod if m == 1 else (err_at[k] / prod) ** (1.0 / m)
            else:
                r = np.inf
            grown = False
            lim = 4.0 * r * r
            for j in range(deg):
                if not member[j]:
                    d = z[j] - zk
                    if d.real * d.real + d.imag * d.imag <= lim:
                        member[j] = True
                        m += 1
                        grown = True
            if not grown:
                break
        radius[k] = r
        if pairs:
            radius[half + k] = r


@nb.njit(cache=True, nogil=True)
def _radii_range(M, C, K0, Kn, Kf, g, e, perms, signs, table, Knx, Kfx, st, roots, radii, even, start, stop):
    """Error radius of every root of points ``start:stop`` from the kernel's own rounding.

    Each coefficient of ``det(M s^2 + C s + K)`` is a signed sum of Leibniz terms; its
    rounding error is at most ``gamma`` (a few eps per operation) times the same sum taken
    in absolute value, and that sum, evaluated at ``|s|``, is the permanent of
    ``|M| |s|^2 + |C| |s| + |K|``, which is at most the product of its row sums. So
    ``gamma prod_i (m_i |s|^2 + c_i |s| + k_i)`` (row sums of absolute entries) bounds the
    polynomial's error at s, and :func:`inclusion_radii` turns it into a radius per root.
    Where the polynomial came from :func:`charpoly_table` (``table`` not empty), each
    coefficient is a signed sum of products of entries of M, C, K0, Kn, Kf and the powers
    of g and e, so the same argument holds with ``|K0| + |g| |Kn| + |e| |Kf|`` in place of
    ``|K|`` and a gamma that also counts the table's longer sums and its evaluation.
    Roots stored as conjugate pairs (the kernel's fast path) share one radius.
    ``even[i]`` is set where the polynomial is even in s (C = 0, or C skew and K symmetric:
    roots in pairs +-s).
    """
    n = M.shape[0]
    deg = 2 * n
    use_table = table.shape[0] > 0
    if use_table:
        gamma = 4.0 * (11 * n + perms.shape[0] + 8) * _EPS
    else:
        gamma = 4.0 * (4 * n + perms.shape[0] + 8) * _EPS
    a = np.empty(deg + 1)
    tmp_a = np.empty(deg + 3)
    tmp_b = np.empty(deg + 3)
    err_at = np.empty(deg)
    member = np.empty(deg, dtype=np.bool_)
    rm = np.zeros(n)
    rc = np.zeros(n)
    rk = np.empty(n)
    ak0 = np.zeros(n)
    akn = np.zeros(n)
    akf = np.zeros(n)
    # the leading coefficient, det(M), does not depend on the point
    _charpoly(M, C, K0, perms, signs, a, tmp_a, tmp_b)
    lead = a[deg]
    c_zero = True
    c_skew = True
    for r in range(n):
        for c in range(n):
            rm[r] += abs(M[r, c])
            rc[r] += abs(C[r, c])
            ak0[r] += abs(K0[r, c])
            akn[r] += abs(Kn[r, c])
            akf[r] += abs(Kf[r, c])
            if C[r, c] != 0.0:
                c_zero = False
            if C[r, c] != -C[c, r]:
                c_skew = False
    for i in range(start, stop):
        gi = g[i]
        ei = e[i]
        k_sym = True
        if use_table:
            for r in range(n):
                rk[r] = ak0[r] + abs(gi) * akn[r] + abs(ei) * akf[r]
        check_sym = c_skew and not c_zero
        sti = st[i] if st.shape[0] > 0 else 0.0
        if check_sym or not use_table:
            for r in range(n):
                acc = 0.0
                for c in range(n):
                    kij = K0[r, c] + gi * Kn[r, c] + ei * Kf[r, c]
                    if sti != 0.0:
                        kij += sti * (gi * Knx[r, c] + ei * Kfx[r, c])
                    acc += abs(kij)
                    if check_sym and c > r:
                        kji = K0[c, r] + gi * Kn[c, r] + ei * Kf[c, r]
                        if sti != 0.0:
                            kji += sti * (gi * Knx[c, r] + ei * Kfx[c, r])
                        if kij != kji:
                            k_sym = False
                if not use_table:
                    rk[r] = acc
        pairs = True
        for k in range(n):
            if roots[i, n + k] != roots[i, k].conjugate():
                pairs = False
        for k in range(n if pairs else deg):
            x = abs(roots[i, k])
            acc = gamma
            for r in range(n):
                acc *= (rm[r] * x + rc[r]) * x + rk[r]
            err_at[k] = acc
        if pairs:
            for k in range(n):
                err_at[n + k] = err_at[k]
        inclusion_radii(roots[i], lead, err_at, radii[i], member, pairs)
        even[i] = c_zero or (c_skew and k_sym)


@nb.njit(cache=True, parallel=True)
def quadratic_eigvals_stack(M, C, K0, Kn, Kf, g, e, perms, signs, roots, radii, even):
    """All 2n eigenvalues for a stack of S models, each over its own row of P points.

    ``M``, ``C``, ``K0``, ``Kn``, ``Kf`` have shape (S, n, n); ``g`` and ``e`` (S, P);
    ``roots`` (S, P, 2n), their error radii ``radii`` (S, P, 2n) and ``even`` (S, P) are
    filled. Each model's row is solved on its own, from a cold first
    point and then warm-started point by point, so a model's eigenvalues depend only on it
    and its row, never on the rest of the stack.
    """
    nmod = g.shape[0]
    npts = g.shape[1]
    # start as a plain int64 (a literal 0 would compile a second specialization of
    # _solve_chunk beside the one quadratic_eigvals uses)
    start = npts - npts
    # one point per model, mostly: the Leibniz formula per point beats a table per model
    no_table = np.empty((0, 0, 0))
    no_slope = np.empty((0, 0))
    no_st = np.empty(0)
    for s in nb.prange(nmod):
        _solve_chunk(M[s], C[s], K0[s], Kn[s], Kf[s], g[s], e[s], perms, signs, no_table, no_slope, no_slope, no_st,
                     roots[s], start, npts)
        _radii_range(M[s], C[s], K0[s], Kn[s], Kf[s], g[s], e[s], perms, signs, no_table, no_slope, no_slope, no_st,
                     roots[s], radii[s], even[s], start, npts)
