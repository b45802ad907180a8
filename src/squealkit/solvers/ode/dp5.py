"""Dormand-Prince 5(4) with error control, dense output and event location (``integrate_adaptive``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .adaptive import _adaptive_for
from .force import _contact, _f

# -- error-controlled integration: Dormand-Prince 5(4) with dense output and events ---------------
#
# The tableau (A, B, C), the error weights E = b5 - b4 and the 4th-order dense-output matrix P
# are those of Dormand & Prince (1980) as tabulated by SciPy's RK45 (Hairer, Norsett & Wanner,
# Solving ODEs I, II.4-II.6); the transient driver passes them in (:class:`.bundles.DP5Tableau`).
# The loop around the step (control, events, output) is :mod:`.adaptive`'s, shared with Rodas4.


@njit(cache=True)
def _dp5_work(m, tab):
    """The stages K (S + 1, m), K[0] = f(t, z) (twice: the rows of f(t, z) and the dense output's
    stages), and the stage state."""
    K = np.empty((tab.A.shape[0] + 1, m))
    return K, K, np.empty(m)


@njit(cache=True, error_model="numpy", _nrt=False)
def _dp5_step(t, h, t_new, z, znew, work, tab, rhs, atol, rtol):
    """One Dormand-Prince step of ``h`` from (t, z) to ``znew``; returns ``(True, err, rhs calls, contact
    force and sliding speed at t_new)`` (:func:`.force._contact`), err the RMS of the error estimate over
    ``atol + rtol max(|z|, |znew|)``. Compiled without reference counts (see :mod:`.adaptive`)."""
    K, _stages, zt = work
    A, Bw, Cn, E = tab.A, tab.B, tab.C, tab.E
    S = A.shape[0]  # stages before the FSAL stage
    m = z.shape[0]
    q = 0.0
    tt_ = 0.0
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
        _nc, _me, q, tt_ = _f(tk, zt, K, k, rhs)
    err = 0.0
    for i in range(m):
        e = 0.0
        for j in range(S + 1):
            e += E[j] * K[j, i]
        sc = atol[i] + rtol * max(abs(z[i]), abs(znew[i]))
        e = h * e / sc
        err += e * e
    g_new, w_new = _contact(znew, q, tt_, rhs)
    return True, math.sqrt(err / m), S, g_new, w_new


@njit(cache=True, _nrt=False)
def _dp5_advance(work):
    """FSAL: the accepted step's last stage is the next step's first."""
    K = work[0]
    S = K.shape[0] - 1
    for i in range(K.shape[1]):
        K[0, i] = K[S, i]


_dp5_run = _adaptive_for(_dp5_work, _dp5_step, _dp5_advance, False, -0.2, 10.0)


@njit(cache=True, parallel=True)
def integrate_adaptive(state, model, forcing, span, tableau, control, out, log):
    """Advance each run from ``span.t_a`` to ``span.t_b`` by Dormand-Prince 5(4) with error control.

    The bundles are those of :mod:`.bundles` (``tableau`` a :class:`.bundles.DP5Tableau`); the runs in
    parallel (``prange``), each by the loop of :mod:`.adaptive`: output samples by dense output,
    contact sign changes located and the step retaken to end there, stick/slip events, and
    ``log.counts[r] = [accepted, rejected, rhs calls, smallest step]``.
    """
    status = log.status
    # the run's index as int64: prange's own is unsigned in the parallel loop, and a second integer type
    # would compile the run's loop twice
    for r in prange(state.X.shape[0]):
        if status[r] == 0:
            _dp5_run(np.int64(r), state, model, forcing, span, tableau, control, out, log)
