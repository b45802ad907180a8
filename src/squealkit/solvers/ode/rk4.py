"""Fixed-step classical RK4 (``integrate_chunk``), in parallel over a batch of runs.

It takes the bundles of the error-controlled methods (:mod:`.bundles`) but not their loop
(:mod:`.adaptive`): it records the state at its own steps, every ``stride`` of them, under the forcing
sampled at its half steps, where that loop writes samples at times ``o / fs`` by a dense output under
the forcing interpolated in time; through that loop its numbers would change (the sample times
accumulated from steps, the interpolated slope) and it would compile that loop's events and dense
output for nothing.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .force import _bundle, _rhs


@njit(error_model="numpy")
def _rk4_run(r, state, model, forcing, steps, limit, out, log):
    """Advance run r by ``steps.n_steps`` RK4 steps of ``state.H[r]`` (see :func:`integrate_chunk`)."""
    X, V, H = state
    n = X.shape[1]
    x = X[r].copy()
    xd = V[r].copy()
    work = (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
            np.empty(n))
    par = (model.mu[r], model.v[r], model.kin[r], model.kc[r], model.s[r], H[r])
    mats, vecs = _bundle(model.C[r], model.K0[r], model.Kn[r], model.Kf[r], model.Knx[r], model.Kfx[r],
                         model.bM[r], model.fM[r], model.F0[r], model.fn[r], model.ff[r], model.b[r], model.fhat[r])
    _rk4_steps(r, x, xd, work, par, mats, vecs, model.opts, forcing, steps, limit, out, log)
    for i in range(n):
        X[r, i] = x[i]
        V[r, i] = xd[i]


@njit(cache=True, error_model="numpy", _nrt=False)
def _rk4_steps(r, x, xd, work, par, mats, vecs, opts, forcing, steps, limit, out, log):
    """The steps of :func:`_rk4_run` from ``x``, ``xd`` (updated in place), with the scratch ``work`` and the
    run's ``par = (mu, v, kin, kc, s, dt)``. Compiled without reference counts (it allocates nothing): called
    with them, RK4 ran at half the speed (measured 0.025-0.028 s against 0.014-0.015 s for 0.2 s of the
    paper's case), each array an inlined right-hand side takes costing a count up and down."""
    xt, vt, k1x, k1v, k2x, k2v, k3x, k3v, k4v = work
    mu_r, v_r, kin_r, kc_r, s_r, dt = par
    qh, th = forcing.q, forcing.tan_theta
    n_steps, stride, o_base = steps.n_steps, steps.stride, steps.o_base
    status, n_valid = log.status, log.n_valid
    n = x.shape[0]
    o = steps.o_start
    for k in range(n_steps + 1):
        i0 = 2 * k
        if k % stride == 0 and (k < n_steps or n_steps == 0):
            nc, me = _rhs(x, 0, xd, 0, qh[r, i0], th[r, i0], mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k1v)
            bad = False
            for i in range(n):
                if not (abs(x[i]) <= limit):
                    bad = True
            if bad:
                status[r] = 1
                break
            if o - o_base < out.x.shape[1]:
                for i in range(n):
                    out.x[r, o - o_base, i] = x[i]
                    out.v[r, o - o_base, i] = xd[i]
                    out.a[r, o - o_base, i] = k1v[i]
                out.nc[r, o - o_base] = nc
                out.me[r, o - o_base] = me
                n_valid[r] = o + 1
            o += 1
        if k == n_steps:
            break
        q0, t0 = qh[r, i0], th[r, i0]
        q1, t1 = qh[r, i0 + 1], th[r, i0 + 1]
        q2, t2 = qh[r, i0 + 2], th[r, i0 + 2]
        _rhs(x, 0, xd, 0, q0, t0, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k1v)
        for i in range(n):
            k1x[i] = xd[i]
            xt[i] = x[i] + 0.5 * dt * k1x[i]
            vt[i] = xd[i] + 0.5 * dt * k1v[i]
        _rhs(xt, 0, vt, 0, q1, t1, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k2v)
        for i in range(n):
            k2x[i] = vt[i]
            xt[i] = x[i] + 0.5 * dt * k2x[i]
            vt[i] = xd[i] + 0.5 * dt * k2v[i]
        _rhs(xt, 0, vt, 0, q1, t1, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k3v)
        for i in range(n):
            k3x[i] = vt[i]
            xt[i] = x[i] + dt * k3x[i]
            vt[i] = xd[i] + dt * k3v[i]
        _rhs(xt, 0, vt, 0, q2, t2, mu_r, v_r, kin_r, kc_r, s_r, mats, vecs, opts, k4v)
        for i in range(n):
            x[i] += dt / 6.0 * (k1x[i] + 2.0 * k2x[i] + 2.0 * k3x[i] + vt[i])
            xd[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i])


@njit(cache=True, parallel=True)
def integrate_chunk(state, model, forcing, steps, limit, out, log):
    """Advance each run r by ``steps.n_steps`` RK4 steps of ``state.H[r]``; record every ``steps.stride`` steps.

    ``forcing.q[r, 2k + j]``/``forcing.tan_theta[r, 2k + j]`` hold q and tan(theta) at ``t_k + j dt/2``.
    The state at step 0 of the chunk is recorded at output index ``steps.o_start``, stored at
    ``o_start - o_base`` of the ``out`` buffers (which hold samples ``o_base...``); ``log.status[r]``
    turns 1 when a recorded displacement exceeds ``limit`` [m] (or is not finite) and the run then
    stops. The bundles are those of :mod:`.bundles`; the runs in parallel (``prange``).
    """
    status = log.status
    # the run's index as int64: prange's own is unsigned in the parallel loop, and a second integer type
    # would compile the run's loop twice
    for r in prange(state.X.shape[0]):
        if status[r] == 0:
            _rk4_run(np.int64(r), state, model, forcing, steps, limit, out, log)
