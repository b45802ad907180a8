"""The right-hand side of M x'' + C x' + f(x, x', q, tan_theta) = F0 and its Jacobian, for every integrator.

All matrices and load vectors arrive premultiplied by M^-1 (``K0 = M^-1 K0`` and so on; ``bM``
and ``fM`` are M^-1 b and M^-1 f), so the right-hand side is the acceleration directly; a run's
13 arrays travel bundled in two (:func:`_bundle`), and with its forcing and scalars in one tuple
(:func:`_run_rhs`) to the integrators' right-hand side :func:`_f`.

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
from numba import njit

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
def _rhs(x, ox, xd, od, q, t, mu, v, kin, kc, s, mats, vecs, opts, acc):
    """Accelerations ``acc`` (n,) at the displacements ``x[ox:ox + n]`` and velocities ``xd[od:od + n]``;
    returns (N cos theta, effective mu). ``mats``, ``vecs``: the run's arrays (:func:`_bundle`)."""
    n = acc.shape[0]
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


@njit(cache=True, inline="always")
def _forcing(tt, tg0, hg, qg, tgr, vel):
    """q and tan(theta) at time tt: cubic Hermite in time through the samples of q and dq/dt = v tan(theta).

    ``vel`` is the speed at which the profile passes (``vq`` of the kernels): 0 for a profile whose slope is
    not dq/dx (a held incline), whose q and tan(theta) are then each interpolated on their own (q with zero
    end slopes, tan(theta) linearly)."""
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
def _run_rhs(r, model, forcing, acc):
    """Run ``r``'s right-hand side, bundled (the argument ``rhs`` of :func:`_f`): ``(t0, h, q, tan_theta,
    mu, v, vq, kin, kc, s, mats, vecs, opts, acc)``, the forcing grid's row r (:class:`.bundles.Forcing`),
    the run's scalars, its arrays in two (:func:`_bundle`), the contact law's flags and ``acc``, a scratch (n,)."""
    mats, vecs = _bundle(model.C[r], model.K0[r], model.Kn[r], model.Kf[r], model.Knx[r], model.Kfx[r],
                         model.bM[r], model.fM[r], model.F0[r], model.fn[r], model.ff[r], model.b[r], model.fhat[r])
    return (forcing.t0, forcing.h, forcing.q[r], forcing.tan_theta[r], model.mu[r], model.v[r], model.vq[r],
            model.kin[r], model.kc[r], model.s[r], mats, vecs, model.opts, acc)


@njit(cache=True, inline="always")
def _f(tt, z, dz, k, rhs):
    """First-order right-hand side ``dz[k] = [x', x'']`` at (tt, z); returns (N cos theta, mu_eff, q, tan theta).

    ``rhs``: the run's bundle (:func:`_run_rhs`). Inlined where the integrators call it every stage (one
    call site in each one's step); elsewhere :func:`_f_call`: each inlined copy of the right-hand side
    costs seconds of compile time."""
    tg0, hg, qg, tgr, mu, v, vq, kin, kc, s, mats, vecs, opts, acc = rhs
    n = acc.shape[0]
    q, tan_t = _forcing(tt, tg0, hg, qg, tgr, vq)
    nc, me = _rhs(z, 0, z, n, q, tan_t, mu, v, kin, kc, s, mats, vecs, opts, acc)
    for i in range(n):
        dz[k, i] = z[n + i]
        dz[k, n + i] = acc[i]
    return nc, me, q, tan_t


@njit(cache=True, error_model="numpy")
def _f_call(tt, z, dz, k, rhs):
    """:func:`_f` compiled once, called: for the first sample of a chunk and the dense output."""
    return _f(tt, z, dz, k, rhs)


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


@njit(cache=True, inline="always")
def _contact(z, q, tan_t, rhs):
    """:func:`_gap_and_slip` of the state ``z = [x, x']`` under the forcing ``q``, ``tan_t``; ``rhs``: the
    run's bundle (:func:`_run_rhs`)."""
    _tg0, _hg, _qg, _tgr, _mu, v, _vq, kin, kc, s, _mats, vecs, _opts, _acc = rhs
    n = z.shape[0] // 2
    return _gap_and_slip(z[:n], z[n:], q, tan_t, v, vecs[_B], vecs[_FHAT], kc, s, kin)


@njit(cache=True, inline="always")
def _contact_at(tt, z, rhs):
    """:func:`_contact` at time ``tt`` (the forcing evaluated there)."""
    q, tan_t = _forcing(tt, rhs[0], rhs[1], rhs[2], rhs[3], rhs[6])
    return _contact(z, q, tan_t, rhs)


@njit(cache=True, inline="always")
def _jacobian(x, xd, q, t, mu, v, kin, kc, s, mats, vecs, opts, Jx, Jv):
    """Analytic d(acc)/dx into Jx and d(acc)/dx' into Jv (the force law of :func:`_rhs`, the same arguments).

    Linear law: -K0 - g (Kn + kin s t Knx) - e (Kf + kin s t Kfx), and -C. Structured law with
    Nc = -kc (b_t.x - q) (0 and flat when the contact is open), mu_e(w) = mu(w) tanh(w / v_reg),
    w = v - s fhat.x': d/dx adds (g bM + e fM) dNc/dx, d/dx' adds Nc (s fM - t bM) mu_e'(w) (-s fhat).
    """
    n = x.shape[0]
    C, K0, Kn, Kf, Knx, Kfx = mats[_C], mats[_K0], mats[_KN], mats[_KF], mats[_KNX], mats[_KFX]
    bM, fM, b, fhat = vecs[_BM], vecs[_FM], vecs[_B], vecs[_FHAT]
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
