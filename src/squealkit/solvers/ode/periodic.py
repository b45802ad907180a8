"""The monodromy matrix of a periodic linear system by RK4: Floquet on a periodic run-out and the limit cycles."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


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
