"""Fixed-step classical RK4 (``integrate_chunk``), in parallel over a batch of runs."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .force import _bundle, _rhs


@njit(cache=True, parallel=True)
def integrate_chunk(
    X, V, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, vq, opts,
    qh, th, dt, n_steps, stride, out_x, out_v, out_a, out_nc, out_me, o_start, limit, status, n_valid,
    o_base,
):
    """Advance each run r by ``n_steps`` RK4 steps of ``dt``; record every ``stride`` steps.

    ``qh[r, 2k + j]``/``th[r, 2k + j]`` hold q and tan(theta) at ``t_k + j dt/2``. The state at
    step 0 of the chunk is recorded at output index ``o_start``, stored at ``o_start - o_base`` of
    the ``out_*`` buffers (which hold samples ``o_base...``); ``status[r]`` turns 1 when a
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
        o = o_start
        mu_r, v_r, kc_r, s_r = mu[r], v[r], kc[r], s[r]
        kin_r = kin[r]
        mats, vecs = _bundle(C[r], K0[r], Kn[r], Kf[r], Knx[r], Kfx[r], bM[r], fM[r], F0[r], fn[r], ff[r], b[r],
                             fhat[r])
        for k in range(n_steps + 1):
            i0 = 2 * k
            if k % stride == 0 and (k < n_steps or n_steps == 0):
                nc, me = _rhs(x, 0, xd, 0, n, qh[r, i0], th[r, i0], mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts,
                              k1v)
                bad = False
                for i in range(n):
                    if not (abs(x[i]) <= limit):
                        bad = True
                if bad:
                    status[r] = 1
                    break
                if o - o_base < out_x.shape[1]:
                    for i in range(n):
                        out_x[r, o - o_base, i] = x[i]
                        out_v[r, o - o_base, i] = xd[i]
                        out_a[r, o - o_base, i] = k1v[i]
                    out_nc[r, o - o_base] = nc
                    out_me[r, o - o_base] = me
                    n_valid[r] = o + 1
                o += 1
            if k == n_steps:
                break
            q0, t0 = qh[r, i0], th[r, i0]
            q1, t1 = qh[r, i0 + 1], th[r, i0 + 1]
            q2, t2 = qh[r, i0 + 2], th[r, i0 + 2]
            _rhs(x, 0, xd, 0, n, q0, t0, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k1v)
            for i in range(n):
                k1x[i] = xd[i]
                xt[i] = x[i] + 0.5 * dt * k1x[i]
                vt[i] = xd[i] + 0.5 * dt * k1v[i]
            _rhs(xt, 0, vt, 0, n, q1, t1, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k2v)
            for i in range(n):
                k2x[i] = vt[i]
                xt[i] = x[i] + 0.5 * dt * k2x[i]
                vt[i] = xd[i] + 0.5 * dt * k2v[i]
            _rhs(xt, 0, vt, 0, n, q1, t1, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k3v)
            for i in range(n):
                k3x[i] = vt[i]
                xt[i] = x[i] + dt * k3x[i]
                vt[i] = xd[i] + dt * k3v[i]
            _rhs(xt, 0, vt, 0, n, q2, t2, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k4v)
            for i in range(n):
                x[i] += dt / 6.0 * (k1x[i] + 2.0 * k2x[i] + 2.0 * k3x[i] + vt[i])
                xd[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])
        for i in range(n):
            X[r, i] = x[i]
            V[r, i] = xd[i]
