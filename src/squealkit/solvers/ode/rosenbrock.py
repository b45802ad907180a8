"""Rodas4, linearly implicit, with the analytic Jacobian, for stiff friction laws (``integrate_rosenbrock``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .adaptive import _adaptive_for
from .force import _contact, _f, _forcing, _jacobian

# -- stiff integration: Rodas4 (linearly implicit Rosenbrock 4(3)) with the analytic Jacobian -----
#
# Hairer & Wanner, Solving ODEs II (2nd ed. 1996), sec. IV.7, Table 7.2 and code RODAS (method 1,
# "RODAS4"): 6 stages, order 4, embedded order 3, stiffly accurate, L-stable, with a 3rd-order
# dense output. In the transformed variables u_i of eq. (7.25):
#   (I / (h gamma) - J) u_i = f(t + alpha_i h, z + sum_j a_ij u_j) + sum_j (c_ij / h) u_j + h d_i f_t
#   z1 = z + sum_j m_j u_j,   error estimate u_6
# dense output  z(t + s h) = (1 - s) z + s (z1 + (1 - s) (D2.u + s D3.u)).
# The transient driver passes the coefficients (:class:`.bundles.Rodas4Tableau`). The loop around the step
# (control, events, output) is :mod:`.adaptive`'s, shared with Dormand-Prince.


@njit(cache=True, inline="always")
def _lu(A, piv):
    """In-place LU factorisation with partial pivoting; returns False if singular."""
    m = A.shape[0]
    for k in range(m):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, m):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        piv[k] = p
        if big == 0.0 or not (big < 1e300):
            return False
        if p != k:
            for j in range(m):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        for i in range(k + 1, m):
            A[i, k] /= A[k, k]
            lik = A[i, k]
            for j in range(k + 1, m):
                A[i, j] -= lik * A[k, j]
    return True


@njit(cache=True, inline="always")
def _lu_solve(A, piv, x):
    """Solve in place with the factors of :func:`_lu`."""
    m = A.shape[0]
    for k in range(m):
        p = piv[k]
        if p != k:
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
    for i in range(m):
        acc = x[i]
        for j in range(i):
            acc -= A[i, j] * x[j]
        x[i] = acc
    for i in range(m - 1, -1, -1):
        acc = x[i]
        for j in range(i + 1, m):
            acc -= A[i, j] * x[j]
        x[i] = acc / A[i, i]


@njit(cache=True)
def _rodas4_work(m, tab):
    """Rows f(t, z), f(t + dtf, z), f(t - dtf, z) and the stage's f; the stages U; the stage state; the
    matrix I / (h gamma) - J with its pivots; the Jacobian's blocks d(acc)/dx and d(acc)/dx'."""
    n = m // 2
    return (np.empty((4, m)), np.empty((tab.A.shape[0], m)), np.empty(m), np.empty((m, m)),
            np.empty(m, dtype=np.int64), np.empty((n, n)), np.empty((n, n)))


@njit(cache=True, error_model="numpy", _nrt=False)
def _rodas4_step(t, h, t_new, z, znew, work, tab, rhs, atol, rtol):
    """One Rodas4 step of ``h`` from (t, z) to ``znew``; returns ``(ok, err, rhs calls, contact force and
    sliding speed at t_new)`` (:func:`.force._contact`), ``ok`` False when I / (h gamma) - J is singular,
    err the RMS of the embedded error u_6 over ``atol + rtol max(|z|, |znew|)``. The Jacobian is analytic
    (:func:`_jacobian`) and evaluated every step, f_t by a central difference in time of the forcing.
    Compiled without reference counts (see :mod:`.adaptive`)."""
    Fs, U, zt, W, piv, Jx, Jv = work
    f0, ft, fa, F = Fs[0], Fs[1], Fs[2], Fs[3]
    RA, RC, RAL, RD, RM, gam = tab.A, tab.C, tab.alpha, tab.d, tab.m, tab.gamma
    tg0, hg, qg, tgr, mu, v, vq, kin, kc, s, mats, vecs, opts, _acc = rhs
    S = RA.shape[0]
    m = z.shape[0]
    n = m // 2
    dtf = 1e-4 * hg
    q = 0.0
    tt_ = 0.0
    # f(t, z) (f0), f_t and the Jacobian at the start of the step
    for c in range(3):  # one call site, so one inlined copy of _f
        tc = t if c == 0 else (t + dtf if c == 1 else t - dtf)
        _ncc, _mec, qc, ttc = _f(tc, z, Fs, c, rhs)
        if c == 0:
            q, tt_ = qc, ttc
    for i in range(m):
        ft[i] = (ft[i] - fa[i]) / (2.0 * dtf)
    _jacobian(z[:n], z[n:], q, tt_, mu, v, kin, kc, s, mats, vecs, opts, Jx, Jv)
    ihg = 1.0 / (h * gam)
    for i in range(m):
        for j in range(m):
            W[i, j] = 0.0
    for i in range(n):
        W[i, i] = ihg
        W[i, n + i] = -1.0
        for j in range(n):
            W[n + i, j] = -Jx[i, j]
            W[n + i, n + j] = -Jv[i, j]
        W[n + i, n + i] += ihg
    if not _lu(W, piv):
        return False, 0.0, 3, 0.0, 0.0
    # stages
    for k in range(S):
        if k == 0:
            for i in range(m):
                F[i] = f0[i]
        else:
            for i in range(m):
                a = 0.0
                for j in range(k):
                    a += RA[k, j] * U[j, i]
                zt[i] = z[i] + a
            _f(t + RAL[k] * h, zt, Fs, 3, rhs)
        for i in range(m):
            a = F[i] + h * RD[k] * ft[i]
            for j in range(k):
                a += RC[k, j] / h * U[j, i]
            U[k, i] = a
        _lu_solve(W, piv, U[k])
    for i in range(m):
        a = 0.0
        for j in range(S):
            a += RM[j] * U[j, i]
        znew[i] = z[i] + a
    err = 0.0
    for i in range(m):
        sc = atol[i] + rtol * max(abs(z[i]), abs(znew[i]))
        e = U[S - 1, i] / sc
        err += e * e
    qn, tn = _forcing(t_new, tg0, hg, qg, tgr, vq)
    g_new, w_new = _contact(znew, qn, tn, rhs)
    return True, math.sqrt(err / m), 3 + S - 1, g_new, w_new


@njit(cache=True, _nrt=False)
def _rodas4_advance(work):
    """Nothing: Rodas4 evaluates f(t, z) at the start of every step."""


_rodas4_run = _adaptive_for(_rodas4_work, _rodas4_step, _rodas4_advance, True, -0.25, 6.0)


@njit(cache=True, parallel=True)
def integrate_rosenbrock(state, model, forcing, span, tableau, control, out, log):
    """Advance each run from ``span.t_a`` to ``span.t_b`` by Rodas4 (see the notes above) with error control.

    Same bundles and conventions as :func:`.dp5.integrate_adaptive` (``tableau`` a
    :class:`.bundles.Rodas4Tableau`): the same loop (:mod:`.adaptive`) around Rodas4's step.
    """
    status = log.status
    # the run's index as int64: prange's own is unsigned in the parallel loop, and a second integer type
    # would compile the run's loop twice
    for r in prange(state.X.shape[0]):
        if status[r] == 0:
            _rodas4_run(np.int64(r), state, model, forcing, span, tableau, control, out, log)
