"""Critical friction, run-out tolerance and parameter sensitivity (paper §3, eqs. 5-6, 11).

The stability boundary is found by root-finding, not grid look-up: a fine scan brackets
the first change of stability from a known side, then bisection on the stability
indicator (``sigma_max > 1e-9 |lambda|``) narrows the bracket to rounding level. All
brackets of a batch are bisected together, each step one vectorised eigenvalue call.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from .. import __version__
from .._validation import InputError, validate_array_finite, validate_finite, validate_positive
from ..models import FrictionModel
from ..models.friction import Stribeck, validate_friction
from .eigen import eigenvalues, unstable_threshold

__all__ = [
    "CriticalFriction",
    "RunoutTolerance",
    "critical_friction",
    "critical_friction_curve",
    "critical_friction_sensitivity",
    "runout_tolerance",
]

_BISECT_STEPS = 64
_SCAN_POINTS = 401


def _unstable(model: FrictionModel, mu: NDArray, t: NDArray, damped: bool, **fr) -> NDArray[np.bool_]:
    lam = eigenvalues(model, mu, t, damped=damped, **fr)
    return np.any(lam.real > unstable_threshold(lam)[..., None], axis=-1)


def _onset_frequency(model: FrictionModel, mu: NDArray, t: NDArray, damped: bool, **fr) -> NDArray:
    lam = eigenvalues(model, mu, t, damped=damped, **fr)
    idx = np.argmax(lam.real, axis=-1)
    return np.abs(np.take_along_axis(lam.imag, idx[..., None], axis=-1)[..., 0])


def _first_change(
    unstable_at: Callable[[NDArray], NDArray[np.bool_]],
    start: NDArray,
    stop: float,
    scan: int,
) -> tuple[NDArray, NDArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Bracket and bisect the first change of stability going from ``start`` to ``stop``.

    ``unstable_at(x)`` takes an array shaped like ``start`` (one value per batch entry).
    Returns ``(x_from_side, x_other_side, found, state_at_start)``; where nothing changes
    before ``stop``, ``found`` is False and both sides are NaN.
    """
    start = np.asarray(start, dtype=float)
    s0 = unstable_at(start)
    grid = start[None, ...] + (stop - start)[None, ...] * np.linspace(0.0, 1.0, scan).reshape(
        (scan,) + (1,) * start.ndim
    )
    states = np.stack([unstable_at(grid[i]) for i in range(scan)])
    changed = states != s0[None, ...]
    found = changed.any(axis=0)
    j = np.where(found, changed.argmax(axis=0), 1)
    take = np.indices(start.shape)
    a = grid[(j - 1, *take)]
    b = grid[(j, *take)]
    for _ in range(_BISECT_STEPS):
        mid = 0.5 * (a + b)
        same = unstable_at(mid) == s0
        a = np.where(same, mid, a)
        b = np.where(same, b, mid)
        if np.all(np.abs(b - a) <= 4 * np.finfo(float).eps * np.maximum(1.0, np.abs(a))):
            break
    a = np.where(found, a, np.nan)
    b = np.where(found, b, np.nan)
    return a, b, found, s0


@dataclass(frozen=True)
class CriticalFriction:
    """Friction at which the system first loses stability, at one run-out incline.

    Attributes
    ----------
    theta : float
        Run-out incline [rad].
    mu_critical : float
        Critical friction coefficient; negative when the system is unstable even without
        friction (the slope alone destabilises it); NaN when no onset is found.
    mu_e_critical : float
        Critical equivalent friction ``mu_critical + tan(theta)`` (eq. 6).
    omega_rad_s, frequency_hz : float
        Frequency of the mode that loses stability, at onset.
    status : str
        ``"onset"``, ``"unstable_without_friction"`` or ``"stable_in_range"``.
    damped : bool
        Whether damping was included.
    """

    theta: float
    mu_critical: float
    mu_e_critical: float
    omega_rad_s: float
    frequency_hz: float
    status: str
    damped: bool

    @property
    def theta_deg(self) -> float:
        return math.degrees(self.theta)

    def to_dict(self) -> dict[str, object]:
        d = dataclasses.asdict(self)
        d["theta_deg"] = self.theta_deg
        return d


