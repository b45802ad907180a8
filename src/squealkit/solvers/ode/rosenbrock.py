"""Rodas4, linearly implicit, with the analytic Jacobian, for stiff friction laws (``integrate_rosenbrock``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .events import (
    EVENT_CONTACT_CLOSES,
    EVENT_CONTACT_OPENS,
    EVENT_SLIP,
    EVENT_STICK,
    _dense_ros,
    _locate,
    _log_event,
    _store,
)
from .force import _bundle, _f, _f_call, _forcing, _gap_and_slip, _jacobian

# -- stiff integration: Rodas4 (linearly implicit Rosenbrock 4(3)) with the analytic Jacobian -----
#
# Hairer & Wanner, Solving ODEs II (2nd ed. 1996), sec. IV.7, Table 7.2 and code RODAS (method 1,
# "RODAS4"): 6 stages, order 4, embedded order 3, stiffly accurate, L-stable, with a 3rd-order
# dense output. In the transformed variables u_i of eq. (7.25):
#   (I / (h gamma) - J) u_i = f(t + alpha_i h, z + sum_j a_ij u_j) + sum_j (c_ij / h) u_j + h d_i f_t
#   z1 = z + sum_j m_j u_j,   error estimate u_6
# dense output  z(t + s h) = (1 - s) z + s (z1 + (1 - s) (D2.u + s D3.u)).
# simulate.py passes the coefficients (ROS_A, ROS_C, ROS_ALPHA, ROS_D, ROS_M, ROS_DENSE, gamma).


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


@njit(cache=True, parallel=True)
def integrate_rosenbrock(
    X, V, H, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, vq, opts,
    qg, tgr, tg0, hg, t_a, t_b, fs, o_first, o_last, o_base, RA, RC, RAL, RD, RM, RDD, gam, rtol, atol, h_max,
    out_x, out_v, out_a, out_nc, out_me, limit, status, n_valid, counts, ev_t, ev_k, n_ev,
):
    """Advance each run from ``t_a`` to ``t_b`` by Rodas4 (see the notes above) with error control.

    Same conventions as :func:`integrate_adaptive` (output by the method's dense output, contact
    sign changes located by bisection on it and the step retaken to end there, stick/slip events,
    ``counts``, ``status``); the Jacobian is analytic (:func:`_jacobian`) and evaluated every step,
    f_t by a central difference in time of the forcing.
    """
    R = X.shape[0]
    n = X.shape[1]
    m = 2 * n
    S = RA.shape[0]
    for r in prange(R):
        if status[r] != 0:
            continue
        z = np.empty(m)
        for i in range(n):
            z[i] = X[r, i]
            z[n + i] = V[r, i]
        U = np.empty((S, m))
        Fs = np.empty((4, m))  # f(t, z), f(t + dtf, z), f(t - dtf, z) and the stage's f, as rows
        f0, ft, fa, F = Fs[0], Fs[1], Fs[2], Fs[3]
        zt = np.empty(m)
        znew = np.empty(m)
        zd = np.empty(m)
        dzd1 = np.empty((1, m))
        dzd = dzd1[0]
        W = np.empty((m, m))
        piv = np.empty(m, dtype=np.int64)
        Jx = np.empty((n, n))
        Jv = np.empty((n, n))
        acc = np.empty(n)
        mu_r, v_r, vq_r, kc_r, s_r, kin_r = mu[r], v[r], vq[r], kc[r], s[r], kin[r]
        bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r = bM[r], fM[r], C[r], K0[r], Kn[r], Kf[r]
        Knx_r, Kfx_r, b_r, fhat_r = Knx[r], Kfx[r], b[r], fhat[r]
        mats, vecs = _bundle(C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, bM_r, fM_r, F0[r], fn[r], ff[r], b_r, fhat_r)
        qg_r, tg_r = qg[r], tgr[r]
        t = t_a
        h = H[r]
        o = o_first
        nc, me, q, tt_ = _f_call(t, z, Fs, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r, s_r, mats, vecs,
                                 opts, acc)
        counts[r, 2] += 1
        if o <= o_last and o / fs <= t + 1e-12 / fs:
            if not _store(r, o, o_base, z, f0, nc, me, limit, out_x, out_v, out_a, out_nc, out_me, n_valid):
                status[r] = 1
            o += 1
        g_old, w_old = _gap_and_slip(z[:n], z[n:], q, tt_, v_r, b_r, fhat_r, kc_r, s_r, kin_r)
        retake = False
        h_saved = h
        dtf = 1e-4 * hg
        while t < t_b and status[r] == 0:
            h_min = 1e-14 * max(1.0, abs(t)) + 1e-300
            if h > h_max[r]:
                h = h_max[r]
            last = False
            if t + h >= t_b:
                h = t_b - t
                last = True
            # f(t, z) (f0), f_t and the Jacobian at the start of the step
            for c in range(3):  # one call site, so one inlined copy of _f
                tc = t if c == 0 else (t + dtf if c == 1 else t - dtf)
                ncc, mec, qc, ttc = _f(tc, z, Fs, c, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r, s_r, mats,
                                       vecs, opts, acc)
                if c == 0:
                    nc, me, q, tt_ = ncc, mec, qc, ttc
            for i in range(m):
                ft[i] = (ft[i] - fa[i]) / (2.0 * dtf)
            counts[r, 2] += 3
            _jacobian(z[:n], z[n:], q, tt_, mu_r, v_r, C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, kin_r, bM_r, fM_r,
                      b_r, fhat_r, kc_r, s_r, opts, Jx, Jv)
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
                counts[r, 1] += 1
                h *= 0.5
                if h < h_min:
                    status[r] = 2
                continue
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
                    _f(t + RAL[k] * h, zt, Fs, 3, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r, s_r, mats, vecs,
                       opts, acc)
                    counts[r, 2] += 1
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
            t_new = t + h if not last else t_b
            err = 0.0
            for i in range(m):
                sc = atol[r, i] + rtol * max(abs(z[i]), abs(znew[i]))
                e = U[S - 1, i] / sc
                err += e * e
            err = math.sqrt(err / m)
            if not (err <= 1.0):
                counts[r, 1] += 1
                fac = 0.9 * err ** -0.25 if err == err and err < 1e300 else 0.2
                h *= max(0.2, fac)
                if h < h_min:
                    status[r] = 2
                continue
            qn, tn = _forcing(t_new, tg0, hg, qg_r, tg_r, vq_r)
            g_new, w_new = _gap_and_slip(znew[:n], znew[n:], qn, tn, v_r, b_r, fhat_r, kc_r, s_r, kin_r)
            if opts[1] != 0.0 and (g_old > 0.0) != (g_new > 0.0) and not retake:
                hi = _locate(False, g_old > 0.0, 50, z, znew, U, RDD, h, True, t, tg0, hg, qg_r, tg_r, vq_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                if hi < 1.0 - 1e-9 and hi * h > h_min:
                    h_saved = h
                    h = hi * h
                    retake = True
                    continue
            counts[r, 0] += 1
            if h < counts[r, 3] or counts[r, 3] == 0.0:
                counts[r, 3] = h
            if opts[1] != 0.0 and (g_old > 0.0) != (g_new > 0.0):
                hi = _locate(False, g_old > 0.0, 50, z, znew, U, RDD, h, True, t, tg0, hg, qg_r, tg_r, vq_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_CONTACT_OPENS if g_new <= 0.0 else EVENT_CONTACT_CLOSES, ev_t, ev_k,
                           n_ev)
            if opts[2] != 0.0 and (w_old < opts[4]) != (w_new < opts[4]):
                hi = _locate(True, w_old < opts[4], 40, z, znew, U, RDD, h, True, t, tg0, hg, qg_r, tg_r, vq_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_STICK if w_new < opts[4] else EVENT_SLIP, ev_t, ev_k, n_ev)
            while o <= o_last and o / fs <= t_new * (1.0 + 1e-15):
                _dense_ros(z, znew, U, RDD, min((o / fs - t) / h, 1.0), zd)
                ncs, mes, _q, _t = _f_call(o / fs, zd, dzd1, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r,
                                           s_r, mats, vecs, opts, acc)
                if not _store(r, o, o_base, zd, dzd, ncs, mes, limit, out_x, out_v, out_a, out_nc, out_me, n_valid):
                    status[r] = 1
                    break
                o += 1
            if status[r] != 0:
                break
            t = t_new
            for i in range(m):
                z[i] = znew[i]
            g_old, w_old = g_new, w_new
            if not retake:
                fac = 0.9 * err ** -0.25 if err > 0.0 else 6.0
                h = h * min(6.0, max(0.2, fac))
            else:
                h = h_saved
            retake = False
            if h < h_min:
                status[r] = 2
        for i in range(n):
            X[r, i] = z[i]
            V[r, i] = z[n + i]
        H[r] = h
