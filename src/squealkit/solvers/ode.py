"""Compiled integration of M x'' + C x' + f(x, x', q, tan_theta) = F0, and the monodromy matrix.

Kernels: ``integrate_chunk`` (fixed-step classical RK4), ``integrate_adaptive``
(Dormand-Prince 5(4) with error control, dense output and event location),
``integrate_rosenbrock`` (Rodas4, linearly implicit with the analytic Jacobian, for stiff
friction laws) and ``monodromy_rk4``, the one RK4 monodromy matrix of a periodic linear system,
used by ``monodromy`` (Floquet: the transient model on a periodic run-out) and by the limit
cycles' Floquet multipliers (:func:`squealkit.nonlinear.continuation.floquet_multipliers`).

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

#: Rows of a run's bundled matrices ``mats`` (6, n, n) and vectors ``vecs`` (7, n) (see :func:`_bundle`).
_C, _K0, _KN, _KF, _KNX, _KFX = range(6)
_BM, _FM, _F0, _FN, _FF, _B, _FHAT = range(7)


@njit(cache=True, error_model="numpy")
def _bundle(C, K0, Kn, Kf, Knx, Kfx, bM, fM, F0, fn, ff, b, fhat):
    """One run's model arrays in two: the right-hand side takes 2 arrays instead of 13 (each array
    passed to a compiled call costs a reference count up and down, in the innermost loop)."""
    n = C.shape[0]
    mats = np.empty((6, n, n))
    vecs = np.empty((7, n))
    for i in range(n):
        for j in range(n):
            mats[_C, i, j] = C[i, j]
            mats[_K0, i, j] = K0[i, j]
            mats[_KN, i, j] = Kn[i, j]
            mats[_KF, i, j] = Kf[i, j]
            mats[_KNX, i, j] = Knx[i, j]
            mats[_KFX, i, j] = Kfx[i, j]
        vecs[_BM, i] = bM[i]
        vecs[_FM, i] = fM[i]
        vecs[_F0, i] = F0[i]
        vecs[_FN, i] = fn[i]
        vecs[_FF, i] = ff[i]
        vecs[_B, i] = b[i]
        vecs[_FHAT, i] = fhat[i]
    return mats, vecs


@njit(cache=True, inline="always")
def _rhs(x, ox, xd, od, n, q, t, mu, v, kin, kc, s, mats, vecs, opts, acc):
    """Accelerations ``acc`` at the displacements ``x[ox:ox + n]`` and velocities ``xd[od:od + n]``;
    returns (N cos theta, effective mu). ``mats``, ``vecs``: the run's arrays (:func:`_bundle`)."""
    for i in range(n):
        ri = vecs[_F0, i]
        for j in range(n):
            ri -= mats[_K0, i, j] * x[ox + j] + mats[_C, i, j] * xd[od + j]
        acc[i] = ri
    nc = 0.0
    me = mu
    if opts[0] == 0.0:
        g = 1.0 - mu * t
        e = s * (mu + t)
        for i in range(n):
            kn = -q * vecs[_FN, i]
            kf = -q * vecs[_FF, i]
            for j in range(n):
                kn += mats[_KN, i, j] * x[ox + j]
                kf += mats[_KF, i, j] * x[ox + j]
            if kin != 0.0:
                for j in range(n):
                    kn += s * t * mats[_KNX, i, j] * x[ox + j]
                    kf += s * t * mats[_KFX, i, j] * x[ox + j]
            acc[i] -= g * kn + e * kf
    else:
        d = -q
        for j in range(n):
            d += (vecs[_B, j] + kin * s * t * vecs[_FHAT, j]) * x[ox + j]
        nc = -kc * d
        if opts[1] != 0.0 and nc < 0.0:
            nc = 0.0
        w = v
        for j in range(n):
            w -= s * vecs[_FHAT, j] * xd[od + j]
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
            acc[i] += nc * (g * vecs[_BM, i] + e * vecs[_FM, i])
    return nc, me


