"""Compiled loops of the harmonic balance: the AFT Jacobian's assembly and the contact force.

The monodromy matrix is :func:`squealkit.solvers.ode.monodromy_rk4` (one RK4 monodromy for
the transient's Floquet exponents and the limit cycles).

Private: :mod:`squealkit.nonlinear.harmonic_balance` and :mod:`squealkit.nonlinear.continuation`
prepare the arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def aft_jacobian(ca, cb, omega, out):  # pragma: no cover - compiled
    """``P diag(a) E + omega P diag(b) E D`` into ``out`` (2H+1, n, 2H+1, n) from Fourier data.

    ``ca``, ``cb`` (2H+1, n, n) complex: ``c_q = (1/N) sum_j a_j exp(-i q tau_j)`` of the
    sampled ``df/dx`` and ``df/dv``, q = 0..2H. With ``c_{-q} = conj(c_q)``, for harmonics
    k, l >= 0 (rows ``[a_0, a_1..a_H, b_1..b_H]``):
    ``cc = Re(c_{k-l} + c_{k+l})``, ``sc = -Im(c_{k-l} + c_{k+l})``,
    ``cs = Im(c_{k-l} - c_{k+l})``, ``ss = Re(c_{k-l} - c_{k+l})``, row 0 halved;
    ``D`` (d/dtau) maps column ``c_l`` to ``-l s_l`` and ``s_l`` to ``l c_l``.
    """
    m = out.shape[0]
    n = out.shape[1]
    H = (m - 1) // 2
    for k in range(H + 1):
        half = 0.5 if k == 0 else 1.0
        for q in range(H + 1):
            d = k - q
            for i in range(n):
                for j in range(n):
                    if d >= 0:
                        am = ca[d, i, j]
                        bm = cb[d, i, j]
                    else:
                        am = np.conj(ca[-d, i, j])
                        bm = np.conj(cb[-d, i, j])
                    ap = ca[k + q, i, j]
                    bp = cb[k + q, i, j]
                    # P diag(a) E blocks
                    a_cc = half * (am.real + ap.real)
                    a_sc = -(am.imag + ap.imag)
                    a_cs = half * (am.imag - ap.imag)
                    a_ss = am.real - ap.real
                    b_cc = half * (bm.real + bp.real)
                    b_sc = -(bm.imag + bp.imag)
                    b_cs = half * (bm.imag - bp.imag)
                    b_ss = bm.real - bp.real
                    wl = omega * q
                    # column c_l: a_c - l omega b_s ; column s_l: a_s + l omega b_c
                    out[k, i, q, j] = a_cc - (wl * b_cs if q > 0 else 0.0)
                    if q > 0:
                        out[k, i, H + q, j] = a_cs + wl * b_cc
                    if k > 0:
                        out[H + k, i, q, j] = a_sc - (wl * b_ss if q > 0 else 0.0)
                        if q > 0:
                            out[H + k, i, H + q, j] = a_ss + wl * b_sc


@njit(cache=True)
def contact_force(X, V, mu, t, b, f, fhat, kc, s, kin, speed, sep, sign, strib, v_reg, mu_s, v_s):  # pragma: no cover
    """The point-contact force of :func:`squealkit.nonlinear.contact_system` and its derivatives.

    ``X``, ``V`` (K, n): displacements and velocities. Returns ``f`` (K, n), ``df/dx``,
    ``df/dv`` (K, n, n), ``df/dmu`` and ``df/dtan_theta`` (K, n)::

        f = N_c (d0 + mu_e d1),  d0 = b + s t f,  d1 = -t b + s f,  N_c = -kc (b_t.x) (>= 0 if sep)
        mu_e = mu(w) phi(w),  w = speed - s fhat.v,  b_t = b + kin s t fhat
    """
    K, n = X.shape
    out = np.zeros((K, n))
    dfdx = np.zeros((K, n, n))
    dfdv = np.zeros((K, n, n))
    dfdmu = np.zeros((K, n))
    dfdt = np.zeros((K, n))
    for r in range(K):
        gap = 0.0
        xf = 0.0
        vf = 0.0
        for i in range(n):
            gap += (b[i] + kin * s * t * fhat[i]) * X[r, i]
            xf += fhat[i] * X[r, i]
            vf += fhat[i] * V[r, i]
        nc = -kc * gap
        closed = True
        if sep and not nc > 0.0:
            closed = False
            nc = 0.0
        w = speed - s * vf
        if strib:
            ex = math.exp(-abs(w) / v_s)
            mw = mu + (mu_s - mu) * ex
            sw = 1.0 if w > 0 else (-1.0 if w < 0 else 0.0)
            dmw = -sw * (mu_s - mu) / v_s * ex
            dmu = 1.0 - ex
        else:
            mw = mu
            dmw = 0.0
            dmu = 1.0
        if sign:
            phi = math.tanh(w / v_reg)
            dphi = (1.0 - phi * phi) / v_reg
        else:
            phi = 1.0
            dphi = 0.0
        me = mw * phi
        dme_dw = dmw * phi + mw * dphi
        dme_dmu = dmu * phi
        dnc_dt = -kc * kin * s * xf if closed else 0.0
        for i in range(n):
            d0 = b[i] + s * t * f[i]
            d1 = -t * b[i] + s * f[i]
            di = d0 + me * d1
            out[r, i] = nc * di
            dfdmu[r, i] = nc * dme_dmu * d1
            dfdt[r, i] = nc * (s * f[i] - me * b[i]) + dnc_dt * di
            for j in range(n):
                if closed:
                    dfdx[r, i, j] = -kc * di * (b[j] + kin * s * t * fhat[j])
                dfdv[r, i, j] = -s * nc * dme_dw * d1 * fhat[j]
    return out, dfdx, dfdv, dfdmu, dfdt
