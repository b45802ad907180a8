"""Dormand-Prince 5(4) with error control, dense output and event location (``integrate_adaptive``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .events import (
    EVENT_CONTACT_CLOSES,
    EVENT_CONTACT_OPENS,
    EVENT_SLIP,
    EVENT_STICK,
    _dense,
    _locate,
    _log_event,
    _store,
)
from .force import _bundle, _f, _f_call, _gap_and_slip

# -- error-controlled integration: Dormand-Prince 5(4) with dense output and events ---------------
#
# The tableau (A, B, C), the error weights E = b5 - b4 and the 4th-order dense-output matrix P
# are those of Dormand & Prince (1980) as tabulated by SciPy's RK45 (Hairer, Norsett & Wanner,
# Solving ODEs I, II.4-II.6); simulate.py passes them in.


@njit(cache=True, parallel=True)
def integrate_adaptive(
    X, V, H, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, vq, opts,
    qg, tgr, tg0, hg, t_a, t_b, fs, o_first, o_last, o_base, A, Bw, Cn, E, P, rtol, atol, h_max,
    out_x, out_v, out_a, out_nc, out_me, limit, status, n_valid, counts, ev_t, ev_k, n_ev,
):
    """Advance each run from ``t_a`` to ``t_b`` by Dormand-Prince 5(4) with error control.

    Output samples ``o_first..o_last`` (times ``o / fs``) inside ``[t_a, t_b]`` are written by
    dense output, sample ``o`` at index ``o - o_base`` of the ``out_*`` buffers (a buffer per
    chunk: the memory does not grow with the duration). ``H[r]`` carries each run's step size
    between calls. ``atol`` has one entry per state component (x then x').
    ``counts[r] = [accepted, rejected, rhs calls, smallest step]``.
    With contact loss (opts[1]) a sign change of the contact force inside a step is located by
    bisection on the dense output and the step is retaken to end just past it, so no step
    straddles the kink; the events (and stick/slip band crossings with the sign law) are recorded
    in ``ev_t``/``ev_k``. ``status[r]``: 1 diverged (|x| > limit), 2 step size underflow.
    """
    R = X.shape[0]
    n = X.shape[1]
    m = 2 * n
    S = A.shape[0]  # stages before the FSAL stage
    for r in prange(R):
        if status[r] != 0:
            continue
        z = np.empty(m)
        for i in range(n):
            z[i] = X[r, i]
            z[n + i] = V[r, i]
        K = np.empty((S + 1, m))
        zt = np.empty(m)
        znew = np.empty(m)
        zd = np.empty(m)
        dzd1 = np.empty((1, m))  # the dense output's derivative (a row, as the stages')
        dzd = dzd1[0]
        acc = np.empty(n)
        mu_r, v_r, vq_r, kc_r, s_r, kin_r = mu[r], v[r], vq[r], kc[r], s[r], kin[r]
        b_r, fhat_r = b[r], fhat[r]
        mats, vecs = _bundle(C[r], K0[r], Kn[r], Kf[r], Knx[r], Kfx[r], bM[r], fM[r], F0[r], fn[r], ff[r], b_r,
                             fhat_r)
        qg_r, tg_r = qg[r], tgr[r]
        t = t_a
        h = H[r]
        o = o_first
        # the first sample of the chunk may sit exactly at t_a
        nc, me, q, tt_ = _f_call(t, z, K, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r, s_r, mats, vecs,
                                 opts, acc)
        counts[r, 2] += 1
        if o <= o_last and o / fs <= t + 1e-12 / fs:
            if not _store(r, o, o_base, z, K[0], nc, me, limit, out_x, out_v, out_a, out_nc, out_me, n_valid):
                status[r] = 1
            o += 1
        g_old, w_old = _gap_and_slip(z[:n], z[n:], q, tt_, v_r, b_r, fhat_r, kc_r, s_r, kin_r)
        retake = False
        h_saved = h
        while t < t_b and status[r] == 0:
            h_min = 1e-14 * max(1.0, abs(t)) + 1e-300
            if h > h_max[r]:
                h = h_max[r]
            last = False
            if t + h >= t_b:
                h = t_b - t
                last = True
            t_new = t + h if not last else t_b
            # the stages, then the FSAL stage f(t_new, znew): one call site, so one inlined copy of _f
            for k in range(1, S + 1):
                if k < S:
                    for i in range(m):
                        a = 0.0
                        for j in range(k):
                            a += A[k, j] * K[j, i]
                        zt[i] = z[i] + h * a
                    tk = t + Cn[k] * h
                else:
                    for i in range(m):
                        a = 0.0
                        for j in range(S):
                            a += Bw[j] * K[j, i]
                        znew[i] = z[i] + h * a
                        zt[i] = znew[i]
                    tk = t_new
                nc, me, q, tt_ = _f(tk, zt, K, k, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r, s_r, mats, vecs,
                                    opts, acc)
            counts[r, 2] += S
            err = 0.0
            for i in range(m):
                e = 0.0
                for j in range(S + 1):
                    e += E[j] * K[j, i]
                sc = atol[r, i] + rtol * max(abs(z[i]), abs(znew[i]))
                e = h * e / sc
                err += e * e
            err = math.sqrt(err / m)
            if not (err <= 1.0):
                counts[r, 1] += 1
                fac = 0.9 * err ** -0.2 if err == err and err < 1e300 else 0.2
                h *= max(0.2, fac)
                if h < h_min:
                    status[r] = 2
                continue
            # accepted: is there a contact event inside the step?
            g_new, w_new = _gap_and_slip(znew[:n], znew[n:], q, tt_, v_r, b_r, fhat_r, kc_r, s_r, kin_r)
            if opts[1] != 0.0 and (g_old > 0.0) != (g_new > 0.0) and not retake:
                hi = _locate(False, g_old > 0.0, 50, z, znew, K, P, h, False, t, tg0, hg, qg_r, tg_r, vq_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                if hi < 1.0 - 1e-9 and hi * h > h_min:
                    # retake the step to end just past the crossing: no step straddles the kink
                    # (K[0] = f(t, z) is still valid: the stages only overwrote K[1:])
                    h_saved = h
                    h = hi * h
                    retake = True
                    continue
            counts[r, 0] += 1
            if h < counts[r, 3] or counts[r, 3] == 0.0:
                counts[r, 3] = h
            # events: contact (located above) and stick/slip band crossings (located here)
            if opts[1] != 0.0 and (g_old > 0.0) != (g_new > 0.0):
                # the crossing on this step's dense output (the step was retaken to end near it, but its
                # end can lie a whole step past where the retaken solution crosses)
                hi = _locate(False, g_old > 0.0, 50, z, znew, K, P, h, False, t, tg0, hg, qg_r, tg_r, vq_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_CONTACT_OPENS if g_new <= 0.0 else EVENT_CONTACT_CLOSES, ev_t, ev_k,
                           n_ev)
            if opts[2] != 0.0 and (w_old < opts[4]) != (w_new < opts[4]):
                hi = _locate(True, w_old < opts[4], 40, z, znew, K, P, h, False, t, tg0, hg, qg_r, tg_r, vq_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_STICK if w_new < opts[4] else EVENT_SLIP, ev_t, ev_k, n_ev)
            # output samples inside (t, t_new] by dense output
            while o <= o_last and o / fs <= t_new * (1.0 + 1e-15):
                _dense(z, K, P, h, min((o / fs - t) / h, 1.0), zd)
                ncs, mes, _q, _t = _f_call(o / fs, zd, dzd1, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, vq_r, kin_r, kc_r,
                                           s_r, mats, vecs, opts, acc)
                if not _store(r, o, o_base, zd, dzd, ncs, mes, limit, out_x, out_v, out_a, out_nc, out_me, n_valid):
                    status[r] = 1
                    break
                o += 1
            if status[r] != 0:
                break
            # advance (FSAL: the last stage is the next step's first)
            t = t_new
            for i in range(m):
                z[i] = znew[i]
                K[0, i] = K[S, i]
            g_old, w_old = g_new, w_new
            if not retake:
                fac = 0.9 * err ** -0.2 if err > 0.0 else 10.0
                h = h * min(10.0, max(0.2, fac))
            else:
                h = h_saved  # after the event, the step the controller had before it
            retake = False
            if h < h_min:
                status[r] = 2
        for i in range(n):
            X[r, i] = z[i]
            V[r, i] = z[n + i]
        H[r] = h
