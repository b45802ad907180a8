"""Critical friction, unstable windows, run-out tolerance and sensitivity (paper §3, eqs. 5-6, 11).

The stability boundary is found by root-finding, not grid look-up: every window of
instability along the friction (or slope) axis is located by
:func:`~squealkit.stability._windows.find_windows` (a scan, golden-section search of the
points where modes come close in frequency or a growth rate peaks, then bisection of
every change of verdict to rounding level). A window narrower than the scan spacing is
found through the frequency gap that closes around it. All rows of a batch (thetas,
sides) are searched together, each step one vectorised eigenvalue call.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from .. import __version__
from .._threads import honour_thread_limit
from .._validation import (
    InputError,
    validate_array_finite,
    validate_finite,
    validate_model,
    validate_plausible,
    validate_positive,
)
from ..models import FrictionModel
from ..models._base import resolve_damped
from ..models.friction import Stribeck, validate_friction
from ._solve import IndeterminateWarning
from ._windows import ONSET_STATUS, SCAN_POINTS, Windows, find_windows
from .eigen import _solve_grid

#: Largest friction coefficient of brake friction materials worth calling realistic (dry pads:
#: about 0.3-0.7); onsets beyond it draw an :class:`UnrealisticFrictionWarning`.
REALISTIC_MU_MAX = 1.0


class UnrealisticFrictionWarning(UserWarning):
    """Mode coupling sets in only at a friction coefficient no brake material has."""

    @classmethod
    def for_onset(cls, mu_crit: float, damping: str = "") -> UnrealisticFrictionWarning:
        """The warning for a lowest onset ``mu_crit``; ``damping`` qualifies it (e.g. "with or without the
        model's damping")."""
        return cls(f"Mode coupling needs friction mu_crit = {mu_crit:.4g} or more, beyond brake friction materials "
                   f"(about 0.3-0.7, at most {REALISTIC_MU_MAX:g})" + (f", {damping}" if damping else "")
                   + ": the modes that couple are far apart in frequency (for a pin-on-disc rig compare the pin "
                   "bending and disc frequencies).")


__all__ = [
    "ONSET_STATUS",
    "REALISTIC_MU_MAX",
    "CriticalFriction",
    "RunoutTolerance",
    "UnrealisticFrictionWarning",
    "critical_friction",
    "critical_friction_curve",
    "runout_tolerance",
]

def _evaluator(model: FrictionModel, damped: bool, mu: NDArray | None, t: NDArray | None, fr: dict):
    """Path evaluator for :func:`find_windows`: rows index ``mu`` or ``t``, x is the other."""

    def evaluate(rows: NDArray, x: NDArray, high_precision: bool = True):
        mu_p = x if mu is None else mu[rows]
        t_p = x if t is None else t[rows]
        lam, _err, verdict, thr = _solve_grid(model, mu_p, t_p, damped, high_precision=high_precision, **fr)
        return verdict, lam, thr

    return evaluate


def _onset_frequency(model: FrictionModel, mu: NDArray, t: NDArray, damped: bool, fr: dict) -> NDArray:
    lam = _solve_grid(model, mu, t, damped, **fr)[0]
    idx = np.argmax(lam.real, axis=-1)
    return np.abs(np.take_along_axis(lam.imag, idx[..., None], axis=-1)[..., 0])


def _intervals_array(win: Windows, n_rows: int, unstable: bool) -> NDArray[np.float64]:
    """Windows of each row as an array (n_rows, W, 2) ascending, padded with NaN."""
    per_row = [[(lo, hi) for lo, hi, u in win.of_row(b) if u == unstable] for b in range(n_rows)]
    width = max(1, max((len(r) for r in per_row), default=0))
    out = np.full((n_rows, width, 2), np.nan)
    for b, r in enumerate(per_row):
        if r:
            out[b, : len(r)] = r
    return out


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
        One of :data:`ONSET_STATUS`: ``"onset"``, ``"unstable_at_start"`` (unstable
        without friction), ``"stable_in_range"`` or ``"indeterminate"``.
    damped : bool
        Whether damping was included.
    unstable_intervals : tuple of (float, float)
        Every friction window ``[start, end]`` in ``[0, mu_max]`` where the system is
        unstable (flutter or divergence); a window open at ``mu_max`` ends there.
    indeterminate_intervals : tuple of (float, float)
        Windows where no verdict could be reached within rounding (usually empty).
    mu_max : float
        End of the searched range.
    """

    theta: float
    mu_critical: float
    mu_e_critical: float
    omega_rad_s: float
    frequency_hz: float
    status: str
    damped: bool
    unstable_intervals: tuple[tuple[float, float], ...] = ()
    indeterminate_intervals: tuple[tuple[float, float], ...] = ()
    mu_max: float = 2.0

    @property
    def theta_deg(self) -> float:
        return math.degrees(self.theta)

    def to_dataset(self) -> xr.Dataset:
        """This result as a Dataset over ``theta`` (one point): the variables, units and status
        flags of :func:`critical_friction_curve` and :func:`~squealkit.stability.fe_critical_friction`
        (``mu_critical``, ``mu_e_critical``, ``omega_rad_s``, ``frequency_hz``, ``status``).

        Examples
        --------
        >>> from squealkit.models import Hoffmann2002
        >>> ds = critical_friction(Hoffmann2002()).to_dataset()
        >>> ds.attrs["kind"], [str(s) for s in ds.status.attrs["flag_meanings"].split()][0]
        ('critical_friction', 'onset')
        """

        def windows(w: tuple[tuple[float, float], ...]) -> NDArray[np.float64]:
            return np.array(w, float).reshape(1, len(w), 2) if w else np.full((1, 1, 2), np.nan)

        t = math.tan(self.theta)
        return xr.Dataset(
            {
                "mu_critical": ("theta", [self.mu_critical],
                                {"units": "1", "long_name": "critical friction coefficient"}),
                "mu_e_critical": ("theta", [self.mu_e_critical],
                                  {"units": "1", "long_name": "critical mu + tan(theta) (eq. 6)"}),
                "omega_rad_s": ("theta", [self.omega_rad_s], {"units": "rad/s", "long_name": "frequency at onset"}),
                "frequency_hz": ("theta", [self.frequency_hz], {"units": "Hz", "long_name": "frequency at onset"}),
                "status": onset_status_variable("theta", np.array([ONSET_STATUS.index(self.status)], np.int8)),
                "unstable_intervals": (("theta", "window", "bound"), windows(self.unstable_intervals),
                                       {"units": "1", "long_name": "unstable friction windows [start, end]"}),
                "indeterminate_intervals": (("theta", "indeterminate_window", "bound"),
                                            windows(self.indeterminate_intervals),
                                            {"units": "1", "long_name": "undecided friction windows [start, end]"}),
            },
            coords={"theta": ("theta", [self.theta], {"units": "rad"}),
                    "theta_deg": ("theta", [self.theta_deg], {"units": "deg"}),
                    "tan_theta": ("theta", [t], {"units": "1"}), "bound": ("bound", ["start", "end"])},
            attrs={"kind": "critical_friction", "damped": int(self.damped), "mu_max": self.mu_max,
                   "squealkit_version": __version__},
        )

    def to_dict(self) -> dict[str, object]:
        d = dataclasses.asdict(self)
        d["theta_deg"] = self.theta_deg
        d["unstable_intervals"] = [list(w) for w in self.unstable_intervals]
        d["indeterminate_intervals"] = [list(w) for w in self.indeterminate_intervals]
        return d


@honour_thread_limit
def critical_friction_curve(
    model: FrictionModel,
    theta: ArrayLike,
    *,
    damped: bool | None = None,
    mu_max: float = 2.0,
    scan: int = SCAN_POINTS,
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> xr.Dataset:
    """Critical friction mu_crit(theta), mu_e_crit = mu_crit + tan(theta), and every unstable window.

    Along ``mu`` from 0 to ``mu_max`` every window of instability is found (down to
    windows much narrower than the scan spacing, through the closing frequency gap that
    announces them). mu_crit is the start of the first. If the system is already unstable
    at mu = 0 the search also goes down to ``-mu_max`` for the first stable point (a
    negative mu_crit).

    Parameters
    ----------
    model : FrictionModel
    theta : array_like
        Run-out inclines [rad], each strictly inside (-90, 90) deg.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.
    mu_max : float
        Search range for ``|mu|``.
    scan : int
        Points of the initial scan.
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
        ``frequency_hz``, ``status`` (codes of :data:`ONSET_STATUS`) and
        ``unstable_intervals`` / ``indeterminate_intervals`` (theta, window, bound:
        start and end, NaN-padded).

    Warns
    -----
    IndeterminateWarning
        When some window could not be decided within rounding.
    UnrealisticFrictionWarning
        When every onset found needs ``mu > REALISTIC_MU_MAX`` (1): squeal by mode coupling
        would need friction no brake material has.
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    friction, speed = validate_friction(model, friction, speed)
    fr = {} if friction is None else {"friction": friction, "speed": speed}
    th = np.atleast_1d(validate_array_finite("theta", theta)).astype(float)
    if th.ndim != 1:
        raise InputError("theta must be a number or a 1-D array.")
    if np.any(np.abs(th) >= math.pi / 2):
        raise InputError("Parameter theta must lie strictly between -90 and 90 deg.")
    mu_max = validate_plausible("mu_max", validate_positive("mu_max", mu_max), "friction")
    t = np.tan(th)
    B = t.size
    evaluate = _evaluator(model, damped, None, t, fr)
    up = find_windows(evaluate, np.zeros(B), np.full(B, mu_max), scan=scan)
    near, far, first_unstable = up.first(B)
    s0 = up.start_unstable
    mu_c = np.where(np.isfinite(near) & ~s0, near, np.nan)
    status = np.where(np.isfinite(mu_c), np.where(first_unstable, 0, 3), 2).astype(np.int8)
    status[s0] = 1
    if s0.any():
        # unstable at mu = 0: the first stable point going down is the (negative) mu_crit
        rows = np.flatnonzero(s0)
        dn = find_windows(_evaluator(model, damped, None, t[rows], fr), np.zeros(rows.size),
                          np.full(rows.size, -mu_max), scan=scan)
        _near, dn_far, _ = dn.first(rows.size)
        reached = np.isfinite(dn_far) & (dn_far > -mu_max)
        mu_c[rows] = np.where(reached, dn_far, np.nan)
    omega = np.full(B, np.nan)
    inside = status == 0
    if inside.any():
        # just inside the window, where the onset mode's growth stands out from rounding
        step = np.minimum(1e-6 * np.maximum(1.0, np.abs(mu_c)), 0.5 * (far - near))
        omega[inside] = _onset_frequency(model, (mu_c + step)[inside], t[inside], damped, fr)
    back = np.flatnonzero(status == 1)
    if back.size and np.isfinite(mu_c[back]).any():
        ok = back[np.isfinite(mu_c[back])]
        omega[ok] = _onset_frequency(model, mu_c[ok] + 1e-6 * np.maximum(1.0, np.abs(mu_c[ok])), t[ok], damped, fr)
    onsets = mu_c[status == 0]
    if onsets.size and onsets.min() > REALISTIC_MU_MAX:
        warnings.warn(UnrealisticFrictionWarning.for_onset(float(onsets.min())), stacklevel=2)
    uns = _intervals_array(up, B, True)
    ind = _intervals_array(up, B, False)
    if np.isfinite(ind).any():
        warnings.warn(
            "Some friction windows could not be decided within rounding of the model's numbers "
            "(see indeterminate_intervals).", IndeterminateWarning, stacklevel=2)
    ds = xr.Dataset(
        {
            "mu_critical": ("theta", mu_c, {"units": "1", "long_name": "critical friction coefficient"}),
            "mu_e_critical": ("theta", (mu_c if friction is None else friction.mu(mu_c, speed)) + t,
                              {"units": "1", "long_name": "critical mu + tan(theta) (eq. 6)"}),
            "omega_rad_s": ("theta", omega, {"units": "rad/s", "long_name": "frequency at onset"}),
            "frequency_hz": ("theta", omega / (2 * math.pi), {"units": "Hz", "long_name": "frequency at onset"}),
            "status": onset_status_variable("theta", status),
            "unstable_intervals": (("theta", "window", "bound"), uns,
                                   {"units": "1", "long_name": "unstable friction windows [start, end]"}),
            "indeterminate_intervals": (("theta", "indeterminate_window", "bound"), ind,
                                        {"units": "1", "long_name": "undecided friction windows [start, end]"}),
        },
        coords={
            "theta": ("theta", th, {"units": "rad"}),
            "theta_deg": ("theta", np.degrees(th), {"units": "deg"}),
            "tan_theta": ("theta", t, {"units": "1"}),
            "bound": ("bound", ["start", "end"]),
        },
        attrs={"kind": "critical_friction", "model": model.to_json(), "damped": int(damped), "mu_max": mu_max,
               "squealkit_version": __version__},
    )
    if friction is not None:
        ds.attrs.update(friction=friction.describe(), mu_static=friction.mu_static, v_stribeck=friction.v_stribeck,
                        speed=speed, speed_units="m/s")
    return ds


def onset_status_variable(dim: str, codes: ArrayLike) -> tuple[str, NDArray[np.int8], dict[str, str]]:
    """The ``status`` variable of an onset search along ``dim``: indices into :data:`ONSET_STATUS`,
    named by CF ``flag_values``/``flag_meanings`` (one encoding for every critical-friction result)."""
    flags = {"flag_values": " ".join(str(i) for i in range(len(ONSET_STATUS))), "flag_meanings": " ".join(ONSET_STATUS)}
    return dim, np.asarray(codes, np.int8), flags


def _pairs(a: NDArray) -> tuple[tuple[float, float], ...]:
    return tuple((float(lo), float(hi)) for lo, hi in a if np.isfinite(lo))


@honour_thread_limit
def critical_friction(
    model: FrictionModel,
    theta: float = 0.0,
    *,
    damped: bool | None = None,
    mu_max: float = 2.0,
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> CriticalFriction:
    """Critical friction and every unstable friction window at one run-out incline ``theta`` [rad].

    See :func:`critical_friction_curve` (paper §3, eq. 6); ``friction`` and ``speed`` as there.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    theta : float
        Run-out incline [rad], strictly inside (-90, 90) deg; ``tan(theta)`` enters the model.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.
    mu_max : float
        Upper end of the friction search range ``[0, mu_max]`` (> 0); when the system is
        unstable already at mu = 0 the search also goes down to ``-mu_max``.
    friction : Stribeck, optional
        Speed-dependent friction; ``mu_critical`` is then the kinetic coefficient and
        ``mu_e_critical`` uses the coefficient at ``speed``.
    speed : float, optional
        Sliding speed V [m/s], > 0; needed with ``friction`` (and only with it).

    Returns
    -------
    CriticalFriction
        The critical friction, its frequency and onset status, and every unstable and
        indeterminate friction window in the searched range.

    Examples
    --------
    Hoffmann's model has a closed-form threshold to compare with:

    >>> from squealkit.models import Hoffmann2002
    >>> m = Hoffmann2002()
    >>> c = critical_friction(m)
    >>> abs(c.mu_critical - m.mu_critical_closed_form()) < 1e-9, len(c.unstable_intervals)
    (True, 1)
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    theta = validate_finite("theta", theta)
    ds = critical_friction_curve(model, [theta], damped=damped, mu_max=mu_max, friction=friction, speed=speed)
    r = ds.isel(theta=0)
    return CriticalFriction(
        theta=theta,
        mu_critical=float(r.mu_critical),
        mu_e_critical=float(r.mu_e_critical),
        omega_rad_s=float(r.omega_rad_s),
        frequency_hz=float(r.frequency_hz),
        status=ONSET_STATUS[int(r.status)],
        damped=damped,
        unstable_intervals=_pairs(r.unstable_intervals.values),
        indeterminate_intervals=_pairs(r.indeterminate_intervals.values),
        mu_max=mu_max,
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
        Whether the brake is stable at ``mu`` without run-out.
    damped : bool
        Whether damping was included.
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


@honour_thread_limit
def runout_tolerance(
    model: FrictionModel,
    mu: float,
    *,
    wavelength: float | None = None,
    damped: bool | None = None,
    slope_max: float = math.tan(math.radians(80.0)),
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> RunoutTolerance:
    """Run-out tolerance at friction ``mu``: the largest stable slope and amplitude (eq. 11).

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : float
        Friction coefficient.
    wavelength : float, optional
        Run-out wavelength [m]; with it the amplitude tolerance ``q0_max`` [m] is given.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.
    slope_max : float, default tan(80 deg)
        Largest slope ``tan(theta)`` [1] searched, on each side.
    friction, speed : Stribeck and float, optional
        Speed-dependent friction (``mu`` its kinetic coefficient) and the sliding speed [m/s];
        see :func:`~squealkit.stability.eigenvalues`.

    Returns
    -------
    RunoutTolerance
        The largest stable slope on both sides, the side that limits it and, with
        ``wavelength``, the amplitude ``q0_max`` [m].

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> tol = runout_tolerance(get_preset("lv2013"), 0.2, wavelength=1e-3)
    >>> tol.limiting_side, tol.q0_max > 0
    ('rising', True)
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    mu = validate_finite("mu", mu)
    slope_max = validate_positive("slope_max", slope_max)
    if wavelength is not None:
        wavelength = validate_positive("wavelength", wavelength)
    friction, speed = validate_friction(model, friction, speed)
    fr = {} if friction is None else {"friction": friction, "speed": speed}
    evaluate = _evaluator(model, damped, np.array([mu, mu]), None, fr)
    win = find_windows(evaluate, np.zeros(2), np.array([slope_max, -slope_max]))
    if win.start_unstable[0]:
        return RunoutTolerance(mu, 0.0, 0.0, "flat", wavelength, 0.0 if wavelength else None, False, damped)
    near, _far, _ = win.first(2)
    sides = {name: abs(float(near[i])) if np.isfinite(near[i]) else math.inf
             for i, name in enumerate(("rising", "falling"))}
    side = min(sides, key=lambda k: sides[k])
    s = sides[side]
    q0 = None if wavelength is None else s * wavelength / (2 * math.pi)
    return RunoutTolerance(mu, s, math.degrees(math.atan(s)), side, wavelength, q0, True, damped)
