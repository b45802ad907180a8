"""The driver of the compiled integrators (:mod:`squealkit.solvers.ode`): a prepared run, chunk by chunk.

Each chunk is one call of a kernel (RK4, Dormand-Prince 5(4) or Rodas4) over at most
``_CHUNK_STEPS`` steps or ``_CHUNK_SAMPLES`` output samples, with the surface profile sampled for
it (q and tan(theta), cubic Hermite in time between ``_FORCING_PER_SAMPLE`` samples per output
sample); the state carries over from chunk to chunk inside the kernels, so the chunks do not
change the numbers. :func:`_integrate` gathers them into one in-memory run. A kernel takes the
named bundles of :mod:`squealkit.solvers.ode.bundles`, built here: the state, the model (``_prepare``'s
``arrays``), the chunk's forcing, its span (or RK4's steps), the tableau, the control, the outputs
and the log.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from .._threads import limit_threads, threads_for
from .._validation import check_memory
from ..solvers import ode
from ..solvers.ode.bundles import Control, DP5Tableau, Forcing, Log, Outputs, Rodas4Tableau, Span, State, Steps
from ._runs import Progress, _Run
from ._setup import _prepare
from ._step import _step_size

#: Samples of the surface profile per output sample (cubic Hermite in time between them).
_FORCING_PER_SAMPLE = 4
#: Output samples per compiled call of the adaptive integrator.
_CHUNK_SAMPLES = 1 << 14
#: Steps per compiled call (progress and divergence are checked between calls).
_CHUNK_STEPS = 1 << 17
#: Events recorded per run (contact loss/closure, stick/slip); later ones are counted only.
_MAX_EVENTS = 4096


def _dopri_tableau():
    from scipy.integrate._ivp.rk import RK45

    A = np.zeros((RK45.n_stages, RK45.n_stages))
    A[:, : RK45.A.shape[1]] = RK45.A
    return DP5Tableau(np.ascontiguousarray(A), np.ascontiguousarray(RK45.B), np.ascontiguousarray(RK45.C),
                      np.ascontiguousarray(RK45.E), np.ascontiguousarray(RK45.P))


def _rodas4_tableau():
    """Rodas4 in the transformed form of Hairer & Wanner II, eq. (IV.7.25), coefficients of their
    code RODAS (method 1): a_ij, c_ij, alpha_i, d_i (f_t), m_j, dense output D2, D3 and gamma."""
    A = np.zeros((6, 6))
    A[1, 0] = 1.544
    A[2, :2] = [0.9466785280815826, 0.2557011698983284]
    A[3, :3] = [3.314825187068521, 2.896124015972201, 0.9986419139977817]
    A[4, :4] = [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895]
    A[5, :4] = A[4, :4]
    A[5, 4] = 1.0
    Cm = np.zeros((6, 6))
    Cm[1, 0] = -5.6688
    Cm[2, :2] = [-2.430093356833875, -0.2063599157091915]
    Cm[3, :3] = [-0.1073529058151375, -9.594562251023355, -20.47028614809616]
    Cm[4, :4] = [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.7089089320616]
    Cm[5, :5] = [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136, -6.058818238834054]
    alpha = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
    d = np.array([0.25, -0.1043, 0.1035, -0.0362, 0.0, 0.0])
    m = np.array([*A[4, :4], 1.0, 1.0])
    dense = np.zeros((2, 6))
    dense[0, :5] = [10.12623508344586, -7.487995877610167, -34.80091861555747, -7.992771707568823, 1.025137723295662]
    dense[1, :5] = [-0.6762803392801253, 6.087714651680015, 16.43084320892478, 24.76722511418386, -6.594389125716872]
    return Rodas4Tableau(A, Cm, alpha, d, m, dense, 0.25)


def _chunks(setup: dict[str, Any], progress: Progress | None) -> Iterator[tuple[int, tuple[np.ndarray, ...]]]:
    """Integrate chunk by chunk, yielding ``(first sample, (x, v, a, nc, me))`` per chunk.

    Each chunk's outputs are a fresh buffer (NaN where a run stopped) of at most
    ``_CHUNK_SAMPLES + 1`` samples: the memory does not grow with the duration. The state
    (``X``, ``V``, the step sizes) carries over from chunk to chunk inside the kernels; the
    chunks are the same whatever the caller does with them, so a streamed run equals the
    in-memory one bit for bit. The per-run counters (``status``, ``n_valid``, steps, events)
    are updated in ``setup``.
    """
    if setup["method"] == "rk4":
        yield from _run_rk4(setup, progress)
    else:
        yield from _run_dopri5(setup, progress)


def _buffers(R: int, m: int, n: int) -> Outputs:
    return Outputs(np.full((R, m, n), np.nan), np.full((R, m, n), np.nan), np.full((R, m, n), np.nan),
                   np.full((R, m), np.nan), np.full((R, m), np.nan))


def _log(setup: dict[str, Any], adaptive: bool) -> Log:
    """The per-run status, counters and events of a run; an adaptive run's counters and events are
    also kept in ``setup`` (the result reports them); RK4 writes ``status`` and ``n_valid`` only."""
    R = setup["X"].shape[0]
    E = _MAX_EVENTS if adaptive else 0
    log = Log(setup["status"], setup["n_valid"], np.zeros((R, 4)), np.full((R, E), np.nan),
              np.zeros((R, E), dtype=np.int64), np.zeros(R, dtype=np.int64))
    if adaptive:
        setup.update(counts=log.counts, ev_t=log.ev_t, ev_k=log.ev_k, n_ev=log.n_ev)
    return log


#: Bytes per output sample and DOF, and per sample, of an in-memory run (the kernel's outputs,
#: the labelled variables and the growth rate's temporaries): 6 n + 24 doubles.
def _in_memory_bytes(n_runs: int, n_out: int, n: int) -> float:
    return 8.0 * n_runs * n_out * (6.0 * n + 24.0)


def _integrate(runs: Sequence[_Run], *, progress: Progress | None, memory_hint: str = "", **kw) -> dict[str, Any]:
    """The whole run in memory: the chunks of :func:`_chunks` gathered into arrays over all samples."""
    setup = _prepare(runs, **kw)
    R, n, n_out = len(runs), setup["n"], setup["n_out"]
    check_memory(_in_memory_bytes(R, n_out, n), f"A transient run of {n_out} samples" + (f" x {R} runs" if R > 1
                 else ""), memory_hint)
    outs = _buffers(R, n_out, n)
    for first, chunk in _chunks(setup, progress):
        k = chunk[0].shape[1]
        for full, part in zip(outs, chunk, strict=True):
            full[:, first:first + k] = part
    raw = {k: v for k, v in setup.items() if k not in ("X", "V", "arrays")}
    raw.update(time=np.arange(n_out) / setup["fs"], x=outs[0], v=outs[1], a=outs[2], nc=outs[3], me=outs[4])
    return raw


def _profile_samples(runs: Sequence[_Run], x_start: float, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """q and tan(theta) of every run at ``times`` (runs sharing a profile and speed evaluated once)."""
    R = len(runs)
    qh = np.empty((R, times.size))
    th = np.empty((R, times.size))
    seen: dict[tuple[int, float], int] = {}
    for i, run in enumerate(runs):
        j = seen.setdefault((id(run.profile), run.speed), i)
        if j == i:
            qh[i], th[i] = run.profile.evaluate(x_start + run.speed * times)
        else:
            qh[i], th[i] = qh[j], th[j]
    return qh, th


def _run_rk4(setup: dict[str, Any], progress: Progress | None) -> Iterator[tuple[int, tuple[np.ndarray, ...]]]:
    """Fixed-step classical RK4, chunk by chunk (q and slope at the half steps)."""
    runs, dt, stride, n_steps, status = setup["runs"], setup["dt"], setup["stride"], setup["n_steps"], setup["status"]
    R = len(runs)
    state = State(setup["X"], setup["V"], np.full(R, dt))
    log = _log(setup, adaptive=False)
    chunk = max(stride, (_CHUNK_STEPS // stride) * stride)
    done = 0
    while True:
        m = min(chunk, n_steps - done)  # m == 0: record the final state only
        qh, th = _profile_samples(runs, setup["x_start"], (done + 0.5 * np.arange(2 * m + 1)) * dt)
        first = done // stride
        outs = _buffers(R, m // stride if m else 1, setup["n"])
        with limit_threads(threads_for(R, serial_below=2)):  # parallel over runs: one run is serial
            ode.integrate_chunk(state, setup["arrays"], Forcing(qh, th, done * dt, 0.5 * dt),
                                Steps(m, stride, first, first), setup["limit"], outs, log)
        done += m
        yield first, outs
        if progress is not None:
            progress(done, n_steps)
        if m == 0 or np.all(status != 0):
            break


def _run_dopri5(setup: dict[str, Any], progress: Progress | None
                ) -> Iterator[tuple[int, tuple[np.ndarray, ...]]]:
    """Dormand-Prince 5(4) (or Rodas4, ``method="rosenbrock"``) with error control, chunk by chunk
    of output samples. Each run has its own step bound and tolerances (from its own model and
    friction), so that a run's numbers do not depend on the batch it is in."""
    runs, X, V, arrays, method = setup["runs"], setup["X"], setup["V"], setup["arrays"], setup["method"]
    fs, n_out, rtol, atol, status = setup["fs"], setup["n_out"], setup["rtol"], setup["atol_user"], setup["status"]
    R, n = X.shape
    per_run = [_step_size([run], fs, setup["dt_user"], setup["contact"], method) for run in runs]
    h_max = np.array([p[0] for p in per_run])
    w = np.array([max(p[2]["omega_max"], 1.0) for p in per_run])
    if atol is None:
        # displacement scale: the static deflection (or 1 nm); velocities scaled by omega_max
        x_ref = np.maximum(np.abs(X).max(axis=1), 1e-9)
        atol_x = 1e-3 * rtol * x_ref
    else:
        atol_x = np.full(R, atol)
    atol_a = np.ascontiguousarray(np.concatenate([np.repeat(atol_x[:, None], n, axis=1),
                                                  np.repeat((atol_x * w)[:, None], n, axis=1)], axis=1))
    tableau = _dopri_tableau() if method == "dopri5" else _rodas4_tableau()
    kernel = ode.integrate_adaptive if method == "dopri5" else ode.integrate_rosenbrock
    state = State(X, V, np.minimum(h_max, 0.1 / w))
    control = Control(rtol, atol_a, h_max, setup["limit"])
    log = _log(setup, adaptive=True)
    setup.update(atol=atol_a, h_max=h_max)
    per = _FORCING_PER_SAMPLE
    o_first = 0
    while o_first < n_out:
        o_last = min(n_out - 1, o_first + _CHUNK_SAMPLES)
        t_a, t_b = (o_first - (o_first > 0)) / fs, o_last / fs
        k_a = o_first - (o_first > 0)
        g = np.arange(k_a * per, o_last * per + 1) / (fs * per)
        qg, tg = _profile_samples(runs, setup["x_start"], g)
        outs = _buffers(R, o_last - o_first + 1, n)
        with limit_threads(threads_for(R, serial_below=2)):  # parallel over runs: one run is serial
            kernel(state, arrays, Forcing(qg, tg, g[0], 1.0 / (fs * per)), Span(t_a, t_b, fs, o_first, o_last, o_first),
                   tableau, control, outs, log)
        yield o_first, outs
        if progress is not None:
            progress(o_last, n_out - 1)
        o_first = o_last + 1
        if np.all(status != 0):
            break
