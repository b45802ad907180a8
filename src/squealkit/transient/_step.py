"""The step bound of the transient integrators, and the output rate's check against the fastest mode.

Two limits cap a step: the fastest mode omega_max of the damped linear model (RK4 takes
``0.25 / omega_max`` for accuracy, Dormand-Prince at most ``3 / omega_max``), and the friction
law's own stiffness: regularised friction ``mu N tanh(w / v_reg)`` acts like a damper
``mu N / v_reg`` on the sliding direction (a Stribeck law adds ``(mu_static - mu) N / v_stribeck``),
whose explicit stability limit ``~2.5 / (c fhat.M^-1.fhat)`` can be far below the modes'
(:func:`step_bound`). Rodas4 (``method="rosenbrock"``) is L-stable: only the modes' bound caps it.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from .._validation import InputError, validate_finite, validate_model, validate_plausible, validate_positive
from ..models import FrictionModel
from ..stability.eigen import eigenvalues
from ._runs import _Run, _validate_method, _validate_model
from .contact import Contact, as_contact, contact_geometry
from .profiles import Smooth

#: RK4 step as a fraction of the period of the fastest mode: dt <= STEP_FACTOR / omega_max.
STEP_FACTOR = 0.25
#: Explicit stability of a damper c on a mass m: h <= STABILITY_FACTOR m / c (RK4's real-axis
#: limit is 2.79, Dormand-Prince 5's 3.3; kept below both).
STABILITY_FACTOR = 2.5
#: Largest Dormand-Prince step as a multiple of 1 / omega_max (its stability limit ~3.3 on the
#: imaginary axis is never reached by the error control at useful tolerances).
DOPRI_OMEGA_FACTOR = 3.0


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
