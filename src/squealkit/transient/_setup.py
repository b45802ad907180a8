"""Everything a transient run needs before its integrator starts: options validated, the step chosen,
the work budget checked, the per-run arrays premultiplied by M^-1 and the initial states (:func:`_prepare`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._threads import thread_limit
from .._validation import InputError, check_budget, validate_finite, validate_fs, validate_positive
from ..solvers.ode.bundles import Model
from ._runs import _Run, _validate_method
from ._step import _check_sampling, _step_size
from .contact import Contact, contact_geometry

#: A lower bound of the time of one integration step of one 3-DOF run [s] (for the work budget).
_SECONDS_PER_STEP = 2e-7


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
    # the speed at which each run's profile passes the forcing's interpolation: 0 where the slope is not dq/dx
    # (ConstantIncline holds tan(theta) apart from q; every other profile's slope is dq/dx)
    vq = np.array([r.speed if r.profile.slope_is_dq_dx else 0.0 for r in runs])
    arrays = Model(bM, fM, C, K0, Kn, Kf, Knx, Kfx, kin, F0, fn, ff, b, fhat, kc, s, mu, v, vq, opts)
    return dict(runs=runs, X=X, V=V, arrays=arrays, n=n, n_out=n_out, n_steps=n_steps, status=status,
                n_valid=n_valid, dt=dt, dt_user=dt_user, stride=stride, x_start=x_start, limit=limit, contact=contact,
                rtol=rtol, atol_user=atol, bounds=bounds, method=method, fs=fs)