def critical_friction_curve(
    model: FrictionModel,
    theta: ArrayLike,
    *,
    damped: bool = False,
    mu_max: float = 2.0,
    scan: int = _SCAN_POINTS,
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> xr.Dataset:
    """Critical friction mu_crit(theta) and mu_e_crit = mu_crit + tan(theta) over theta.

    Starting from mu = 0 the search goes up to ``mu_max`` for the first loss of stability;
    if the system is already unstable at mu = 0 it goes down to ``-mu_max`` for the first
    stable point instead (a negative mu_crit).

    Parameters
    ----------
    model : FrictionModel
    theta : array_like
        Run-out inclines [rad], each strictly inside (-90, 90) deg.
    damped : bool
        Include damping.
    mu_max : float
        Search range for |mu|.
    scan : int
        Points of the bracketing scan (a narrower unstable window could be missed).
    friction : Stribeck, optional
        Speed-dependent friction; ``mu_critical`` is then the kinetic coefficient and
        ``mu_e_critical`` uses the coefficient at ``speed`` (see
        :func:`~squealkit.stability.eigenvalues`).
    speed : float, optional
        Sliding speed V [m/s]; needed with ``friction``.

    Returns
    -------
    xarray.Dataset
        Over ``theta``: ``mu_critical``, ``mu_e_critical``, ``omega_rad_s``,
        ``frequency_hz`` and ``status`` (0 onset, 1 unstable without friction,
        2 stable in range).
    """
    friction, speed = validate_friction(model, friction, speed)
    fr = {} if friction is None else {"friction": friction, "speed": speed}
    th = np.atleast_1d(validate_array_finite("theta", theta)).astype(float)
    if th.ndim != 1:
        raise InputError("theta must be a number or a 1-D array.")
    if np.any(np.abs(th) >= math.pi / 2):
        raise InputError("Parameter theta must lie strictly between -90 and 90 deg.")
    mu_max = validate_positive("mu_max", mu_max)
    t = np.tan(th)

    def unstable_at(mu: NDArray) -> NDArray[np.bool_]:
        return _unstable(model, mu, t, damped, **fr)

    s0 = unstable_at(np.zeros_like(t))
    # stable at mu = 0: search upwards; unstable: search downwards for the boundary
    up_a, _up_b, up_found, _ = _first_change(unstable_at, np.zeros_like(t), mu_max, scan)
    _dn_a, dn_b, dn_found, _ = _first_change(unstable_at, np.zeros_like(t), -mu_max, scan)
    # the boundary value: the stable side's end of the bracket (rounding-level bracket)
    mu_c = np.where(s0, dn_b, up_a)
    found = np.where(s0, dn_found, up_found)
    status = np.where(s0, 1, np.where(found, 0, 2))
    mu_c = np.where(found, mu_c, np.nan)
    omega = np.full_like(t, np.nan)
    if found.any():
        # On the rounding-level bracket every growth rate is noise-sized; a step of 1e-6
        # into the unstable side (always towards larger mu) makes the onset mode stand out.
        step = 1e-6 * np.maximum(1.0, np.abs(mu_c[found]))
        omega[found] = _onset_frequency(model, mu_c[found] + step, t[found], damped, **fr)
    ds = xr.Dataset(
        {
            "mu_critical": ("theta", mu_c, {"units": "1", "long_name": "critical friction coefficient"}),
            "mu_e_critical": ("theta", (mu_c if friction is None else friction.mu(mu_c, speed)) + t,
                              {"units": "1", "long_name": "critical mu + tan(theta) (eq. 6)"}),
            "omega_rad_s": ("theta", omega, {"units": "rad/s", "long_name": "frequency at onset"}),
            "frequency_hz": ("theta", omega / (2 * math.pi), {"units": "Hz", "long_name": "frequency at onset"}),
            "status": ("theta", status.astype(np.int8),
                       {"flag_values": "0 1 2", "flag_meanings": "onset unstable_without_friction stable_in_range"}),
        },
        coords={
            "theta": ("theta", th, {"units": "rad"}),
            "theta_deg": ("theta", np.degrees(th), {"units": "deg"}),
            "tan_theta": ("theta", t, {"units": "1"}),
        },
        attrs={"model": model.to_json(), "damped": int(damped), "mu_max": mu_max,
               "squealkit_version": __version__},
    )
    if friction is not None:
        ds.attrs.update(friction=friction.describe(), mu_static=friction.mu_static, v_stribeck=friction.v_stribeck,
                        speed=speed, speed_units="m/s")
    return ds


_STATUS = {0: "onset", 1: "unstable_without_friction", 2: "stable_in_range"}


def critical_friction(
    model: FrictionModel,
    theta: float = 0.0,
    *,
    damped: bool = False,
    mu_max: float = 2.0,
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> CriticalFriction:
    """Critical friction at one run-out incline ``theta`` [rad] (paper §3, eq. 6).

    ``friction`` and ``speed`` as for :func:`critical_friction_curve`.

    Examples
    --------
    Hoffmann's model has a closed-form threshold to compare with:

    >>> from squealkit.models import Hoffmann2002
    >>> m = Hoffmann2002()
    >>> abs(critical_friction(m).mu_critical - m.mu_critical_closed_form()) < 1e-9
    True
    """
    theta = validate_finite("theta", theta)
    ds = critical_friction_curve(model, [theta], damped=damped, mu_max=mu_max, friction=friction, speed=speed)
    r = ds.isel(theta=0)
    return CriticalFriction(
        theta=theta,
        mu_critical=float(r.mu_critical),
        mu_e_critical=float(r.mu_e_critical),
        omega_rad_s=float(r.omega_rad_s),
        frequency_hz=float(r.frequency_hz),
        status=_STATUS[int(r.status)],
        damped=damped,
    )


@dataclass(frozen=True)
class RunoutTolerance:
    """The largest disc run-out that keeps the brake stable at friction ``mu``.

    A sine run-out ``q = q0 sin(2 pi x / lambda)`` has slopes up to
    ``tan(theta) = 2 pi q0 / lambda`` on its rising and falling stages alike (eq. 11), so
    the tolerance is set by the smaller of the stable slopes on both sides.

    Attributes
    ----------
    mu : float
        Friction coefficient.
    tan_theta_max : float
        Largest slope s such that every slope in [-s, s] is stable (0 if unstable on a flat
        disc; inf if stable over the whole search range).
    theta_max_deg : float
        The same as an incline angle [deg].
    limiting_side : str
        ``"rising"`` or ``"falling"`` run-out sets the limit (``"flat"`` when unstable flat).
    wavelength : float or None
        Run-out wavelength lambda [m], if given.
    q0_max : float or None
        Largest run-out amplitude [m] at that wavelength, ``s lambda / (2 pi)`` (eq. 11).
    stable_on_flat_disc : bool
    damped : bool
    """

    mu: float
    tan_theta_max: float
    theta_max_deg: float
    limiting_side: str
    wavelength: float | None
    q0_max: float | None
    stable_on_flat_disc: bool
    damped: bool

    def to_dict(self) -> dict[str, object]:
        return dataclasses.asdict(self)


def runout_tolerance(
    model: FrictionModel,
    mu: float,
    *,
    wavelength: float | None = None,
    damped: bool = False,
    slope_max: float = math.tan(math.radians(80.0)),
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> RunoutTolerance:
    """Run-out tolerance at friction ``mu``: the largest stable slope and amplitude (eq. 11).

    Parameters
    ----------
    model : FrictionModel
    mu : float
        Friction coefficient.
    wavelength : float, optional
        Run-out wavelength [m]; with it the amplitude tolerance ``q0_max`` [m] is given.
    damped : bool
        Include damping.
    slope_max : float
        Largest slope searched.
    friction, speed : Stribeck and float, optional
        Speed-dependent friction (``mu`` its kinetic coefficient) and the sliding speed [m/s];
        see :func:`~squealkit.stability.eigenvalues`.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> tol = runout_tolerance(get_preset("lv2013"), 0.2, wavelength=1e-3)
    >>> tol.limiting_side, tol.q0_max > 0
    ('rising', True)
    """
    mu = validate_finite("mu", mu)
    slope_max = validate_positive("slope_max", slope_max)
    friction, speed = validate_friction(model, friction, speed)
    fr = {} if friction is None else {"friction": friction, "speed": speed}
    if wavelength is not None:
        wavelength = validate_positive("wavelength", wavelength)
    mu_arr = np.array([mu])

    def unstable_at(t: NDArray) -> NDArray[np.bool_]:
        return _unstable(model, mu_arr, t, damped, **fr)

    flat_unstable = bool(unstable_at(np.zeros(1))[0])
    if flat_unstable:
        return RunoutTolerance(mu, 0.0, 0.0, "flat", wavelength, 0.0 if wavelength else None, False, damped)
    sides = {}
    for name, stop in (("rising", slope_max), ("falling", -slope_max)):
        a, _, found, _ = _first_change(unstable_at, np.zeros(1), stop, _SCAN_POINTS)
        sides[name] = abs(float(a[0])) if found[0] else math.inf
    side = min(sides, key=lambda k: sides[k])
    s = sides[side]
    q0 = None if wavelength is None else s * wavelength / (2 * math.pi)
    return RunoutTolerance(mu, s, math.degrees(math.atan(s)), side, wavelength, q0, True, damped)


def critical_friction_sensitivity(
    model: FrictionModel,
    theta: float = 0.0,
    *,
    damped: bool = False,
    parameters: Sequence[str] | None = None,
    rel_step: float = 1e-4,
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> list[dict[str, object]]:
    """Sensitivity of the critical friction to each model parameter.

    Central differences with a relative step. The elasticity
    ``(p / mu_crit) d mu_crit / d p`` is the percent change of mu_crit per percent
    change of p: the parameter with the largest positive elasticity buys the most margin
    when raised. Rows are sorted by ``|elasticity|``.

    ``friction`` and ``speed`` as for :func:`critical_friction_curve`.

    Returns
    -------
    list of dict
        ``parameter``, ``value``, ``unit``, ``dmu_dp`` (per unit of p) and ``elasticity``.
    """
    fr = {"friction": friction, "speed": speed}
    base = critical_friction(model, theta, damped=damped, **fr)
    if base.status != "onset" or not math.isfinite(base.mu_critical):
        raise InputError("The model has no friction onset at this theta; sensitivity is undefined.")
    info = model.parameter_info()
    names = list(parameters) if parameters is not None else [
        k for k, v in info.items()
        if v["kind"] in ("positive", "nonnegative", "angle", "finite")
        and (damped or not v["unit"].startswith("N s/m"))
    ]
    rows = []
    for name in names:
        if name not in info:
            raise InputError(f"Unknown parameter {name!r} for model {model.kind!r}.")
        value = float(getattr(model, name))
        h = rel_step * abs(value) if value != 0 else rel_step
        try:
            up = critical_friction(model.replace(**{name: value + h}), theta, damped=damped, **fr)
            dn = critical_friction(model.replace(**{name: value - h}), theta, damped=damped, **fr)
        except InputError:
            continue  # a step outside the allowed range (e.g. a zero damping)
        d = (up.mu_critical - dn.mu_critical) / (2 * h)
        rows.append({
            "parameter": name,
            "value": value,
            "unit": info[name]["unit"],
            "dmu_dp": d,
            "elasticity": d * value / base.mu_critical,
        })
    rows.sort(key=lambda r: -abs(float(r["elasticity"])))  # type: ignore[arg-type]
    return rows
