"""What the error-controlled integrators share: dense output, event location and the output buffers."""

from __future__ import annotations

from numba import njit

from .force import _contact_at

# Event codes recorded per run:
EVENT_CONTACT_OPENS = 1
EVENT_CONTACT_CLOSES = 2
EVENT_STICK = 3   # the sliding speed |w| falls into the regularisation band v_reg
EVENT_SLIP = 4    # ... and leaves it


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
def _locate(slip, side_old, n_iter, z, z1, St, Co, h, rosenbrock, t, rhs, zd):
    """Fraction of the step at which the contact force changes sign (``slip`` False) or the sliding
    speed crosses the stick band ``|w| < v_reg`` (``slip`` True), by bisection on the dense output
    (:func:`_interp`); ``rhs``: the run's bundle (:func:`.force._run_rhs`)."""
    v_reg = rhs[12][4]
    lo, hi = 0.0, 1.0
    for _ in range(n_iter):
        mid = 0.5 * (lo + hi)
        _interp(z, z1, St, Co, h, mid, rosenbrock, zd)
        gm, wm = _contact_at(t + mid * h, zd, rhs)
        side = (wm < v_reg) if slip else (gm > 0.0)
        if side == side_old:
            lo = mid
        else:
            hi = mid
    return hi


@njit(cache=True, error_model="numpy")
def _log_event(r, t_ev, kind, log):
    """Record event ``kind`` at ``t_ev`` for run ``r`` in ``log`` (:class:`.bundles.Log`; counted even
    when the buffer is full)."""
    k_ev = log.n_ev[r]
    if k_ev < log.ev_t.shape[1]:
        log.ev_t[r, k_ev] = t_ev
        log.ev_k[r, k_ev] = kind
    log.n_ev[r] = k_ev + 1


@njit(cache=True, error_model="numpy")
def _store(r, o, o_base, z, dz, nc, me, limit, out, n_valid):
    """Write output sample ``o`` of run ``r`` at row ``o - o_base`` of the output buffers ``out``
    (:class:`.bundles.Outputs`); False (nothing written) if some |x_i| > ``limit``."""
    n = out.x.shape[2]
    for i in range(n):
        if not (abs(z[i]) <= limit):
            return False
    for i in range(n):
        out.x[r, o - o_base, i] = z[i]
        out.v[r, o - o_base, i] = z[n + i]
        out.a[r, o - o_base, i] = dz[n + i]
    out.nc[r, o - o_base] = nc
    out.me[r, o - o_base] = me
    n_valid[r] = o + 1
    return True