@njit(cache=True, parallel=True)
def integrate_chunk(
    X, V, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, opts,
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



# -- error-controlled integration: Dormand-Prince 5(4) with dense output and events ---------------
#
# The tableau (A, B, C), the error weights E = b5 - b4 and the 4th-order dense-output matrix P
# are those of Dormand & Prince (1980) as tabulated by SciPy's RK45 (Hairer, Norsett & Wanner,
# Solving ODEs I, II.4-II.6); simulate.py passes them in. Event codes recorded per run:
EVENT_CONTACT_OPENS = 1
EVENT_CONTACT_CLOSES = 2
EVENT_STICK = 3   # the sliding speed |w| falls into the regularisation band v_reg
EVENT_SLIP = 4    # ... and leaves it


@njit(cache=True, inline="always")
def _forcing(tt, tg0, hg, qg, tgr, vel):
    """q and tan(theta) at time tt: cubic Hermite in time through the samples of q and dq/dt = v tan(theta)."""
    G = qg.shape[0]
    u = (tt - tg0) / hg
    j = math.floor(u)
    if j < 0:
        j = 0
    if j > G - 2:
        j = G - 2
    u -= j
    q0 = qg[j]
    q1 = qg[j + 1]
    d0 = tgr[j] * vel * hg
    d1 = tgr[j + 1] * vel * hg
    u2 = u * u
    u3 = u2 * u
    q = (2 * u3 - 3 * u2 + 1) * q0 + (u3 - 2 * u2 + u) * d0 + (-2 * u3 + 3 * u2) * q1 + (u3 - u2) * d1
    if vel != 0.0:
        dq = (6 * u2 - 6 * u) * q0 + (3 * u2 - 4 * u + 1) * d0 + (-6 * u2 + 6 * u) * q1 + (3 * u2 - 2 * u) * d1
        tan_t = dq / (vel * hg)
    else:
        tan_t = tgr[j] + u * (tgr[j + 1] - tgr[j])
    return q, tan_t


@njit(cache=True, inline="always")
def _f(tt, z, dz, k, n, tg0, hg, qg, tgr, mu, v, kin, kc, s, mats, vecs, opts, acc):
    """First-order right-hand side ``dz[k] = [x', x'']`` at (tt, z); returns (N cos theta, mu_eff, q, tan theta).

    Inlined where the integrators call it every stage (one call site in each one's step); elsewhere
    :func:`_f_call`: each inlined copy of the right-hand side costs seconds of compile time."""
    q, tan_t = _forcing(tt, tg0, hg, qg, tgr, v)
    nc, me = _rhs(z, 0, z, n, n, q, tan_t, mu, v, kin, kc, s, mats, vecs, opts, acc)
    for i in range(n):
        dz[k, i] = z[n + i]
        dz[k, n + i] = acc[i]
    return nc, me, q, tan_t


@njit(cache=True, error_model="numpy")
def _f_call(tt, z, dz, k, n, tg0, hg, qg, tgr, mu, v, kin, kc, s, mats, vecs, opts, acc):
    """:func:`_f` compiled once, called: for the first sample of a chunk and the dense output."""
    return _f(tt, z, dz, k, n, tg0, hg, qg, tgr, mu, v, kin, kc, s, mats, vecs, opts, acc)


@njit(cache=True, inline="always")
def _gap_and_slip(x, xd, q, tan_t, v, b, fhat, kc, s, kin):
    """Contact force without clamping, -kc (b_t.x - q), and |w| (sliding speed of disc past pin)."""
    n = x.shape[0]
    d = -q
    w = v
    for j in range(n):
        d += (b[j] + kin * s * tan_t * fhat[j]) * x[j]
        w -= s * fhat[j] * xd[j]
    return -kc * d, abs(w)


@njit(cache=True, error_model="numpy")
def _dense(z, K, P, h, th, out):
    """State at t + th h from the step's stages (4th-order continuous extension)."""
    m = z.shape[0]
    p0 = th
    p1 = th * th
    p2 = p1 * th
    p3 = p2 * th
    for i in range(m):
        acc = 0.0
        for j in range(K.shape[0]):
            acc += K[j, i] * (P[j, 0] * p0 + P[j, 1] * p1 + P[j, 2] * p2 + P[j, 3] * p3)
        out[i] = z[i] + h * acc


@njit(cache=True, error_model="numpy")
def _dense_ros(z, z1, U, Dd, th, out):
    """Rodas4's 3rd-order continuous extension at t + th h."""
    m = z.shape[0]
    for i in range(m):
        d2 = 0.0
        d3 = 0.0
        for j in range(Dd.shape[1]):
            d2 += Dd[0, j] * U[j, i]
            d3 += Dd[1, j] * U[j, i]
        out[i] = (1.0 - th) * z[i] + th * (z1[i] + (1.0 - th) * (d2 + th * d3))

@njit(cache=True, inline="always")
def _interp(z, z1, St, Co, h, th, rosenbrock, out):
    """State at t + th h by the step's continuous extension: Dormand-Prince's (stages ``St`` = K,
    coefficients ``Co`` = P) or Rodas4's (``St`` = U, ``Co`` = its dense-output matrix)."""
    if rosenbrock:
        _dense_ros(z, z1, St, Co, th, out)
    else:
        _dense(z, St, Co, h, th, out)


@njit(cache=True, error_model="numpy")  # called at events only: compiled once, not inlined at each call
def _locate(slip, side_old, n_iter, z, z1, St, Co, h, rosenbrock, t, tg0, hg, qg, tgr, v, b, fhat, kc, s, kin,
            v_reg, zd):
    """Fraction of the step at which the contact force changes sign (``slip`` False) or the sliding
    speed crosses the stick band ``|w| < v_reg`` (``slip`` True), by bisection on the dense output."""
    n = zd.shape[0] // 2
    lo, hi = 0.0, 1.0
    for _ in range(n_iter):
        mid = 0.5 * (lo + hi)
        _interp(z, z1, St, Co, h, mid, rosenbrock, zd)
        qm, tm = _forcing(t + mid * h, tg0, hg, qg, tgr, v)
        gm, wm = _gap_and_slip(zd[:n], zd[n:], qm, tm, v, b, fhat, kc, s, kin)
        side = (wm < v_reg) if slip else (gm > 0.0)
        if side == side_old:
            lo = mid
        else:
            hi = mid
    return hi


@njit(cache=True, error_model="numpy")
def _log_event(r, t_ev, kind, ev_t, ev_k, n_ev):
    """Record event ``kind`` at ``t_ev`` for run ``r`` (counted even when the buffer is full)."""
    k_ev = n_ev[r]
    if k_ev < ev_t.shape[1]:
        ev_t[r, k_ev] = t_ev
        ev_k[r, k_ev] = kind
    n_ev[r] = k_ev + 1


@njit(cache=True, error_model="numpy")
def _store(r, o, o_base, z, dz, nc, me, limit, out_x, out_v, out_a, out_nc, out_me, n_valid):
    """Write output sample ``o`` of run ``r`` at row ``o - o_base`` of the output buffers; False
    (nothing written) if some |x_i| > ``limit``."""
    n = out_x.shape[2]
    for i in range(n):
        if not (abs(z[i]) <= limit):
            return False
    for i in range(n):
        out_x[r, o - o_base, i] = z[i]
        out_v[r, o - o_base, i] = z[n + i]
        out_a[r, o - o_base, i] = dz[n + i]
    out_nc[r, o - o_base] = nc
    out_me[r, o - o_base] = me
    n_valid[r] = o + 1
    return True


@njit(cache=True, parallel=True)
def integrate_adaptive(
    X, V, H, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, opts,
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
        mu_r, v_r, kc_r, s_r, kin_r = mu[r], v[r], kc[r], s[r], kin[r]
        b_r, fhat_r = b[r], fhat[r]
        mats, vecs = _bundle(C[r], K0[r], Kn[r], Kf[r], Knx[r], Kfx[r], bM[r], fM[r], F0[r], fn[r], ff[r], b_r,
                             fhat_r)
        qg_r, tg_r = qg[r], tgr[r]
        t = t_a
        h = H[r]
        o = o_first
        # the first sample of the chunk may sit exactly at t_a
        nc, me, q, tt_ = _f_call(t, z, K, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs,
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
                nc, me, q, tt_ = _f(tk, zt, K, k, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs,
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
                hi = _locate(False, g_old > 0.0, 50, z, znew, K, P, h, False, t, tg0, hg, qg_r, tg_r, v_r,
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
                hi = _locate(False, g_old > 0.0, 50, z, znew, K, P, h, False, t, tg0, hg, qg_r, tg_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_CONTACT_OPENS if g_new <= 0.0 else EVENT_CONTACT_CLOSES, ev_t, ev_k,
                           n_ev)
            if opts[2] != 0.0 and (w_old < opts[4]) != (w_new < opts[4]):
                hi = _locate(True, w_old < opts[4], 40, z, znew, K, P, h, False, t, tg0, hg, qg_r, tg_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_STICK if w_new < opts[4] else EVENT_SLIP, ev_t, ev_k, n_ev)
            # output samples inside (t, t_new] by dense output
            while o <= o_last and o / fs <= t_new * (1.0 + 1e-15):
                _dense(z, K, P, h, min((o / fs - t) / h, 1.0), zd)
                ncs, mes, _q, _t = _f_call(o / fs, zd, dzd1, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r,
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
def _jacobian(x, xd, q, t, mu, v, C, K0, Kn, Kf, Knx, Kfx, kin, bM, fM, b, fhat, kc, s, opts, Jx, Jv):
    """Analytic d(acc)/dx into Jx and d(acc)/dx' into Jv (the force law of :func:`_rhs`).

    Linear law: -K0 - g (Kn + kin s t Knx) - e (Kf + kin s t Kfx), and -C. Structured law with
    Nc = -kc (b_t.x - q) (0 and flat when the contact is open), mu_e(w) = mu(w) tanh(w / v_reg),
    w = v - s fhat.x': d/dx adds (g bM + e fM) dNc/dx, d/dx' adds Nc (s fM - t bM) mu_e'(w) (-s fhat).
    """
    n = x.shape[0]
    for i in range(n):
        for j in range(n):
            Jx[i, j] = -K0[i, j]
            Jv[i, j] = -C[i, j]
    if opts[0] == 0.0:
        g = 1.0 - mu * t
        e = s * (mu + t)
        for i in range(n):
            for j in range(n):
                Jx[i, j] -= g * Kn[i, j] + e * Kf[i, j]
                if kin != 0.0:
                    Jx[i, j] -= s * t * (g * Knx[i, j] + e * Kfx[i, j])
        return
    d = -q
    for j in range(n):
        d += (b[j] + kin * s * t * fhat[j]) * x[j]
    nc = -kc * d
    closed = True
    if opts[1] != 0.0 and nc < 0.0:
        nc = 0.0
        closed = False
    w = v
    for j in range(n):
        w -= s * fhat[j] * xd[j]
    mw = mu
    dmw = 0.0
    if opts[3] != 0.0:
        ex = math.exp(-abs(w) / opts[6])
        mw = mu + (opts[5] - mu) * ex
        sg = 1.0 if w > 0.0 else (-1.0 if w < 0.0 else 0.0)
        dmw = -(opts[5] - mu) * ex * sg / opts[6]
    phi = 1.0
    dphi = 0.0
    if opts[2] != 0.0:
        phi = math.tanh(w / opts[4])
        dphi = (1.0 - phi * phi) / opts[4]
    me = mw * phi
    dme = dmw * phi + mw * dphi
    g = 1.0 - me * t
    e = s * (me + t)
    for i in range(n):
        if closed:
            gi = g * bM[i] + e * fM[i]
            for j in range(n):
                Jx[i, j] += gi * (-kc * (b[j] + kin * s * t * fhat[j]))
        hi = nc * (s * fM[i] - t * bM[i]) * dme
        for j in range(n):
            Jv[i, j] += hi * (-s * fhat[j])


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
    X, V, H, bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, opts,
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
        mu_r, v_r, kc_r, s_r, kin_r = mu[r], v[r], kc[r], s[r], kin[r]
        bM_r, fM_r, C_r, K0_r, Kn_r, Kf_r = bM[r], fM[r], C[r], K0[r], Kn[r], Kf[r]
        Knx_r, Kfx_r, b_r, fhat_r = Knx[r], Kfx[r], b[r], fhat[r]
        mats, vecs = _bundle(C_r, K0_r, Kn_r, Kf_r, Knx_r, Kfx_r, bM_r, fM_r, F0[r], fn[r], ff[r], b_r, fhat_r)
        qg_r, tg_r = qg[r], tgr[r]
        t = t_a
        h = H[r]
        o = o_first
        nc, me, q, tt_ = _f_call(t, z, Fs, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs,
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
                ncc, mec, qc, ttc = _f(tc, z, Fs, c, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs,
                                       opts, acc)
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
                    _f(t + RAL[k] * h, zt, Fs, 3, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs,
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
            qn, tn = _forcing(t_new, tg0, hg, qg_r, tg_r, v_r)
            g_new, w_new = _gap_and_slip(znew[:n], znew[n:], qn, tn, v_r, b_r, fhat_r, kc_r, s_r, kin_r)
            if opts[1] != 0.0 and (g_old > 0.0) != (g_new > 0.0) and not retake:
                hi = _locate(False, g_old > 0.0, 50, z, znew, U, RDD, h, True, t, tg0, hg, qg_r, tg_r, v_r,
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
                hi = _locate(False, g_old > 0.0, 50, z, znew, U, RDD, h, True, t, tg0, hg, qg_r, tg_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_CONTACT_OPENS if g_new <= 0.0 else EVENT_CONTACT_CLOSES, ev_t, ev_k,
                           n_ev)
            if opts[2] != 0.0 and (w_old < opts[4]) != (w_new < opts[4]):
                hi = _locate(True, w_old < opts[4], 40, z, znew, U, RDD, h, True, t, tg0, hg, qg_r, tg_r, v_r,
                             b_r, fhat_r, kc_r, s_r, kin_r, opts[4], zd)
                _log_event(r, t + hi * h, EVENT_STICK if w_new < opts[4] else EVENT_SLIP, ev_t, ev_k, n_ev)
            while o <= o_last and o / fs <= t_new * (1.0 + 1e-15):
                _dense_ros(z, znew, U, RDD, min((o / fs - t) / h, 1.0), zd)
                ncs, mes, _q, _t = _f_call(o / fs, zd, dzd1, 0, n, tg0, hg, qg_r, tg_r, mu_r, v_r, kin_r, kc_r,
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


# -- monodromy matrix of the periodic linear system (Floquet) --------------------------------------


@njit(cache=True, inline="always")
def _state_matrix(tan_t, mu, s, kin, MC, MK0, MKn, MKf, MKnx, MKfx, A):
    """A(t) = [[0, I], [-M^-1 K(mu, tan_t), -M^-1 C]] into A (paper eq. 4, homogeneous part)."""
    n = MC.shape[0]
    g = 1.0 - mu * tan_t
    e = s * (mu + tan_t)
    st = kin * s * tan_t
    for i in range(n):
        for j in range(n):
            A[i, j] = 0.0
            A[i, n + j] = 1.0 if i == j else 0.0
            k = MK0[i, j] + g * (MKn[i, j] + st * MKnx[i, j]) + e * (MKf[i, j] + st * MKfx[i, j])
            A[n + i, j] = -k
            A[n + i, n + j] = -MC[i, j]


@njit(cache=True, inline="always")
def _slope_at(tg, u):
    """Periodic linear interpolation of the slope samples tg (one period) at phase u in [0, 1]."""
    M = tg.shape[0]
    x = u * M
    j = math.floor(x)
    w = x - j
    j = j % M
    return tg[j] + w * (tg[(j + 1) % M] - tg[j])


def _rk4_for(rhs):
    """The RK4 monodromy kernel of one right-hand side ``rhs``, compiled and cached for it.

    The right-hand side is a variable of the closure, not an argument: a compiled function passed
    as an argument is a value numba's cache cannot keep ("dynamic globals"), so the kernel was
    compiled again in every process. The closure itself, called from Python, is no better: its
    cache key holds its variables pickled, and a compiled function pickles with an id of its
    process. So each kernel is called from a module-level compiled function
    (:func:`monodromy`, :func:`_sampled_monodromy`), which numba's cache keeps with it.
    """

    @njit(cache=True)
    def rk4(data, n_steps, h, m):
        """Phi(T) by ``n_steps`` RK4 steps of ``h`` (see :func:`monodromy_rk4`)."""
        Phi = np.eye(m)
        k1 = np.empty((m, m))
        k2 = np.empty((m, m))
        k3 = np.empty((m, m))
        k4 = np.empty((m, m))
        Y = np.empty((m, m))
        for step in range(n_steps):
            rhs(data, step, 0, Phi, k1)
            for i in range(m):
                for j in range(m):
                    Y[i, j] = Phi[i, j] + 0.5 * h * k1[i, j]
            rhs(data, step, 1, Y, k2)
            for i in range(m):
                for j in range(m):
                    Y[i, j] = Phi[i, j] + 0.5 * h * k2[i, j]
            rhs(data, step, 1, Y, k3)
            for i in range(m):
                for j in range(m):
                    Y[i, j] = Phi[i, j] + h * k3[i, j]
            rhs(data, step, 2, Y, k4)
            for i in range(m):
                for j in range(m):
                    Phi[i, j] += h / 6.0 * (k1[i, j] + 2.0 * k2[i, j] + 2.0 * k3[i, j] + k4[i, j])
        return Phi

    return rk4


_RK4: dict[object, object] = {}


def monodromy_rk4(rhs, data, n_steps, h, m):
    """Monodromy matrix Phi(T) of ``Phi' = A(t) Phi``, Phi(0) = I (m x m), by ``n_steps`` classical RK4 steps of ``h``.

    ``rhs(data, step, stage, Y, out)``, a compiled function, sets ``out = A(t) Y`` at the start
    (``stage`` 0), the middle (1) or the end (2) of step ``step``: :func:`_runout_rhs` (the transient
    model on a periodic run-out, :func:`monodromy`) or :func:`sampled_rhs` (samples of A, the limit
    cycles' variational equations). One kernel per ``rhs``, compiled once and kept in numba's cache.
    """
    if rhs is sampled_rhs:  # the cached one (see _rk4_for)
        return _sampled_monodromy(data, n_steps, h, m)
    kernel = _RK4.get(rhs)
    if kernel is None:
        kernel = _RK4[rhs] = _rk4_for(rhs)
    return kernel(data, n_steps, h, m)


@njit(cache=True, inline="always")
def _mm(A, B, out):
    """``out = A B`` by the plain triple loop (the limit cycles' monodromy, as it always was)."""
    m = A.shape[0]
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for r in range(m):
                acc += A[i, r] * B[r, j]
            out[i, j] = acc


@njit(cache=True, inline="always")
def _copy2(src, dst):
    """``dst[:, :] = src`` by a loop: an array assignment makes numba compile its shape-mismatch
    message (string formatting, ~10 s on a first run) into the kernel."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@njit(cache=True)
def sampled_rhs(A, step, stage, Y, out):
    """``A(t) Y`` from samples ``A`` (2S+1, m, m) of A at the steps and their midpoints (``A[2 step + stage]``)."""
    _mm(A[2 * step + stage], Y, out)


@njit(cache=True)
def _runout_rhs(data, step, stage, Y, out):
    """``A(t) Y`` of the model on a periodic run-out: ``data = (tg, mu, s, kin, MC, MK0, MKn, MKf, MKnx,
    MKfx, du, A)`` with the slope samples ``tg`` over one period, the step ``du`` in units of the
    period and ``A`` a scratch matrix."""
    tg, mu, s, kin, MC, MK0, MKn, MKf, MKnx, MKfx, du, A = data
    u = step * du
    if stage == 1:
        u = u + 0.5 * du
    elif stage == 2:
        u = u + du
    _state_matrix(_slope_at(tg, u), mu, s, kin, MC, MK0, MKn, MKf, MKnx, MKfx, A)
    _copy2(A @ Y, out)


_sampled_rk4 = _RK4[sampled_rhs] = _rk4_for(sampled_rhs)


@njit(cache=True)
def _sampled_monodromy(A, n_steps, h, m):
    """:func:`monodromy_rk4` of :func:`sampled_rhs`, in numba's cache (see :func:`_rk4_for`)."""
    return _sampled_rk4(A, n_steps, h, m)


#: The run-out's monodromy kernel, named for the parallel loop of :func:`monodromy`.
_runout_rk4 = _RK4[_runout_rhs] = _rk4_for(_runout_rhs)


@njit(cache=True, parallel=True)
def monodromy(tg, mu, s, kin, MC, MK0, MKn, MKf, MKnx, MKfx, period, n_steps, out):
    """Monodromy matrices Phi(T) of z' = A(t) z over one ``period`` [s], by classical RK4 (``n_steps``).

    Case b has the slope samples ``tg[b]`` over one period (periodic), friction ``mu[b]`` and
    model matrices ``M^-1 C``, ``M^-1 K0``... (``[b]``); ``out[b]`` receives Phi(T), shape (2n, 2n).
    The cases in parallel (``prange``), each by :func:`monodromy_rk4`.
    """
    B = tg.shape[0]
    m = 2 * MC.shape[1]
    h = period / n_steps
    du = 1.0 / n_steps  # the step in units of the period (phase of the slope samples)
    for bi in prange(B):
        data = (tg[bi], mu[bi], s[bi], kin[bi], MC[bi], MK0[bi], MKn[bi], MKf[bi], MKnx[bi], MKfx[bi], du,
                np.empty((m, m)))
        _copy2(_runout_rk4(data, n_steps, h, m), out[bi])
