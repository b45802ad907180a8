"""The one driver loop of the error-controlled integrators, built for a method's step (Dormand-Prince 5(4), Rodas4).

Everything but the step is the same for both methods: the step-size bounds, acceptance and the
controller, contact sign changes located on the step's dense output and the step retaken to end
just past them, stick/slip events, output samples by dense output, divergence and the counters.
:func:`_adaptive_for` compiles that loop around one method, given as

- ``work(m, tableau)``: the method's scratch arrays, a tuple whose item 0 holds f(t, z) in its row 0
  at the start of every step and item 1 the stages its dense output reads (:func:`.events._interp`);
- ``step(t, h, t_new, z, znew, work, tableau, rhs, atol, rtol)``: one step from (t, z) to znew at t_new,
  returning ``(ok, err, rhs calls, contact force and sliding speed at t_new)`` (``ok`` False: the step
  could not be taken, as with a singular Rodas4 matrix, and is halved);
- ``advance(work)``: what the method keeps from an accepted step (Dormand-Prince: its last stage is the
  next step's first, FSAL);
- its dense output's kind (``rosenbrock``), and its controller's exponent ``-1 / (order + 1)`` and
  largest growth of the step.

The method is a variable of the closure, fixed at compile time (as :func:`.periodic._rk4_for` does for
a right-hand side): each method's kernel compiles its own step only. The closure is called from each
method's module-level kernel (:func:`.dp5.integrate_adaptive`, :func:`.rosenbrock.integrate_rosenbrock`),
which numba's cache keeps with it.

The step and ``advance`` are compiled with ``_nrt=False`` (no reference counting; they allocate
nothing): each array taken out of a bundle costs numba a reference count up and down that its
pruning pass cannot pair, and with the step inlined into this loop, taking the run's bundled
right-hand side apart at every stage, a Dormand-Prince run took twice as long (measured 0.035 s
against 0.017 s for 0.2 s of the paper's case). Called, the step costs about 2 % of that run.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .events import (
    EVENT_CONTACT_CLOSES,
    EVENT_CONTACT_OPENS,
    EVENT_SLIP,
    EVENT_STICK,
    _interp,
    _locate,
    _log_event,
    _store,
)
from .force import _contact, _f_call, _run_rhs


def _adaptive_for(work, step, advance, rosenbrock, exponent, grow):
    """The per-run loop of an error-controlled method (see the module notes), compiled for it."""

    @njit(error_model="numpy")
    def run(r, state, model, forcing, span, tab, control, out, log):
        """Advance run ``r`` from ``span.t_a`` to ``span.t_b``; write its samples ``span.o_first..o_last``.

        Output sample ``o`` (time ``o / fs``) is written by dense output at row ``o - o_base`` of the
        ``out`` buffers. ``state.H[r]`` carries the step size between calls. With contact loss
        (opts[1]) a sign change of the contact force inside a step is located by bisection on the
        dense output and the step is retaken to end just past it, so no step straddles the kink; the
        events (and stick/slip band crossings with the sign law) are recorded in ``log``.
        ``log.status[r]``: 1 diverged (|x| > limit), 2 step size underflow.
        """
        X, V, H = state
        status, n_valid, counts = log.status, log.n_valid, log.counts
        t_b, fs, o_last, o_base = span.t_b, span.fs, span.o_last, span.o_base
        limit, rtol, atol_r, h_max_r = control.limit, control.rtol, control.atol[r], control.h_max[r]
        n = X.shape[1]
        m = 2 * n
        z = np.empty(m)
        for i in range(n):
            z[i] = X[r, i]
            z[n + i] = V[r, i]
        wk = work(m, tab)
        rows, stages, dense = wk[0], wk[1], tab.dense
        znew = np.empty(m)
        zd = np.empty(m)
        dzd1 = np.empty((1, m))  # the dense output's derivative (a row, as the stages')
        dzd = dzd1[0]
        rhs = _run_rhs(r, model, forcing, np.empty(n))
        v_reg = model.opts[4]
        separation, sign_law = model.opts[1] != 0.0, model.opts[2] != 0.0
        t = span.t_a
        h = H[r]
        o = span.o_first
        # the first sample of the chunk may sit exactly at t_a
        nc, me, q, tt_ = _f_call(t, z, rows, 0, rhs)
        counts[r, 2] += 1
        if o <= o_last and o / fs <= t + 1e-12 / fs:
            if not _store(r, o, o_base, z, rows[0], nc, me, limit, out, n_valid):
                status[r] = 1
            o += 1
        g_old, w_old = _contact(z, q, tt_, rhs)
        retake = False
        h_saved = h
        while t < t_b and status[r] == 0:
            h_min = 1e-14 * max(1.0, abs(t)) + 1e-300
            if h > h_max_r:
                h = h_max_r
            last = False
            if t + h >= t_b:
                h = t_b - t
                last = True
            t_new = t + h if not last else t_b
            ok, err, calls, g_new, w_new = step(t, h, t_new, z, znew, wk, tab, rhs, atol_r, rtol)
            counts[r, 2] += calls
            if not ok:
                counts[r, 1] += 1
                h *= 0.5
                if h < h_min:
                    status[r] = 2
                continue
            if not (err <= 1.0):
                counts[r, 1] += 1
                fac = 0.9 * err ** exponent if err == err and err < 1e300 else 0.2
                h *= max(0.2, fac)
                if h < h_min:
                    status[r] = 2
                continue
            # accepted: is there a contact event inside the step?
            if separation and (g_old > 0.0) != (g_new > 0.0) and not retake:
                hi = _locate(False, g_old > 0.0, 50, z, znew, stages, dense, h, rosenbrock, t, rhs, zd)
                if hi < 1.0 - 1e-9 and hi * h > h_min:
                    # retake the step to end just past the crossing: no step straddles the kink
                    # (f(t, z) in rows[0] is still valid: a step writes the other rows)
                    h_saved = h
                    h = hi * h
                    retake = True
                    continue
            counts[r, 0] += 1
            if h < counts[r, 3] or counts[r, 3] == 0.0:
                counts[r, 3] = h
            # events: contact (located above) and stick/slip band crossings (located here)
            if separation and (g_old > 0.0) != (g_new > 0.0):
                # the crossing on this step's dense output (the step was retaken to end near it, but its
                # end can lie a whole step past where the retaken solution crosses)
                hi = _locate(False, g_old > 0.0, 50, z, znew, stages, dense, h, rosenbrock, t, rhs, zd)
                _log_event(r, t + hi * h, EVENT_CONTACT_OPENS if g_new <= 0.0 else EVENT_CONTACT_CLOSES, log)
            if sign_law and (w_old < v_reg) != (w_new < v_reg):
                hi = _locate(True, w_old < v_reg, 40, z, znew, stages, dense, h, rosenbrock, t, rhs, zd)
                _log_event(r, t + hi * h, EVENT_STICK if w_new < v_reg else EVENT_SLIP, log)
            # output samples inside (t, t_new] by dense output
            while o <= o_last and o / fs <= t_new * (1.0 + 1e-15):
                _interp(z, znew, stages, dense, h, min((o / fs - t) / h, 1.0), rosenbrock, zd)
                ncs, mes, _q, _t = _f_call(o / fs, zd, dzd1, 0, rhs)
                if not _store(r, o, o_base, zd, dzd, ncs, mes, limit, out, n_valid):
                    status[r] = 1
                    break
                o += 1
            if status[r] != 0:
                break
            t = t_new
            for i in range(m):
                z[i] = znew[i]
            advance(wk)
            g_old, w_old = g_new, w_new
            if not retake:
                fac = 0.9 * err ** exponent if err > 0.0 else grow
                h = h * min(grow, max(0.2, fac))
            else:
                h = h_saved  # after the event, the step the controller had before it
            retake = False
            if h < h_min:
                status[r] = 2
        for i in range(n):
            X[r, i] = z[i]
            V[r, i] = z[n + i]
        H[r] = h

    return run
