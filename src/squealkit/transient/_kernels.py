"""Compiled fixed-step RK4 integration of M x'' + C x' + f(x, x', q, tan_theta) = F0.

All matrices and load vectors arrive premultiplied by M^-1 (``K0 = M^-1 K0`` and so on; ``bM``
and ``fM`` are M^-1 b and M^-1 f), so the right-hand side is the acceleration directly.

Private: :mod:`squealkit.transient.simulate` prepares the arrays. Each call advances a
batch of R independent runs by one chunk of steps, in parallel over runs (``prange``).

Contact force (the part of eq. 4 carried by the contact), for each run::

    linear:     -g (Kn x - q fn) - e (Kf x - q ff),   g = 1 - mu t, e = s (mu + t)
                  - s t (g Knx x + e Kfx x)   (consistent kinematics only, ``kin = 1``)
    structured: Nc (g b + e f),  Nc = -kc (b_t.x - q) = N cos(theta) (eq. 2)
                with b_t = b (paper) or b + s t fhat (consistent kinematics)
                with Nc >= 0 if contact may open, and mu -> mu(w) phi(w) where w is the
                sliding speed of the disc past the pin, phi = tanh(w / v_reg).

Flags (``opts``): [structured, separation, sign_friction, stribeck, v_reg, mu_static, v_stribeck].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _rhs(x, xd, q, t, mu, v, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, opts, r, acc):
    """Accelerations ``acc`` at state (x, xd); returns (N cos theta, effective mu)."""
    n = x.shape[0]
    for i in range(n):
        ri = F0[i]
        for j in range(n):
            ri -= K0[i, j] * x[j] + C[i, j] * xd[j]
        r[i] = ri
    nc = 0.0
    me = mu
    if opts[0] == 0.0:
        g = 1.0 - mu * t
        e = s * (mu + t)
        for i in range(n):
            kn = -q * fn[i]
            kf = -q * ff[i]
            for j in range(n):
                kn += Kn[i, j] * x[j]
                kf += Kf[i, j] * x[j]
            if kin != 0.0:
                for j in range(n):
                    kn += s * t * Knx[i, j] * x[j]
                    kf += s * t * Kfx[i, j] * x[j]
            r[i] -= g * kn + e * kf
    else:
        d = -q
        for j in range(n):
            d += (b[j] + kin * s * t * fhat[j]) * x[j]
        nc = -kc * d
        if opts[1] != 0.0 and nc < 0.0:
            nc = 0.0
        w = v
        for j in range(n):
            w -= s * fhat[j] * xd[j]
        mw = mu
        if opts[3] != 0.0:
            mw = mu + (opts[5] - mu) * math.exp(-abs(w) / opts[6])
        phi = 1.0
        if opts[2] != 0.0:
            phi = math.tanh(w / opts[4])
        me = mw * phi
        g = 1.0 - me * t
        e = s * (me + t)
        for i in range(n):
            r[i] += nc * (g * bM[i] + e * fM[i])
    for i in range(n):
        acc[i] = r[i]
    return nc, me


@njit(cache=True, parallel=True)
def integrate_chunk(
    X, V, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, opts,
    qh, th, dt, n_steps, stride, out_x, out_v, out_a, out_nc, out_me, o_start, limit, status, n_valid,
):
    """Advance each run r by ``n_steps`` RK4 steps of ``dt``; record every ``stride`` steps.

    ``qh[r, 2k + j]``/``th[r, 2k + j]`` hold q and tan(theta) at ``t_k + j dt/2``. The state at
    step 0 of the chunk is recorded at output index ``o_start``; ``status[r]`` turns 1 when a
    recorded displacement exceeds ``limit`` (or is not finite) and the run then stops.
    """
    R = X.shape[0]
    n = X.shape[1]
    for r in prange(R):
        if status[r] != 0:
            continue
        x = X[r].copy()
        xd = V[r].copy()
        xt = np.empty(n)
        vt = np.empty(n)
        k1x = np.empty(n)
        k1v = np.empty(n)
        k2x = np.empty(n)
        k2v = np.empty(n)
        k3x = np.empty(n)
        k3v = np.empty(n)
        k4v = np.empty(n)
        work = np.empty(n)
        o = o_start
        mu_r, v_r, kc_r, s_r = mu[r], v[r], kc[r], s[r]
        bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r = bM[r], fM[r], C[r], K0[r], Kn[r], Kf[r]
        Knx_r, Kfx_r, kin_r = Knx[r], Kfx[r], kin[r]
        F0_r, fn_r, ff_r, b_r, f_r, fhat_r = F0[r], fn[r], ff[r], b[r], f[r], fhat[r]
        for k in range(n_steps + 1):
            i0 = 2 * k
            if k % stride == 0 and (k < n_steps or n_steps == 0):
                nc, me = _rhs(x, xd, qh[r, i0], th[r, i0], mu_r, v_r, bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r,
                              Knx_r, Kfx_r, kin_r,
                 F0_r, fn_r, ff_r, b_r, f_r, fhat_r, kc_r, s_r, opts, work, k1v)
                bad = False
                for i in range(n):
                    if not (abs(x[i]) <= limit):
                        bad = True
                if bad:
                    status[r] = 1
                    break
                if o < out_x.shape[1]:
                    for i in range(n):
                        out_x[r, o, i] = x[i]
                        out_v[r, o, i] = xd[i]
                        out_a[r, o, i] = k1v[i]
                    out_nc[r, o] = nc
                    out_me[r, o] = me
                    n_valid[r] = o + 1
                o += 1
            if k == n_steps:
                break
            q0, t0 = qh[r, i0], th[r, i0]
            q1, t1 = qh[r, i0 + 1], th[r, i0 + 1]
            q2, t2 = qh[r, i0 + 2], th[r, i0 + 2]
            _rhs(x, xd, q0, t0, mu_r, v_r, bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, kin_r,
                 F0_r, fn_r, ff_r, b_r, f_r, fhat_r, kc_r, s_r, opts, work, k1v)
            for i in range(n):
                k1x[i] = xd[i]
                xt[i] = x[i] + 0.5 * dt * k1x[i]
                vt[i] = xd[i] + 0.5 * dt * k1v[i]
            _rhs(xt, vt, q1, t1, mu_r, v_r, bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, kin_r,
                 F0_r, fn_r, ff_r, b_r, f_r, fhat_r, kc_r, s_r, opts, work, k2v)
            for i in range(n):
                k2x[i] = vt[i]
                xt[i] = x[i] + 0.5 * dt * k2x[i]
                vt[i] = xd[i] + 0.5 * dt * k2v[i]
            _rhs(xt, vt, q1, t1, mu_r, v_r, bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, kin_r,
                 F0_r, fn_r, ff_r, b_r, f_r, fhat_r, kc_r, s_r, opts, work, k3v)
            for i in range(n):
                k3x[i] = vt[i]
                xt[i] = x[i] + dt * k3x[i]
                vt[i] = xd[i] + dt * k3v[i]
            _rhs(xt, vt, q2, t2, mu_r, v_r, bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, kin_r,
                 F0_r, fn_r, ff_r, b_r, f_r, fhat_r, kc_r, s_r, opts, work, k4v)
            for i in range(n):
                x[i] += dt / 6.0 * (k1x[i] + 2.0 * k2x[i] + 2.0 * k3x[i] + vt[i])
                xd[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])
        for i in range(n):
            X[r, i] = x[i]
            V[r, i] = xd[i]

