"""Transient time simulation of a friction model sliding over a disc surface profile.

Solves the paper's equations of motion (eqs. 1-4) with time-varying run-out q(t) and slope
tan(theta(t)) = dq/dx at x = x_start + v t (eqs. 9-11) in compiled code, and returns an
:class:`xarray.Dataset` sampled at ``fs``. Two integrators:

- ``"dopri5"`` (default): Dormand-Prince 5(4) with error control (``rtol``, ``atol``), a step
  per run, output by its 4th-order dense interpolant at ``fs``; contact loss and closure are
  located inside a step (bisection on the interpolant) and the step is retaken to end there;
  stick/slip transitions of the regularised friction law are located and recorded.
- ``"rosenbrock"``: Rodas4 (Hairer & Wanner, Solving ODEs II, sec. IV.7, code RODAS), a
  linearly implicit, L-stable Rosenbrock 4(3) pair with the analytic Jacobian of the force law,
  for stiff friction laws (small ``v_reg``): its step is bounded by the error control only (and
  by ``3 / omega_max``), not by the friction law's stability bound. Output by its own 3rd-order
  dense output; contact and stick/slip events as for ``"dopri5"``.
- ``"rk4"``: classical RK4 with a fixed step (the earlier integrator, for order studies).

The explicit ones respect a step bound from the fastest mode and from the friction law's own stiffness:
regularised friction ``mu N tanh(w / v_reg)`` acts like a damper ``mu N / v_reg`` on the sliding
direction (and a Stribeck law adds ``(mu_static - mu) N / v_stribeck``), whose explicit
stability limit ``~2.5 / (c fhat.M^-1.fhat)`` can be far below the modes' (see
:func:`step_bound`). The q and slope samples are interpolated in time by cubic Hermite
polynomials through q and dq/dt = v tan(theta) (4 samples per output sample).
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .._deprecation import renamed_kwargs
from .._threads import limit_threads, thread_limit, threads_for
from .._validation import (
    InputError,
    check_budget,
    check_memory,
    validate_dataset,
    validate_finite,
    validate_fs,
    validate_model,
    validate_plausible,
    validate_positive,
)
from ..models import FrictionModel
from ..solvers import ode
from ..stability.eigen import eigenvalues
from .contact import Contact, as_contact, contact_geometry
from .profiles import Smooth, SurfaceProfile

__all__ = ["AliasingWarning", "TensileContactWarning", "response_envelope", "simulate", "simulate_batch",
           "simulate_blocks", "step_bound", "transient_summary"]

#: RK4 step as a fraction of the period of the fastest mode: dt <= STEP_FACTOR / omega_max.
STEP_FACTOR = 0.25
#: Explicit stability of a damper c on a mass m: h <= STABILITY_FACTOR m / c (RK4's real-axis
#: limit is 2.79, Dormand-Prince 5's 3.3; kept below both).
STABILITY_FACTOR = 2.5
#: Largest Dormand-Prince step as a multiple of 1 / omega_max (its stability limit ~3.3 on the
#: imaginary axis is never reached by the error control at useful tolerances).
DOPRI_OMEGA_FACTOR = 3.0
#: Samples of the surface profile per output sample (cubic Hermite in time between them).
_FORCING_PER_SAMPLE = 4
#: Output samples per compiled call of the adaptive integrator.
_CHUNK_SAMPLES = 1 << 14
#: Events recorded per run (contact loss/closure, stick/slip); later ones are counted only.
_MAX_EVENTS = 4096
#: A lower bound of the time of one integration step of one 3-DOF run [s] (for the work budget).
_SECONDS_PER_STEP = 2e-7
METHODS = ("dopri5", "rosenbrock", "rk4")
_EVENT_NAMES = {1: "contact_opens", 2: "contact_closes", 3: "stick", 4: "slip"}
_STATUS = {0: "completed", 1: "diverged", 2: "failed"}


class TensileContactWarning(UserWarning):
    """The linear (paper's) contact law carried a pulling normal force: run with contact loss."""


class AliasingWarning(UserWarning):
    """The output sample rate ``fs`` is below twice the model's highest natural frequency.

    The integrator's step does not depend on ``fs`` (it follows the error control and the
    modes' bound), but the outputs are sampled from it, not filtered: vibration above
    ``fs / 2`` shows up at a false, aliased frequency and peaks between samples are missed.
    """


def _check_sampling(fs: float, omega_max: float) -> None:
    """Warn (:class:`AliasingWarning`) when ``fs`` cannot represent the fastest mode."""
    f_max = omega_max / (2 * math.pi)
    if fs < 2.0 * f_max:
        warnings.warn(
            f"fs={fs:g} Hz is below twice the model's highest natural frequency {f_max:.0f} Hz: the outputs are "
            f"sampled, not filtered (the integration step does not depend on fs), so vibration above fs/2 = "
            f"{fs / 2:g} Hz appears aliased and peaks are missed; use fs >= {math.ceil(2 * f_max)} Hz.",
            AliasingWarning, stacklevel=4)


def _dopri_tableau():
    from scipy.integrate._ivp.rk import RK45

    A = np.zeros((RK45.n_stages, RK45.n_stages))
    A[:, : RK45.A.shape[1]] = RK45.A
    return (np.ascontiguousarray(A), np.ascontiguousarray(RK45.B), np.ascontiguousarray(RK45.C),
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
    return A, Cm, alpha, d, m, dense, 0.25


#: Steps per compiled call (progress and divergence are checked between calls).
_CHUNK_STEPS = 1 << 17

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class _Run:
    model: FrictionModel
    mu: float
    profile: SurfaceProfile
    speed: float


def _validate_model(model: object) -> FrictionModel:
    if not isinstance(model, FrictionModel):
        raise InputError(f"Parameter model must be a squealkit FrictionModel; got {type(model).__name__}.")
    return model


def _omega_max(runs: Sequence[_Run]) -> float:
    """Largest |lambda| [rad/s] of the damped linear models of the runs (flat disc)."""
    wmax = 0.0
    by_model: dict[int, tuple[FrictionModel, list[float]]] = {}
    for run in runs:
        by_model.setdefault(id(run.model), (run.model, []))[1].append(run.mu)
    for model, mus in by_model.values():
        lam = eigenvalues(model, np.unique(mus), tan_theta=0.0, damped=True)
        wmax = max(wmax, float(np.abs(lam).max()))
    return wmax


def _friction_rate(run: _Run, contact: Contact) -> float:
    """Largest rate [1/s] of the friction law's velocity dependence: ``c fhat.M^-1.fhat`` with
    ``c = mu N0 / v_reg`` (sign law) plus ``|mu_static - mu| N0 / v_stribeck`` (Stribeck), N0 the
    static contact force (doubled: the dynamic force swings about it). 0 for the linear law."""
    if contact.is_linear:
        return 0.0
    ok, _kc, _b, f = contact_geometry(run.model)
    if not ok:
        return 0.0
    fhat = f / max(float(np.linalg.norm(f)), 1e-300)
    mob = float(fhat @ np.linalg.solve(run.model.mass_matrix(), fhat))
    n0 = 2.0 * abs(float(run.model.static_contact_force(contact.sliding_mu(run.mu, run.speed))))
    mu_top = max(abs(run.mu), contact.mu_static or 0.0)
    c = mu_top * n0 / contact.v_reg if contact.sign_friction else 0.0
    if contact.mu_static is not None:
        c += abs(contact.mu_static - run.mu) * n0 / contact.v_stribeck
    return c * mob


def step_bound(model: FrictionModel, *, mu: float, contact: Contact | str = "linear", speed: float = 0.02,
               method: str = "dopri5") -> dict[str, float]:
    """The largest stable explicit step [s] for a model, and what sets it.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : float
        Friction coefficient (kinetic value for the Stribeck law).
    contact : Contact or {"linear", "nonlinear"}, default "linear"
        Contact law (see :class:`Contact`).
    speed : float, default 0.02
        Sliding speed [m/s], >= 0.
    method : {"dopri5", "rosenbrock", "rk4"}, default "dopri5"
        Integrator whose mode bound is wanted (see :func:`simulate`).

    Returns
    -------
    dict of str to float
        ``{"omega_max": ..., "friction_rate": ..., "mode_bound": ..., "friction_bound": ...,
        "bound": ...}``: the fastest mode omega_max [rad/s] gives ``0.25 / omega_max`` (RK4, for
        accuracy) or ``3 / omega_max`` (Dormand-Prince, stability); a regularised or Stribeck
        friction law a rate ``c fhat.M^-1.fhat`` [1/s] (``c = mu N / v_reg``: see the module notes)
        and ``2.5 / rate``. ``bound`` is the smaller [s].

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> from squealkit.transient import Contact
    >>> b = step_bound(get_preset("lv2013"), mu=0.4, contact=Contact.nonlinear(v_reg=1e-5), speed=0.0)
    >>> b["friction_bound"] < b["mode_bound"]     # the friction law is the stiffer part
    True
    """
    validate_model(model)
    run = _Run(_validate_model(model), validate_finite("mu", mu), Smooth(), validate_plausible("speed", speed))
    return _bounds([run], as_contact(contact), _validate_method(method))


def _bounds(runs: Sequence[_Run], contact: Contact, method: str) -> dict[str, float]:
    wmax = _omega_max(runs)
    rate = max(_friction_rate(r, contact) for r in runs)
    mode = (STEP_FACTOR if method == "rk4" else DOPRI_OMEGA_FACTOR) / wmax if wmax > 0 else math.inf
    fric = STABILITY_FACTOR / rate if rate > 0 else math.inf
    return {"omega_max": wmax, "friction_rate": rate, "mode_bound": mode, "friction_bound": fric,
            "bound": min(mode, fric)}


def _validate_method(method: object) -> str:
    if method not in METHODS:
        raise InputError(f"Parameter method={method!r} must be one of {', '.join(map(repr, METHODS))}.")
    return str(method)


def _step_size(runs: Sequence[_Run], fs: float, dt: float | None, contact: Contact | None = None,
               method: str = "rk4") -> tuple[float, int, dict[str, float]]:
    """Step dt [s] (RK4: fixed; Dormand-Prince: the largest), steps per output sample (RK4:
    1/fs = stride * dt) and the bounds. A given ``dt`` beyond the friction law's stability
    bound is an error for RK4 (it would integrate noise) and is cut to it for Dormand-Prince."""
    bounds = _bounds(runs, contact or Contact.linear(), method)
    if method == "rosenbrock":  # L-stable: only the modes' bound (accuracy of the forcing) caps the step
        mode = bounds["mode_bound"] if math.isfinite(bounds["mode_bound"]) else 1.0 / fs
        return (mode if dt is None else min(validate_positive("dt", dt), mode)), 1, bounds
    if dt is None:
        dt_max = bounds["bound"] if math.isfinite(bounds["bound"]) else 1.0 / fs
    else:
        dt_max = validate_positive("dt", dt)
        if dt_max > bounds["friction_bound"] * (1 + 1e-12):
            if method == "rk4":
                raise InputError(
                    f"Parameter dt={dt!r} s exceeds the stability bound {bounds['friction_bound']:.3g} s of the "
                    "friction law (mu N / v_reg acts as a damper on the sliding direction); use a smaller dt or "
                    "method='dopri5'.")
            dt_max = bounds["friction_bound"]
    if method == "dopri5":
        return dt_max, 1, bounds
    stride = max(1, math.ceil((1.0 / fs) / dt_max * (1 - 1e-12)))
    return 1.0 / (fs * stride), stride, bounds


def _initial_state(
    run: _Run, contact: Contact, x0, v0, perturbation: float, noise, x_start: float
) -> tuple[np.ndarray, np.ndarray]:
    n = run.model.n_dof
    q0, t0 = (float(a[0]) for a in run.profile.evaluate(np.array([x_start])))
    if x0 is None:
        # At rest in the static equilibrium of t = 0: K(0) x = F(0) (paper eq. 4), with the
        # friction coefficient of steady sliding at the run's speed (Stribeck: mu(v), not mu).
        x = run.model.static_equilibrium(contact.sliding_mu(run.mu, run.speed), t0, q0)
    else:
        x = np.array(x0, dtype=float).reshape(-1)
        if x.shape != (n,) or not np.all(np.isfinite(x)):
            raise InputError(f"Parameter x0 must be {n} finite displacements {run.model.dof_names} [m].")
    v = np.zeros(n) if v0 is None else np.array(v0, dtype=float).reshape(-1)
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise InputError(f"Parameter v0 must be {n} finite velocities [m/s].")
    if perturbation:
        x = x + perturbation * noise
    return x, v


def _perturbation_noise(perturbation: float, rng, n_runs: int, n: int) -> np.ndarray:
    """Standard-normal perturbation per run, shape (n_runs, n): drawn from ``rng`` run after
    run, or given (an array: the rows a distributed batch's piece takes from the whole)."""
    if not perturbation:
        return np.zeros((n_runs, n))
    if isinstance(rng, np.ndarray):
        return rng
    if not isinstance(rng, np.random.Generator):
        raise InputError("A perturbation needs rng, a numpy.random.Generator (numpy.random.default_rng(seed)).")
    return rng.standard_normal((n_runs, n))


def _prepare(
    runs: Sequence[_Run],
    *,
    duration: float,
    fs: float,
    contact: Contact,
    x0,
    v0,
    perturbation: float,
    rng,
    x_start: float,
    dt: float | None,
    limit: float,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
) -> dict[str, Any]:
    """Validate, build the per-run arrays and the initial states: everything but the outputs."""
    method = _validate_method(method)
    rtol = validate_positive("rtol", rtol)
    if not 1e-13 <= rtol < 1:
        raise InputError(f"Parameter rtol={rtol!r} must lie in [1e-13, 1).")
    if atol is not None:
        atol = validate_positive("atol", atol)
    duration = validate_positive("duration", duration)
    fs = validate_fs(fs)
    limit = validate_positive("limit", limit)
    perturbation = validate_positive("perturbation", perturbation, allow_zero=True)
    x_start = validate_finite("x_start", x_start)
    n_out = math.floor(duration * fs * (1 + 1e-12)) + 1
    if n_out < 2:
        raise InputError(f"Parameter duration={duration!r} s is shorter than one sample at fs={fs!r} Hz.")
    n = runs[0].model.n_dof
    if any(r.model.n_dof != n for r in runs):
        raise InputError("All models of a batch must have the same number of degrees of freedom.")
    dt_user = dt
    dt, stride, bounds = _step_size(runs, fs, dt, contact, method)
    _check_sampling(fs, bounds["omega_max"])
    n_steps = (n_out - 1) * stride
    t_end = (n_out - 1) / fs
    # adaptive methods take at least t_end / dt_max steps; a step of R runs costs at least
    # _SECONDS_PER_STEP (n / 3)^2 each (measured 0.8-2.3 us on the 3-DOF paper model)
    least = max(n_steps if method == "rk4" else 0, t_end / dt)
    check_budget(f"A transient run of {t_end:.6g} s ({least:.3g} steps" + (f" x {len(runs)} runs)" if len(runs) > 1
                 else ")"), seconds=len(runs) * least * _SECONDS_PER_STEP * (n / 3) ** 2 / thread_limit(),
                 hint="Use a shorter duration.")
    for run in runs:
        run.profile.check_range(min(x_start, x_start + run.speed * t_end), max(x_start, x_start + run.speed * t_end))

    R = len(runs)
    geo = [contact_geometry(r.model) for r in runs]
    if not contact.is_linear and not all(g[0] for g in geo):
        raise InputError(
            "Nonlinear contact needs a model with one point contact (Kn = kc b b^T, Kf = kc f b^T); "
            "use contact='linear' for this model."
        )
    Minv = [np.linalg.inv(r.model.mass_matrix()) for r in runs]

    def stack(fn):
        """Per-run arrays premultiplied by M^-1 (the kernel works with accelerations)."""
        return np.ascontiguousarray(np.stack([Minv[i] @ fn(r) for i, r in enumerate(runs)]), dtype=float)

    C = stack(lambda r: r.model.damping_matrix())
    K0 = stack(lambda r: r.model.stiffness_parts()[0])
    Kn = stack(lambda r: r.model.stiffness_parts()[1])
    Kf = stack(lambda r: r.model.stiffness_parts()[2])
    Knx = stack(lambda r: r.model.slope_parts()[0])
    Kfx = stack(lambda r: r.model.slope_parts()[1])
    kin = np.array([float(r.model.slope_coupled) for r in runs])
    F0 = stack(lambda r: r.model.load_parts()[0])
    fn = stack(lambda r: r.model.load_parts()[1])
    ff = stack(lambda r: r.model.load_parts()[2])
    kc = np.array([g[1] for g in geo])
    b = np.ascontiguousarray(np.stack([g[2] for g in geo]))
    f = np.ascontiguousarray(np.stack([g[3] for g in geo]))
    fhat = np.ascontiguousarray(f / np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-300))
    bM = np.ascontiguousarray(np.einsum("rij,rj->ri", np.stack(Minv), b))
    fM = np.ascontiguousarray(np.einsum("rij,rj->ri", np.stack(Minv), f))
    s = np.array([float(r.model.sliding_direction) for r in runs])
    mu = np.array([r.mu for r in runs])
    v = np.array([r.speed for r in runs])
    opts = contact.options()

    X = np.empty((R, n))
    V = np.empty((R, n))
    noise = _perturbation_noise(perturbation, rng, R, n)
    for i, run in enumerate(runs):
        X[i], V[i] = _initial_state(run, contact, x0, v0, perturbation, noise[i], x_start)
    status = np.zeros(R, dtype=np.int64)
    n_valid = np.zeros(R, dtype=np.int64)
    arrays = (bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, f, fhat, kc, s, mu, v, opts)
    return dict(runs=runs, X=X, V=V, arrays=arrays, n=n, n_out=n_out, n_steps=n_steps, status=status,
                n_valid=n_valid, dt=dt, dt_user=dt_user, stride=stride, x_start=x_start, limit=limit, contact=contact,
                rtol=rtol, atol_user=atol, bounds=bounds, method=method, fs=fs)


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


def _buffers(R: int, m: int, n: int) -> tuple[np.ndarray, ...]:
    return (np.full((R, m, n), np.nan), np.full((R, m, n), np.nan), np.full((R, m, n), np.nan),
            np.full((R, m), np.nan), np.full((R, m), np.nan))


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
    runs, X, V, arrays = setup["runs"], setup["X"], setup["V"], setup["arrays"]
    dt, stride, n_steps, status = setup["dt"], setup["stride"], setup["n_steps"], setup["status"]
    R = len(runs)
    chunk = max(stride, (_CHUNK_STEPS // stride) * stride)
    done = 0
    while True:
        m = min(chunk, n_steps - done)  # m == 0: record the final state only
        qh, th = _profile_samples(runs, setup["x_start"], (done + 0.5 * np.arange(2 * m + 1)) * dt)
        first = done // stride
        outs = _buffers(R, m // stride if m else 1, setup["n"])
        with limit_threads(threads_for(R, serial_below=2)):  # parallel over runs: one run is serial
            ode.integrate_chunk(X, V, *arrays, qh, th, dt, m, stride, *outs, first, setup["limit"], status,
                                setup["n_valid"], first)
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
    H = np.minimum(h_max, 0.1 / w)
    setup.update(counts=np.zeros((R, 4)), ev_t=np.full((R, _MAX_EVENTS), np.nan),
                 ev_k=np.zeros((R, _MAX_EVENTS), dtype=np.int64), n_ev=np.zeros(R, dtype=np.int64), atol=atol_a,
                 h_max=h_max)
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
            kernel(
                X, V, H, *arrays, qg, tg, g[0], 1.0 / (fs * per), t_a, t_b, fs, o_first, o_last, o_first, *tableau,
                rtol, atol_a, h_max, *outs, setup["limit"], status, setup["n_valid"], setup["counts"], setup["ev_t"],
                setup["ev_k"], setup["n_ev"],
            )
        yield o_first, outs
        if progress is not None:
            progress(o_last, n_out - 1)
        o_first = o_last + 1
        if np.all(status != 0):
            break


def _run_dataset(run: _Run, raw: dict, i: int, n_keep: int) -> xr.Dataset:
    """Labelled result of run i, first ``n_keep`` samples."""
    model = run.model
    time = raw["time"][:n_keep]
    pos = raw["x_start"] + run.speed * time
    q, tan_theta = run.profile.evaluate(pos)
    nc = raw["nc"][i, :n_keep]
    me = raw["me"][i, :n_keep]
    structured, kc, _, _ = contact_geometry(model)
    if raw["contact"].is_linear:
        # N cos(theta) = -kc (b_t.x - q) (eq. 2), also for output of the linear law.
        nc = (-kc * (np.sum(raw["x"][i, :n_keep] * model.contact_normal(tan_theta), axis=-1) - q)
              if structured else np.full(n_keep, np.nan))
    normal = nc * np.sqrt(1.0 + tan_theta**2)  # eq. (2): N = -kc (y1 - y2 - q) / cos(theta)
    # sigma depends on tan(theta) only (mu fixed): solve once per distinct slope (to 1e-12).
    slopes, inverse = np.unique(np.round(tan_theta, 12), return_inverse=True)
    law = raw["contact"].friction_law
    fr = {"friction": law, "speed": run.speed} if law is not None and run.speed > 0 else {}
    sigma = eigenvalues(model, run.mu, tan_theta=slopes, damped=True, **fr).real.max(axis=-1)[inverse.reshape(-1)]
    data: dict[str, tuple] = {}
    for j, name in enumerate(model.dof_names):
        data[name] = ("time", raw["x"][i, :n_keep, j], {"units": "m", "long_name": f"displacement {name}"})
        data[f"{name}_dot"] = ("time", raw["v"][i, :n_keep, j], {"units": "m/s", "long_name": f"velocity {name}"})
        data[f"{name}_ddot"] = (
            "time", raw["a"][i, :n_keep, j], {"units": "m/s^2", "long_name": f"acceleration {name}"},
        )
    data["normal_force"] = ("time", normal, {"units": "N", "long_name": "normal contact force N (eq. 2)"})
    data["friction_force"] = ("time", me * normal, {"units": "N", "long_name": "friction force F_f = mu N (eq. 3)"})
    data["q"] = ("time", q, {"units": "m", "long_name": "surface run-out q (eq. 10)"})
    data["tan_theta"] = ("time", tan_theta, {"units": "1", "long_name": "run-out slope tan(theta) (eq. 11)"})
    data["mu_e"] = ("time", me + tan_theta, {"units": "1", "long_name": "equivalent friction mu + tan(theta) (eq. 6)"})
    data["growth_rate"] = (
        "time", sigma,
        {"units": "1/s", "long_name": "frozen-time growth rate sigma(t) = max Re(lambda) (eq. 8, damped)"},
    )
    attrs = {}
    if raw["contact"].is_linear and np.isfinite(normal).any():
        # the paper's law keeps the contact closed whatever the force: say how often it pulled
        attrs = {"tensile_fraction": float(np.mean(normal < 0.0)), "min_normal_force": float(np.nanmin(normal))}
    return xr.Dataset(
        data,
        coords={
            "time": ("time", time, {"units": "s", "long_name": "time"}),
            "position": ("time", pos, {"units": "m", "long_name": "sliding position x = x_start + v t"}),
        },
        attrs=attrs,
    )


def _attrs(run: _Run, raw: dict, status: str, t_stop: float, fs: float, i: int = 0) -> dict:
    return {
        "kind": "simulation",
        "title": "squealkit transient simulation",
        "reference": "Lv, Zhang & Yu, J. Vibroeng. 15(2) 2013, eqs. 1-4 and 9-11",
        "model": run.model.to_json(),
        "model_kind": run.model.kind,
        "kinematics": run.model.kinematics_option,
        "mu": run.mu,
        "speed": run.speed,
        "speed_units": "m/s",
        "profile": run.profile.describe(),
        "profile_kind": run.profile.kind,
        "contact": raw["contact"].describe(),
        "fs": fs,
        "status": status,
        "t_stop": t_stop,
        "divergence_limit": raw["limit"],
        **_integrator_attrs(raw, i),
    }


def _integrator_attrs(raw: dict, i: int) -> dict:
    """What the integrator did for run i: method, steps, bounds (one vocabulary for both methods)."""
    b = raw["bounds"]
    dt = raw["dt"] if raw["method"] == "rk4" else float(raw["h_max"][i])
    out = {"method": raw["method"], "dt": dt, "step_bound_modes": b["mode_bound"],
           "step_bound_friction": b["friction_bound"] if math.isfinite(b["friction_bound"]) else 0.0}
    if raw["method"] == "rk4":
        out.update(integrator="classical RK4, fixed step (numba)", steps_per_sample=raw["stride"])
    else:
        steps, rejected, calls, hmin = raw["counts"][i]
        name = ("Dormand-Prince 5(4)" if raw["method"] == "dopri5" else
                "Rodas4 Rosenbrock 4(3), analytic Jacobian")
        out.update(integrator=f"{name}, error control, dense output, event location (numba)",
                   rtol=raw["rtol"], atol=float(raw["atol"][i, 0]), steps=int(steps), rejected_steps=int(rejected),
                   rhs_calls=int(calls), min_step=float(hmin))
    return out


def _as_runs(models, mus, profiles, speeds) -> list[_Run]:
    R = max(len(models), len(mus), len(profiles), len(speeds))
    out = []
    for seq, name in ((models, "model"), (mus, "mu"), (profiles, "profile"), (speeds, "speed")):
        if len(seq) not in (1, R):
            raise InputError(f"Batch parameter {name} has {len(seq)} entries; expected 1 or {R}.")
    def pick(seq, i):
        return seq[i if len(seq) > 1 else 0]

    for i in range(R):
        profile = pick(profiles, i)
        if profile is None:
            profile = Smooth()
        if not isinstance(profile, SurfaceProfile):
            raise InputError(f"Parameter profile must be a SurfaceProfile; got {type(profile).__name__}.")
        out.append(
            _Run(
                _validate_model(pick(models, i)),
                validate_finite("mu", pick(mus, i)),
                profile,
                validate_plausible("speed", pick(speeds, i)),
            )
        )
    return out


def simulate(
    model: FrictionModel,
    *,
    mu: float,
    profile: SurfaceProfile | None = None,
    speed: float = 0.02,
    duration: float,
    fs: float = 40_000.0,
    contact: Contact | str = "linear",
    x0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    perturbation: float = 0.0,
    rng: np.random.Generator | None = None,
    x_start: float = 0.0,
    dt: float | None = None,
    limit: float = 1.0,
    progress: Progress | None = None,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
) -> xr.Dataset:
    """Time response of a model sliding over a disc surface profile (paper section 4).

    Integrates ``M x'' + C x' + K(mu, tan_theta(t)) x = F(mu, tan_theta(t), q(t))`` (eq. 4)
    with q and tan(theta) from the profile at ``x = x_start + speed * t`` (eqs. 9-11), by
    Dormand-Prince 5(4) with error control (default) or classical RK4 with a fixed step,
    output every ``1/fs`` (see the module notes for the step bound and the events).

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : float
        Friction coefficient (kinetic value for the Stribeck law).
    profile : SurfaceProfile, optional
        Disc surface; default :class:`~squealkit.transient.profiles.Smooth`.
    speed : float
        Sliding speed v [m/s] (paper: 0.02 m/s).
    duration : float
        Simulated time [s].
    fs : float
        Output sample rate [Hz] (default 40 kHz, the paper's rig).
    contact : Contact or {"linear", "nonlinear"}
        Contact law; ``"linear"`` is the paper's (eqs. 2-3). See :class:`Contact`.
    x0, v0 : array_like, shape (n,), optional
        Initial displacements [m] and velocities [m/s]. Default: at rest in the static
        equilibrium of t = 0, ``K(0) x = F(0)``.
    perturbation : float
        Standard deviation [m] of a random displacement added to the initial state (needs
        ``rng``); a flat disc in exact equilibrium never leaves it.
    rng : numpy.random.Generator, optional
        Source of the perturbation.
    x_start : float
        Position on the profile at t = 0 [m].
    dt : float, optional
        Largest step [s]. RK4: its fixed step (rounded down so that ``1/fs`` is a whole number
        of steps; default ``min(0.25 / omega_max, 2.5 / friction rate)``, and an error if it
        exceeds the friction law's stability bound, :func:`step_bound`). Dormand-Prince: the
        largest step the error control may take (cut to the stability bound).
    limit : float
        A run whose displacement exceeds ``limit`` [m] stops with status ``"diverged"``.
    progress : callable, optional
        Called as ``progress(done, total)``.
    method : {"dopri5", "rosenbrock", "rk4"}
        Integrator: Dormand-Prince 5(4) with error control and event location; Rodas4, a
        linearly implicit Rosenbrock 4(3) pair with the analytic Jacobian, error control, its own
        dense output and the same event location, for stiff friction laws (small ``v_reg``: its
        step is not held at the friction law's stability bound; ``dt`` caps it, default
        ``3 / omega_max``); or fixed-step RK4.
    rtol : float
        Relative tolerance of the error control (Dormand-Prince, Rodas4).
    atol : float, optional
        Absolute displacement tolerance [m]; velocities get ``atol * omega_max``. Default
        ``1e-3 rtol`` times the largest initial displacement (at least 1 nm).

    Returns
    -------
    xarray.Dataset
        Over ``time`` [s] (coordinate ``position`` [m]): each DOF's displacement (``x1``,
        ``y1``, ``y2`` for the paper's model), velocity (``x1_dot``...) and acceleration
        (``x1_ddot``...), ``normal_force`` and ``friction_force`` [N], ``q`` [m],
        ``tan_theta``, ``mu_e`` and the frozen-time ``growth_rate`` sigma(t) [1/s] of the
        damped linear model at (mu, tan_theta(t)) (with a Stribeck contact, linearised about
        sliding at ``speed``: see :func:`~squealkit.stability.eigenvalues`). A run starts at rest
        in the static equilibrium of steady sliding (friction ``mu(speed)`` for a Stribeck
        contact) unless ``x0`` is given. Attribute ``status`` is ``"completed"``,
        ``"diverged"`` or ``"failed"`` (the error control could not meet ``rtol`` above the
        smallest step); such a run is cut at its last sample (``t_stop``). Dormand-Prince and Rodas4 runs
        carry ``steps``, ``rejected_steps``, ``rhs_calls``, ``min_step`` and the located events
        (``event_time``, ``event_kind`` over ``event``: contact_opens / contact_closes / stick /
        slip). A linear contact whose normal force pulls has ``tensile_fraction`` > 0 and
        ``min_normal_force`` < 0 and warns (:class:`TensileContactWarning`).

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> from squealkit.transient import SineRunOut, simulate
    >>> ds = simulate(get_preset("lv2013"), mu=0.4, profile=SineRunOut(0.08e-3, 1e-3),
    ...               speed=0.02, duration=0.01, fs=40_000)
    >>> ds.attrs["status"], ds.sizes["time"]
    ('completed', 401)
    """
    validate_model(model)
    runs = _as_runs([model], [mu], [profile], [speed])
    raw = _integrate(
        runs, duration=duration, fs=fs, contact=as_contact(contact), x0=x0, v0=v0, perturbation=perturbation,
        rng=rng, x_start=x_start, dt=dt, limit=limit, progress=progress, method=method, rtol=rtol, atol=atol,
        memory_hint="Stream it to a file block by block: simulate_blocks and io.save_blocks (CLI: --out FILE.nc).",
    )
    n_keep = max(1, int(raw["n_valid"][0]))
    status = _STATUS[int(raw["status"][0])]
    ds = _run_dataset(runs[0], raw, 0, n_keep)
    ds.attrs.update(_attrs(runs[0], raw, status, float(raw["time"][n_keep - 1]), validate_fs(fs)))
    ds = _with_events(ds, raw, 0)
    _warn_tensile(ds)
    return ds


#: Samples per block of :func:`simulate_blocks` by default (about 10 MB for the paper's model).
BLOCK_SAMPLES = 1 << 16


def simulate_blocks(
    model: FrictionModel,
    *,
    mu: float,
    profile: SurfaceProfile | None = None,
    speed: float = 0.02,
    duration: float,
    fs: float = 40_000.0,
    contact: Contact | str = "linear",
    x0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    perturbation: float = 0.0,
    rng: np.random.Generator | None = None,
    x_start: float = 0.0,
    dt: float | None = None,
    limit: float = 1.0,
    progress: Progress | None = None,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
    block_samples: int = BLOCK_SAMPLES,
) -> Iterator[xr.Dataset]:
    """The run of :func:`simulate`, block by block along ``time``: memory bounded for any duration.

    The integrator runs in the same chunks as :func:`simulate` and carries its state from one to
    the next, so the blocks put together (``xarray.concat(blocks, "time")``) equal
    :func:`simulate`'s result bit for bit. Write them with :func:`squealkit.io.save_blocks`.
    The inputs are checked when this is called, before the first block.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu, profile, speed, duration, fs, contact, x0, v0, perturbation, rng, x_start, dt, limit : object
        As for :func:`simulate`.
    progress, method, rtol, atol : object
        As for :func:`simulate`.
    block_samples : int
        Samples per block (the last one holds what is left, at least one sample).

    Yields
    ------
    xarray.Dataset
        The variables of :func:`simulate` over consecutive pieces of ``time``. Only the last
        block carries the attributes (status, steps, ``tensile_fraction`` over the whole
        run...) and the located events (``event_time``, ``event_kind``); the others have none.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> blocks = simulate_blocks(get_preset("lv2013"), mu=0.4, duration=0.01, block_samples=100)
    >>> [b.sizes["time"] for b in blocks]
    [100, 100, 100, 100, 1]
    """
    validate_model(model)
    if isinstance(block_samples, bool) or not isinstance(block_samples, int | np.integer) or block_samples < 1:
        raise InputError(f"Parameter block_samples={block_samples!r} must be an integer >= 1.")
    runs = _as_runs([model], [mu], [profile], [speed])
    setup = _prepare(
        runs, duration=duration, fs=fs, contact=as_contact(contact), x0=x0, v0=v0, perturbation=perturbation,
        rng=rng, x_start=x_start, dt=dt, limit=limit, method=method, rtol=rtol, atol=atol,
    )
    return _stream(runs[0], setup, progress, int(block_samples))


def _stream(run: _Run, setup: dict[str, Any], progress: Progress | None, block: int) -> Iterator[xr.Dataset]:
    fs = setup["fs"]
    pending: list[xr.Dataset] = []
    n_pending = n_kept = n_tensile = 0
    min_force, any_force = math.inf, False

    def take(k: int) -> xr.Dataset:
        nonlocal pending, n_pending
        whole = pending[0] if len(pending) == 1 else xr.concat(pending, "time", combine_attrs="override")
        out, rest = whole.isel(time=slice(0, k)), whole.isel(time=slice(k, None))
        pending, n_pending = ([rest] if rest.sizes["time"] else []), n_pending - k
        return out

    for first, (x, v, a, nc, me) in _chunks(setup, progress):
        valid = min(int(setup["n_valid"][0]), first + x.shape[1]) - first
        if first == 0:
            valid = max(valid, 1)  # as simulate: a run that fails at once keeps its first sample
        if valid <= 0:
            break
        raw = {"time": np.arange(first, first + valid) / fs, "x": x, "v": v, "a": a, "nc": nc, "me": me,
               "x_start": setup["x_start"], "contact": setup["contact"]}
        part = _run_dataset(run, raw, 0, valid)
        part.attrs = {}
        normal = part["normal_force"].values
        if setup["contact"].is_linear and np.isfinite(normal).any():
            any_force = True
            n_tensile += int(np.sum(normal < 0.0))
            min_force = min(min_force, float(np.nanmin(normal)))
        n_kept += valid
        pending.append(part)
        n_pending += valid
        while n_pending > block:  # keep at least one sample back: the last block carries the attributes
            yield take(block)
    last = take(n_pending)
    attrs: dict[str, Any] = {}
    if any_force:
        attrs = {"tensile_fraction": float(n_tensile / n_kept), "min_normal_force": min_force}
    attrs.update(_attrs(run, setup, _STATUS[int(setup["status"][0])], float((n_kept - 1) / fs), fs))
    last.attrs = attrs
    last = _with_events(last, setup, 0)
    _warn_tensile(last)
    yield last


def _with_events(ds: xr.Dataset, raw: dict, i: int) -> xr.Dataset:
    """The run's located events as variables over ``event`` (Dormand-Prince runs)."""
    if "n_ev" not in raw:
        return ds
    k = int(min(raw["n_ev"][i], _MAX_EVENTS))
    ds.attrs["events"] = int(raw["n_ev"][i])
    if k == 0:
        return ds
    codes = sorted(_EVENT_NAMES)
    return ds.assign(
        event_time=("event", raw["ev_t"][i, :k], {"units": "s", "long_name": "time of a located event"}),
        event_kind=("event", raw["ev_k"][i, :k].astype(np.int8),
                    {"long_name": "kind of event", "flag_values": np.array(codes, dtype=np.int8),
                     "flag_meanings": " ".join(_EVENT_NAMES[c] for c in codes)}),
    )


def _warn_tensile(ds: xr.Dataset) -> None:
    frac = ds.attrs.get("tensile_fraction", 0.0)
    if frac > 0:
        warnings.warn(
            f"The normal force of the linear contact was tensile {100 * frac:.1f} % of the time (down to "
            f"{ds.attrs['min_normal_force']:.4g} N): a real contact opens there. Run with contact='nonlinear' "
            "(CLI: --contact nonlinear), which lets the contact open.", TensileContactWarning, stacklevel=3)


def simulate_batch(
    models: FrictionModel | Sequence[FrictionModel],
    *,
    mu: float | ArrayLike,
    profiles: SurfaceProfile | Sequence[SurfaceProfile | None] | None = None,
    speed: float | ArrayLike = 0.02,
    duration: float,
    fs: float = 40_000.0,
    contact: Contact | str = "linear",
    x0: ArrayLike | None = None,
    perturbation: float = 0.0,
    rng: np.random.Generator | None = None,
    x_start: float = 0.0,
    dt: float | None = None,
    limit: float = 1.0,
    progress: Progress | None = None,
    store: str | Path | None = None,
    client: Any = None,
    runs_per_task: int = 16,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
) -> xr.Dataset:
    """Many runs at once, in parallel over runs (numba ``prange``, all cores).

    Each of ``models``, ``mu``, ``profiles`` and ``speed`` is one value for all runs or one
    per run; the runs are their broadcast. All models need the same DOFs. RK4's step ``dt``
    is the smallest any run needs; Dormand-Prince steps each run on its own (``method``,
    ``rtol``, ``atol`` as for :func:`simulate`), so a run's numbers do not depend on the
    batch. Returns the variables of :func:`simulate` with a leading ``run`` dimension and
    per-run ``status`` (``"completed"``/``"diverged"``/``"failed"``), ``mu``, ``speed``,
    ``tensile_fraction`` and ``min_normal_force`` (linear contact), and with Dormand-Prince
    ``steps`` and ``events``; samples after a divergence are NaN.

    With ``store`` (a ``.zarr`` path) the runs are computed ``runs_per_task`` at a time and
    written piece by piece into the store, which is returned opened lazily; with
    ``client`` (a ``distributed.Client``) the pieces run on that Dask cluster. The step
    and the perturbations are fixed for the whole batch up front, so the numbers are
    identical to the in-memory run.

    Parameters
    ----------
    models : FrictionModel or sequence of FrictionModel
        One model for all runs, or one per run (same DOFs).
    mu : float or array_like
        Friction coefficient(s), one or one per run.
    profiles : SurfaceProfile or sequence of SurfaceProfile or None, optional
        Disc surface(s), one or one per run (None: :class:`~squealkit.transient.profiles.Smooth`).
    speed : float or array_like, default 0.02
        Sliding speed(s) [m/s], one or one per run.
    duration : float
        Simulated time [s].
    fs : float, default 40000.0
        Output sample rate [Hz].
    contact : Contact or {"linear", "nonlinear"}, default "linear"
        Contact law, the same for all runs.
    x0 : array_like, shape (n,), optional
        Initial displacements [m] of every run (default: the static equilibrium of each).
    perturbation : float, default 0.0
        Standard deviation [m] of a random initial displacement, drawn per run (needs ``rng``).
    rng : numpy.random.Generator, optional
        Source of the perturbations.
    x_start : float, default 0.0
        Position on the profile at t = 0 [m].
    dt : float, optional
        Step [s] as for :func:`simulate`.
    limit : float, default 1.0
        A run whose displacement exceeds ``limit`` [m] stops with status ``"diverged"``.
    progress : callable, optional
        Called as ``progress(done, total)``.
    store : str or Path, optional
        A ``.zarr`` path to stream the runs into (returned opened lazily).
    client : distributed.Client, optional
        Run the pieces on this Dask cluster (needs ``store``).
    runs_per_task : int, default 16
        Runs per piece written to ``store`` (and per Dask task).
    method : {"dopri5", "rosenbrock", "rk4"}, default "dopri5"
        Integrator (see :func:`simulate`).
    rtol : float, default 1e-8
        Relative tolerance of the error control.
    atol : float, optional
        Absolute displacement tolerance [m] (see :func:`simulate`).

    Returns
    -------
    xarray.Dataset
        The variables of :func:`simulate` with a leading ``run`` dimension, and per run
        ``status``, ``mu``, ``speed`` and the contact and step statistics described above.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = simulate_batch(get_preset("lv2013"), mu=[0.2, 0.4], duration=0.002)
    >>> ds.sizes["run"], ds.status.values.tolist()
    (2, ['completed', 'completed'])
    """
    models_l = list(models) if isinstance(models, Sequence) else [models]
    mus = np.atleast_1d(np.asarray(mu, dtype=float)).tolist()
    profs = list(profiles) if isinstance(profiles, Sequence) else [profiles]
    speeds = np.atleast_1d(np.asarray(speed, dtype=float)).tolist()
    runs = _as_runs(models_l, mus, profs, speeds)
    kw = dict(duration=duration, fs=fs, contact=as_contact(contact), x0=x0, perturbation=perturbation, x_start=x_start,
              dt=dt, limit=limit, method=method, rtol=rtol, atol=atol)
    if store is None and client is not None:
        raise InputError("A cluster run streams its result to zarr: pass store='....zarr' with client.")
    if store is None:
        ds = _batch_dataset(runs, rng=rng, progress=progress, **kw)
        tensile = ds["tensile_fraction"].values
        if np.any(tensile > 0):
            warnings.warn(
                f"The normal force of the linear contact was tensile in {int(np.sum(tensile > 0))} of {tensile.size} "
                f"runs (up to {100 * float(tensile.max()):.1f} % of the time; see tensile_fraction): a real contact "
                "opens there. Run with contact='nonlinear' (CLI: --contact nonlinear).",
                TensileContactWarning, stacklevel=2)
        return ds
    if Path(store).suffix.lower() != ".zarr":
        raise InputError(f"Parameter store={str(store)!r} must be a zarr store ending in .zarr.")
    if isinstance(runs_per_task, bool) or not isinstance(runs_per_task, int) or runs_per_task < 1:
        raise InputError(f"Parameter runs_per_task={runs_per_task!r} must be an integer >= 1.")
    n = runs[0].model.n_dof
    if any(r.model.n_dof != n for r in runs):
        raise InputError("All models of a batch must have the same number of degrees of freedom.")
    # one step and one set of perturbations for the whole batch, whatever the pieces
    if _validate_method(method) == "rk4":  # RK4's step is the batch's; Dormand-Prince steps each run alone
        kw["dt"] = _step_size(runs, validate_fs(fs), dt, kw["contact"], "rk4")[0]
    noise = _perturbation_noise(validate_positive("perturbation", perturbation, allow_zero=True), rng, len(runs), n)
    from ..scale import lazy_template, stream_to_zarr

    R = len(runs)
    sample = _batch_piece((runs[:1], 0, noise[:1], kw))
    pieces = [(_batch_piece, (runs[a:a + runs_per_task], a, noise[a:a + runs_per_task], kw), a,
               min(R, a + runs_per_task)) for a in range(0, R, runs_per_task)]
    template = lazy_template(sample, "run", np.arange(R), runs_per_task)
    return stream_to_zarr(store, template, "run", pieces, client=client, progress=progress,
                          name="squealkit-transient")


def _batch_piece(arg: tuple) -> xr.Dataset:
    """Runs ``first, first + 1, ...`` of a streamed batch (a task)."""
    runs, first, noise, kw = arg
    ds = _batch_dataset(runs, rng=noise, progress=None, **kw)
    return ds.assign_coords(run=np.arange(first, first + len(runs)))


def _batch_dataset(runs: Sequence[_Run], *, duration, fs, contact, x0, perturbation, rng, x_start, dt, limit,
                   progress, method="dopri5", rtol=1e-8, atol=None) -> xr.Dataset:
    raw = _integrate(
        runs, duration=duration, fs=fs, contact=contact, x0=x0, v0=None, perturbation=perturbation,
        rng=rng, x_start=x_start, dt=dt, limit=limit, progress=progress, method=method, rtol=rtol, atol=atol,
        memory_hint="Stream the batch run by run: store='....zarr' (CLI: --out FILE.zarr).",
    )
    n_out = raw["time"].size
    parts = [_run_dataset(run, raw, i, n_out) for i, run in enumerate(runs)]
    tensile = [p.attrs.get("tensile_fraction", 0.0) for p in parts]
    min_force = [p.attrs.get("min_normal_force", math.nan) for p in parts]
    ds = xr.concat(parts, dim="run", coords="different", compat="equals", join="exact", combine_attrs="drop")
    ds = ds.assign_coords(run=np.arange(len(runs)))
    ds["status"] = ("run", np.array([_STATUS[int(s)] for s in raw["status"]]))
    ds["mu"] = ("run", np.array([r.mu for r in runs]), {"units": "1"})
    ds["speed"] = ("run", np.array([r.speed for r in runs]), {"units": "m/s"})
    ds["tensile_fraction"] = ("run", np.array(tensile), {"units": "1", "long_name": "share of time the linear "
                                                          "contact pulled (normal force < 0)"})
    ds["min_normal_force"] = ("run", np.array(min_force), {"units": "N"})
    if "counts" in raw:
        ds["steps"] = ("run", raw["counts"][:, 0].astype(np.int64), {"long_name": "accepted steps"})
        ds["events"] = ("run", raw["n_ev"].astype(np.int64), {"long_name": "located contact and stick/slip events"})
        ds["max_step"] = ("run", raw["h_max"], {"units": "s", "long_name": "largest step (the run's stability bound)"})
    # batch attributes may not depend on which runs a piece holds (streamed batches must equal
    # the in-memory one): the per-run steps and bounds are variables, RK4's dt is fixed up front
    integ = _integrator_attrs(raw, 0)
    for k in ("steps", "rejected_steps", "rhs_calls", "min_step", "atol", "dt", "step_bound_modes",
              "step_bound_friction"):
        integ.pop(k, None)
    if raw["method"] == "rk4":
        integ["dt"] = float(raw["dt"])
    ds.attrs.update(
        {"kind": "simulation_batch", "title": "squealkit transient simulation (batch)", "fs": float(fs), **integ,
         "integrator": integ["integrator"].replace("(numba)", "(numba, parallel over runs)"),
         "contact": raw["contact"].describe()}
    )
    return ds


@renamed_kwargs(freq_lower="highpass_freq")
def response_envelope(ds: xr.Dataset, var: str, *, highpass_freq: float = 1000.0) -> xr.DataArray:
    """Envelope of the vibration of ``var``: high-pass above ``highpass_freq`` [Hz], then ``|Hilbert|``.

    The high-pass (4th-order Butterworth, zero phase) removes the quasi-static response to the
    run-out so that what remains is the self-excited vibration (paper section 5 does the same
    with the rig's displacement).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`simulate` (or :func:`simulate_batch`), with attribute ``fs`` [Hz].
    var : str
        The variable, e.g. ``"x1_ddot"``; time is its last dimension.
    highpass_freq : float, default 1000.0
        High-pass corner [Hz], in ``(0, fs / 2)`` (formerly ``freq_lower``, still accepted
        with a DeprecationWarning).

    Returns
    -------
    xarray.DataArray
        The envelope, the shape, coordinates and units of ``ds[var]``, named ``{var}_envelope``.
    """
    validate_dataset(ds, variables=("time",), attrs=("fs",), what="simulate")
    from scipy.signal import butter, hilbert, sosfiltfilt

    if var not in ds:
        raise InputError(f"Variable {var!r} is not in the dataset; have {sorted(ds.data_vars)}.")
    fs = float(ds.attrs["fs"])
    y = np.asarray(ds[var].values, dtype=float)
    if not 0 < highpass_freq < fs / 2:
        raise InputError(f"Parameter highpass_freq={highpass_freq!r} Hz must lie between 0 and fs/2 = {fs / 2:g} Hz.")
    if y.shape[-1] > 27:
        sos = butter(4, highpass_freq, btype="highpass", fs=fs, output="sos")
        y = sosfiltfilt(sos, y - y[..., :1], axis=-1)
    env = np.abs(hilbert(y, axis=-1))
    out = xr.DataArray(env, dims=ds[var].dims, coords=ds[var].coords, name=f"{var}_envelope")
    out.attrs = {
        "units": ds[var].attrs.get("units", ""),
        "long_name": f"vibration envelope of {var} (> {highpass_freq:g} Hz)",
    }
    return out


def _stages(tan_theta: np.ndarray) -> list[tuple[int, int, str]]:
    """Contiguous index ranges where the run-out rises, falls or is flat."""
    label = np.where(tan_theta > 1e-12, 1, np.where(tan_theta < -1e-12, -1, 0))
    edges = np.flatnonzero(np.diff(label)) + 1
    bounds = np.concatenate([[0], edges, [label.size]])
    names = {1: "rising", -1: "falling", 0: "flat"}
    return [(int(a), int(b), names[int(label[a])]) for a, b in itertools.pairwise(bounds)]


#: Samples of the record the stage rates of :func:`transient_summary` look at (about 26 s at 40 kHz):
#: the envelope is a whole-record filter, so a longer (streamed) record is summarised by its start.
SUMMARY_STAGE_SAMPLES = 1 << 20


@renamed_kwargs(freq_lower="highpass_freq")
def transient_summary(ds: xr.Dataset, *, max_stages: int = 50, highpass_freq: float = 1000.0) -> dict[str, object]:
    """Peak amplitudes, and growth or decay rate of the vibration per run-out stage.

    The growth rate of a stage [1/s] is the least-squares slope of the log of the envelope
    (see :func:`response_envelope`, first DOF's acceleration) over the stage, leaving out the
    first and last 5 ms of the record (filter end effects); it is positive
    where the vibration grows (paper Fig. 4: rising SRO) and negative where it decays.

    The peaks cover the whole record, read piece by piece when ``ds`` is opened lazily (a
    streamed run: ``xarray.open_dataset(path, chunks={})``), so a record of any length is
    summarised in bounded memory; the stages are those of its first
    :data:`SUMMARY_STAGE_SAMPLES` samples (``stages_truncated`` is then true).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`simulate` (or the blocks of :func:`simulate_blocks` as written).
    max_stages : int, default 50
        At most this many stages are listed (``stages_truncated`` says whether more were cut).
    highpass_freq : float, default 1000.0
        High-pass corner [Hz] of the envelope (:func:`response_envelope`; formerly
        ``freq_lower``, still accepted with a DeprecationWarning).

    Returns
    -------
    dict
        JSON-ready: the run's ``status``, ``t_stop``, ``duration`` [s], ``fs`` [Hz], ``mu``,
        ``speed``, ``profile``, ``contact``, step statistics, ``peak`` per DOF (displacement
        change [m], velocity [m/s], acceleration [m/s^2]), ``growth_rate_max`` [1/s] and
        ``stages`` (``stage``, ``t_start``, ``t_end``, ``rate_per_s``, ``sigma_mean_per_s``,
        ``partial``) and ``stages_truncated``.
    """
    validate_dataset(ds, variables=("time",), attrs=("fs",), what="simulate")
    model_dofs = [v[: -len("_ddot")] for v in ds.data_vars if str(v).endswith("_ddot")]
    fs = float(ds.attrs["fs"])
    n_time = ds.sizes["time"]
    out: dict[str, object] = {
        "status": ds.attrs.get("status"),
        "t_stop": ds.attrs.get("t_stop"),
        "duration": float(ds.time[-1]) if n_time else 0.0,
        "fs": fs,
        "mu": ds.attrs.get("mu"),
        "speed": ds.attrs.get("speed"),
        "profile": ds.attrs.get("profile"),
        "contact": ds.attrs.get("contact"),
        "dt": ds.attrs.get("dt"),
        "method": ds.attrs.get("method"),
        "steps": ds.attrs.get("steps"),
        "events": ds.attrs.get("events"),
        "tensile_fraction": ds.attrs.get("tensile_fraction"),
        "min_normal_force": ds.attrs.get("min_normal_force"),
        "peak": {},
    }
    reductions = {"growth_rate_max": ds.growth_rate.max()}
    for d in model_dofs:
        start = float(ds[d].isel(time=0))  # a number, not a lazy piece: dask would hold every chunk for it
        reductions[f"{d}/disp"] = abs(ds[d] - start).max()
        reductions[f"{d}/vel"] = abs(ds[f"{d}_dot"]).max()
        reductions[f"{d}/acc"] = abs(ds[f"{d}_ddot"]).max()
    # one pass over a lazily opened record, a piece at a time (no-op for one in memory)
    red = {k: float(v) for k, v in xr.Dataset(reductions).compute(scheduler="synchronous").data_vars.items()}
    for d in model_dofs:
        out["peak"][d] = {  # type: ignore[index]
            "displacement_change_m": red[f"{d}/disp"],
            "velocity_m_s": red[f"{d}/vel"],
            "acceleration_m_s2": red[f"{d}/acc"],
        }
    out["growth_rate_max"] = red["growth_rate_max"]
    cut = n_time > SUMMARY_STAGE_SAMPLES
    head = ds.isel(time=slice(0, SUMMARY_STAGE_SAMPLES)) if cut else ds
    stages = _stage_rates(head, fs, model_dofs[0], highpass_freq)
    if cut and stages:
        stages = stages[:-1]  # the stage the cut runs through is not whole
    out["stages"] = stages[:max_stages]
    out["stages_truncated"] = len(stages) > max_stages or cut
    return out


def _stage_rates(ds: xr.Dataset, fs: float, dof: str, highpass_freq: float) -> list[dict[str, object]]:
    """Growth or decay rate of the envelope per run-out stage (see :func:`transient_summary`)."""
    time = ds.time.values
    stages: list[dict[str, object]] = []
    if time.size > 32 and fs > 2500.0:
        env = response_envelope(ds, f"{dof}_ddot", highpass_freq=highpass_freq).values
        # The zero-phase filter and the Hilbert transform ring for a few ms at both ends of
        # the record: those samples take no part in the rate fits.
        edge = np.zeros(time.size, dtype=bool)
        n_edge = min(int(0.005 * fs), time.size // 4)
        edge[:n_edge] = edge[time.size - n_edge :] = True
        sigma = ds.growth_rate.values
        for a, b, kind in _stages(ds.tan_theta.values):
            if b - a < 16:
                continue
            seg = env[a:b]
            ok = (seg > 0) & ~edge[a:b]
            rate = float(np.polyfit(time[a:b][ok], np.log(seg[ok]), 1)[0]) if ok.sum() > 8 else math.nan
            stages.append({
                "stage": kind, "t_start": float(time[a]), "t_end": float(time[b - 1]), "rate_per_s": rate,
                "sigma_mean_per_s": float(sigma[a:b].mean()),
                "partial": a == 0 or b == time.size,  # cut by the record: rate less reliable
            })
    return stages
