"""Branches of squeal limit cycles of a squealkit model, over friction or run-out slope: the Hopf
point of the model's nonlinear contact, the continuation of harmonic balance from it
(:mod:`squealkit.nonlinear.arclength`: pseudo-arclength, the corners of an opening contact, each
cycle's Floquet stability), and the labelled result with its checks (harmonics, onset kind).

The algorithm's names are importable from here too (``Branch``, ``continue_branch``,
``floquet_multipliers``), as before it had a module of its own.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from .. import __version__
from .._validation import InputError, validate_dataset, validate_finite, validate_int, validate_model, validate_positive
from .arclength import (  # noqa: F401  (the algorithm's names, importable from here as before the split)
    CONTACT_SAMPLES,
    FLOQUET_TOL,
    STABILITY_METHODS,
    Branch,
    _sample,
    continue_branch,
    floquet_multipliers,
    floquet_steps,
)
from .harmonic_balance import (
    SecondOrderSystem,
    contact_system,
    n_time_samples,
)
from .hopf import HopfPoint, hopf_point

__all__ = [
    "Branch",
    "continue_branch",
    "floquet_multipliers",
    "limit_cycle_branch",
    "limit_cycle_branch_slope",
    "limit_cycle_summary",
]


def _onset_kind(hopf: HopfPoint, branch_p: NDArray, stable: NDArray) -> tuple[str, str]:
    """Sub/supercritical from l1, or (degenerate l1: a non-smooth onset) from the branch."""
    if hopf.kind != "degenerate":
        return hopf.kind, "lyapunov_coefficient"
    # the branch leaves the Hopf point towards larger p with stable cycles: soft onset
    d = branch_p - hopf.p
    far = np.flatnonzero(np.abs(d) > 1e-6 * max(1.0, abs(hopf.p)))
    if far.size == 0:
        return "degenerate", "branch"
    k = far[0]
    return ("supercritical" if d[k] > 0 and stable[k] else "subcritical"), "branch"


def limit_cycle_branch(
    model,
    mu: tuple[float, float] | NDArray,
    *,
    theta: float = 0.0,
    contact=None,
    speed: float = 0.02,
    harmonics: int = 10,
    n_points: int = 50,
    max_points: int | None = None,
    n_floquet: int | None = None,
    check_harmonics: bool = True,
    stability: str = "monodromy",
    harmonics_tol: float | None = None,
    onset=None,
) -> xr.Dataset:
    """Squeal limit cycles of a squealkit model over friction, from the Hopf point (harmonic balance).

    The Hopf point is the critical friction of the damped model (the transient's nonlinear
    contact linearised about steady sliding; :func:`squealkit.stability.critical_friction`)
    refined on the nonlinear system; the branch is continued in ``mu`` by pseudo-arclength
    within ``[mu_start, mu_stop]``.

    Parameters
    ----------
    model : FrictionModel
        E.g. ``get_preset("lv2013")``; it needs one point contact.
    mu : (float, float) or array
        Friction range ``(start, stop)`` (an array: its min and max).
    theta : float
        Run-out incline [rad] (frozen slope tan(theta), mean surface q = 0).
    contact : Contact or str, optional
        Contact law (default ``Contact.nonlinear()``).
    speed : float
        Sliding speed [m/s].
    harmonics : int
        Harmonics H per cycle.
    n_points : int
        Nominal number of points over the range (sets the arclength step).
    max_points : int, optional
        Largest number of points (default ``10 n_points``).
    n_floquet : int, optional
        RK4 steps of the monodromy matrix per period (default: from the variational system's
        fastest rate, :func:`floquet_steps`).
    check_harmonics : bool
        Re-solve every 5th point with 2H harmonics; the largest relative amplitude change
        is the attribute ``harmonics_change``.
    stability : {"monodromy", "hill"}
        Floquet multipliers by the monodromy matrix or by Hill's method (attribute
        ``stability_method``).
    harmonics_tol : float, optional
        Adapt the number of harmonics: ``harmonics`` is doubled (up to :data:`MAX_HARMONICS`)
        until the amplitude changes by at most this much (relative) at 2H; attributes
        ``harmonics_tol`` and ``harmonics_converged`` (with a warning when it is not).
        None (default): H stays ``harmonics`` and the change is only reported.
    onset : CriticalFriction, optional
        ``critical_friction(model, theta, damped=True)`` when the caller has it already (a report
        computes it once for every section): used instead of computing it again. Only an onset
        (status ``"onset"``) of the damped model at this ``theta`` is taken, and only for a contact
        without static friction (whose onset needs the friction law); otherwise it is computed.

    Returns
    -------
    xarray.Dataset
        Over ``point`` (and ``dof``): ``mu``, ``frequency_hz``, ``omega_rad_s``,
        ``amplitude`` [m] (half peak-to-peak over one period), ``mean`` [m],
        ``contact_loss_fraction``, ``stable``, ``floquet_max`` (largest non-trivial
        multiplier modulus), ``fold``; over ``fold``: ``fold_mu`` (mu of each fold); attrs: ``hopf_mu``,
        ``hopf_frequency_hz``, ``lyapunov_coefficient``, ``hopf_kind``, ``hopf_kind_from``,
        ``hysteresis_mu`` (the range of mu where a quiet and a squealing state coexist,
        NaN if none), ``harmonics``, ``harmonics_change``, ``stop_reason`` (``"left_range"``: the
        branch reached the end of the range), ``stop_detail`` (where and why it stopped, one
        sentence), units.
    """
    validate_model(model, kind="friction")
    harmonics = validate_int("harmonics", harmonics, 1)
    from ..stability import critical_friction
    from ..transient.contact import Contact, as_contact

    contact = Contact.nonlinear() if contact is None else as_contact(contact)
    theta = validate_finite("theta", theta)
    mu_a = np.atleast_1d(np.asarray(mu, float))
    lo, hi = float(mu_a.min()), float(mu_a.max())
    if not hi > lo:
        raise InputError(f"Parameter mu={mu!r} must span a range (start < stop).")
    n_points = validate_int("n_points", n_points, 2)
    t = math.tan(theta)
    fr = {} if contact.mu_static is None else {"friction": contact.friction_law, "speed": speed}
    given = (onset is not None and not fr and getattr(onset, "status", None) == "onset"
             and getattr(onset, "damped", False) and getattr(onset, "theta", None) == theta)
    crit = onset if given else critical_friction(model, theta, damped=True, mu_max=max(2.0, 2 * hi), **fr)
    if crit.status != "onset":
        raise InputError(f"No squeal onset at theta = {math.degrees(theta):g} deg (status {crit.status}); "
                         "there is no Hopf point to start a limit-cycle branch from.")
    system = contact_system(model, contact, speed=speed, tan_theta=t)
    if not lo <= crit.mu_critical <= hi:
        raise InputError(f"The squeal onset mu_crit = {crit.mu_critical:.6g} (theta = {math.degrees(theta):g} deg) "
                         f"lies outside the friction range [{lo:g}, {hi:g}]; the branch starts there: widen the range.")
    hopf = hopf_point(system, crit.mu_critical)

    def solve(H: int) -> xr.Dataset:
        br = continue_branch(system, hopf, (lo, hi), harmonics=H, step=(hi - lo) / (n_points - 1),
                             max_points=max_points or 10 * n_points, n_floquet=n_floquet, stability=stability)
        return branch_dataset(system, br, harmonics=H, check_harmonics=check_harmonics,
                              attrs={"model": model.to_json(), "stability_method": stability, "theta": theta,
                                     "theta_deg": math.degrees(theta), "tan_theta": t, "speed": speed,
                                     "speed_units": "m/s", "contact": contact.describe(), "mu_range": [lo, hi]})

    return _enough_harmonics(solve, harmonics, harmonics_tol, check_harmonics)


#: Most harmonics an adaptive branch (``harmonics_tol``) goes to.
MAX_HARMONICS = 80


def _enough_harmonics(solve: Callable[[int], xr.Dataset], harmonics: int, tol: float | None,
                      check: bool) -> xr.Dataset:
    """``solve(H)`` with H doubled from ``harmonics`` until the amplitude changes by at most
    ``tol`` (relative) at 2H, or H would pass :data:`MAX_HARMONICS`; ``tol`` None: one solve."""
    if tol is None:
        return solve(int(harmonics))
    tol = validate_positive("harmonics_tol", tol)
    if not check:
        raise InputError("Parameter harmonics_tol needs check_harmonics=True: the amplitude change at 2H is "
                         "what measures convergence in the harmonics.")
    H = validate_int("harmonics", harmonics, 1)
    while True:
        ds = solve(H)
        change = float(ds.attrs["harmonics_change"])
        converged = change <= tol
        if converged or not math.isfinite(change) or 2 * H > MAX_HARMONICS:
            break
        H *= 2
    ds.attrs.update(harmonics_tol=tol, harmonics_converged=int(converged))
    if not converged:
        warnings.warn(f"The limit-cycle amplitudes changed by {change:.3g} (relative) from H = {H} to {2 * H} "
                      f"harmonics, more than harmonics_tol = {tol:g}"
                      + (f", at the most harmonics tried (MAX_HARMONICS = {MAX_HARMONICS})" if 2 * H > MAX_HARMONICS
                         else " (the change could not be measured)") + ".", RuntimeWarning, stacklevel=3)
    return ds


def limit_cycle_branch_slope(
    model,
    tan_theta: tuple[float, float] | NDArray,
    *,
    mu: float,
    contact=None,
    speed: float = 0.02,
    harmonics: int = 10,
    n_points: int = 50,
    max_points: int | None = None,
    n_floquet: int | None = None,
    check_harmonics: bool = True,
    scan: int = 81,
    stability: str = "monodromy",
    harmonics_tol: float | None = None,
) -> xr.Dataset:
    """Squeal limit cycles over the run-out slope tan(theta) at a fixed friction ``mu``.

    As :func:`limit_cycle_branch` with the roles swapped: the Hopf point is the first slope in
    the range where the damped linearisation loses stability (a scan of ``scan`` slopes, then a
    secant on the growth rate), and the branch is continued in ``tan_theta`` (variable
    ``tan_theta`` over ``point`` instead of ``mu``; ``hopf_mu`` then holds the critical slope).

    Parameters
    ----------
    model : FrictionModel
    tan_theta : (float, float) or array
        Slope range ``(start, stop)``.
    mu : float
        Friction coefficient.
    contact, speed, harmonics, n_points, max_points, n_floquet, check_harmonics, stability, harmonics_tol
        As for :func:`limit_cycle_branch`.
    scan : int
        Slopes scanned for the onset.

    Returns
    -------
    xarray.Dataset
    """
    validate_model(model, kind="friction")
    harmonics = validate_int("harmonics", harmonics, 1)
    n_points = validate_int("n_points", n_points, 2)
    scan = validate_int("scan", scan, 2)
    from ..transient.contact import Contact, as_contact
    from .hopf import _growth

    contact = Contact.nonlinear() if contact is None else as_contact(contact)
    t_a = np.atleast_1d(np.asarray(tan_theta, float))
    lo, hi = float(t_a.min()), float(t_a.max())
    if not hi > lo:
        raise InputError(f"Parameter tan_theta={tan_theta!r} must span a range (start < stop).")
    system = contact_system(model, contact, speed=speed, mu=validate_finite("mu", mu), param="tan_theta")
    grid = np.linspace(lo, hi, scan)
    g = np.array([_growth(system, t)[0] for t in grid])
    up = np.flatnonzero((g[:-1] < 0) & (g[1:] >= 0))
    if up.size == 0:
        raise InputError(f"No squeal onset for tan(theta) in [{lo:g}, {hi:g}] at mu = {mu:g}: "
                         "there is no Hopf point to start a limit-cycle branch from.")
    k = up[0]
    hopf = hopf_point(system, float(grid[k] - g[k] * (grid[k + 1] - grid[k]) / (g[k + 1] - g[k])))

    def solve(H: int) -> xr.Dataset:
        br = continue_branch(system, hopf, (lo, hi), harmonics=H, step=(hi - lo) / (n_points - 1),
                             max_points=max_points or 10 * n_points, n_floquet=n_floquet, stability=stability)
        return branch_dataset(system, br, harmonics=H, check_harmonics=check_harmonics,
                              attrs={"model": model.to_json(), "stability_method": stability, "mu": float(mu),
                                     "speed": speed, "speed_units": "m/s", "contact": contact.describe(),
                                     "tan_theta_range": [lo, hi], "hopf_theta_deg": math.degrees(math.atan(hopf.p))})

    ds = _enough_harmonics(solve, harmonics, harmonics_tol, check_harmonics)
    theta_deg = np.degrees(np.arctan(ds["tan_theta"].values))
    return ds.assign_coords(theta_deg=("point", theta_deg, {"units": "deg", "long_name": "run-out incline theta"}))


def branch_dataset(system: SecondOrderSystem, br: Branch, *, harmonics: int, check_harmonics: bool = True,
                   attrs: dict | None = None) -> xr.Dataset:
    """Label a :class:`Branch` as an xarray Dataset (see :func:`limit_cycle_branch`)."""
    from .harmonic_balance import harmonic_balance

    cyc = br.cycles
    p = np.array([c.p for c in cyc])
    omega = np.array([c.omega for c in cyc])
    amp = np.array([c.amplitude for c in cyc])
    change = float("nan")
    if check_harmonics:
        changes = []
        # at the Hopf point itself a piecewise-linear law has cycles of any small amplitude
        # (a vertical start): the check is made where the parameter has moved off it
        moved = [c for c in cyc if abs(c.p - br.hopf.p) > 1e-6 * max(1.0, abs(br.hopf.p))]
        # as many AFT samples as the branch's own (a contact that opens: at least CONTACT_SAMPLES)
        n_time = (None if system.contact_open is None
                  else max(n_time_samples(2 * harmonics), CONTACT_SAMPLES))
        with threadpool_limits(1, user_api="blas"):
            for c in moved[::5]:
                try:
                    c2 = harmonic_balance(system, c.p, omega=c.omega, guess=c.coefficients,
                                          harmonics=2 * harmonics, check_harmonics=False, n_time=n_time)
                except InputError:  # next to a vertical start the fixed-parameter solve is ill-posed: skip it
                    continue
                changes.append(float(np.max(np.abs(c2.amplitude - c.amplitude)) / np.max(c2.amplitude)))
        change = max(changes) if changes else float("nan")
    kind, kind_from = _onset_kind(br.hopf, p, br.stable)
    fold_mu = [float(p[i]) for i in br.folds]
    # hysteresis: squealing cycles (stable) exist below the Hopf point
    below = list(p[(p < br.hopf.p - 1e-9) & br.stable])
    below += [float(p[i]) for i in br.folds if p[i] < br.hopf.p and i + 1 < p.size and br.stable[i + 1]]
    hyst = [float(min(below)), float(br.hopf.p)] if below else [math.nan, math.nan]
    fold_flag = np.zeros(p.size, dtype=bool)
    fold_flag[list(br.folds)] = True
    ds = xr.Dataset(
        {
            system.param: ("point", p, {"units": "1", "long_name": "friction coefficient"}),
            "frequency_hz": ("point", omega / (2 * math.pi), {"units": "Hz", "long_name": "limit-cycle frequency"}),
            "omega_rad_s": ("point", omega, {"units": "rad/s"}),
            "amplitude": (("point", "dof"), amp,
                          {"units": "m", "long_name": "displacement amplitude (half peak-to-peak over one period)"}),
            "mean": (("point", "dof"), np.array([c.coefficients[0] for c in cyc]),
                     {"units": "m", "long_name": "mean displacement over one period"}),
            "contact_loss_fraction": ("point", np.array([c.contact_loss_fraction for c in cyc]),
                                      {"units": "1", "long_name": "fraction of the period with contact open"}),
            "stable": ("point", br.stable, {"long_name": "stable limit cycle (Floquet multipliers inside the unit "
                                                         "circle)"}),
            "floquet_max": ("point", np.abs(br.multipliers[:, :-1]).max(axis=1),
                            {"units": "1", "long_name": "largest non-trivial Floquet multiplier modulus"}),
            "floquet_error": ("point", np.abs(br.multipliers[:, -1] - 1.0),
                              {"units": "1", "long_name": "distance of the trivial Floquet multiplier from 1 (error)"}),
            "fold": ("point", fold_flag, {"long_name": "point nearest to a fold (turning point in mu)"}),
            "fold_mu": ("fold", np.array(fold_mu, float), {"units": "1", "long_name": "friction at each fold"}),
            "coefficients": (("point", "harmonic_row", "dof"), np.array([c.coefficients for c in cyc]),
                             {"units": "m", "long_name": "Fourier coefficients [a0, a1..aH, b1..bH]"}),
        },
        coords={"point": np.arange(p.size), "dof": list(system.dof_names),
                "harmonic_row": np.arange(2 * harmonics + 1)},
        attrs={
            "kind": "limit_cycle_branch",
            "title": "Limit-cycle branch by harmonic balance",
            "param": system.param,
            "system": system.description,
            "hopf_mu": br.hopf.p,
            "hopf_frequency_hz": br.hopf.frequency_hz,
            "lyapunov_coefficient": br.hopf.lyapunov_coefficient,
            "lyapunov_units": f"per length_scale^2, length_scale = {system.length_scale:.6g} m",
            "length_scale": system.length_scale,
            "hopf_kind": kind,
            "hopf_kind_from": kind_from,
            "hysteresis_mu": hyst,
            "harmonics": harmonics,
            "harmonics_change": change,
            "stop_reason": br.stop_reason,
            "stop_detail": br.stop_detail,
            "squealkit_version": __version__,
            **(attrs or {}),
        },
    )
    return ds.set_coords(system.param) if system.param in ds else ds


def _old_or_new(attrs: dict, new: str, old: str) -> str:
    """``attrs[new]``, or ``attrs[old]`` in a branch saved before the rename (``kind`` now names the result)."""
    return str(attrs[new] if new in attrs else attrs[old])


def limit_cycle_summary(ds: xr.Dataset) -> dict[str, object]:
    """A branch as plain Python (what ``squealkit limitcycle --json`` prints).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`limit_cycle_branch` (over friction) or
        :func:`limit_cycle_branch_slope` (over the run-out slope), optionally with
        :func:`~squealkit.nonlinear.sound_level` added.

    Returns
    -------
    dict
        ``parameter`` (``"mu"`` or ``"theta"``); ``mu`` (list over a friction branch, the fixed
        value over a slope branch) and ``theta_deg`` (the fixed incline, or the list over a
        slope branch); ``frequency_hz`` (list), ``amplitude`` (DOF name -> list of
        displacement amplitudes [m], half the peak-to-peak over one period), ``stable``
        (list of booleans), ``contact_loss_fraction`` (list), ``hopf`` (``mu``,
        ``frequency_hz``, ``lyapunov_coefficient``, ``kind``, ``kind_from``; and
        ``theta_deg`` over a slope branch), ``folds`` (list of mu, or of theta_deg),
        ``hysteresis_mu`` (or ``hysteresis_theta_deg``: [start, end] or []), ``harmonics``,
        ``harmonics_change``, ``stability_method``, ``stop_reason``, ``stop_detail`` (where and why
        the continuation stopped; empty for a branch saved before it existed), ``contact``; with
        ``harmonics_tol``: ``harmonics_tol`` and ``harmonics_converged``; with a
        level: ``level_db`` (list, dB SPL re 20 uPa), ``level_dof``, ``level_from``.
    """
    validate_dataset(ds, what="limit_cycle_branch")
    a = ds.attrs
    over_theta = a.get("param") == "tan_theta"

    def deg(t):
        return [float(math.degrees(math.atan(float(v)))) for v in np.atleast_1d(t) if np.isfinite(v)]

    hyst = [float(v) for v in np.atleast_1d(a["hysteresis_mu"]) if np.isfinite(v)]
    out: dict[str, object] = {"parameter": "theta" if over_theta else "mu"}
    if over_theta:
        out["mu"] = float(a["mu"])
        out["theta_deg"] = [float(v) for v in ds["theta_deg"].values]
    else:
        out["mu"] = [float(v) for v in ds["mu"].values]
        out["theta_deg"] = float(a.get("theta_deg", 0.0))
    hopf = {"mu": float(a["mu"]) if over_theta else float(a["hopf_mu"]),
            "frequency_hz": float(a["hopf_frequency_hz"]),
            "lyapunov_coefficient": float(a["lyapunov_coefficient"]), "kind": _old_or_new(a, "hopf_kind", "kind"),
            "kind_from": _old_or_new(a, "hopf_kind_from", "kind_from")}
    if over_theta:
        hopf["theta_deg"] = float(math.degrees(math.atan(float(a["hopf_mu"]))))
    out.update({
        "frequency_hz": [float(v) for v in ds["frequency_hz"].values],
        "amplitude": {str(d): [float(v) for v in ds["amplitude"].sel(dof=d).values] for d in ds["dof"].values},
        "stable": [bool(v) for v in ds["stable"].values],
        "contact_loss_fraction": [float(v) for v in ds["contact_loss_fraction"].values],
        "hopf": hopf,
        "folds": deg(ds["fold_mu"].values) if over_theta else [float(v) for v in ds["fold_mu"].values],
        ("hysteresis_theta_deg" if over_theta else "hysteresis_mu"): deg(hyst) if over_theta else hyst,
        "harmonics": int(a["harmonics"]),
        "harmonics_change": float(a["harmonics_change"]),
        "stability_method": str(a.get("stability_method", "monodromy")),
        "stop_reason": str(a["stop_reason"]),
        "stop_detail": str(a.get("stop_detail", "")),
        "contact": str(a.get("contact", "")),
    })
    if "harmonics_tol" in a:  # an adaptive branch
        out["harmonics_tol"] = float(a["harmonics_tol"])
        out["harmonics_converged"] = bool(a["harmonics_converged"])
    if "level_db" in ds:
        out["level_db"] = [float(v) for v in ds["level_db"].values]
        out["level_dof"] = str(a["level_dof"])
        out["level_from"] = str(a["level_from"])
    return out
