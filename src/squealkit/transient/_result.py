"""The labelled result of a transient run: variables with units, attributes, located events, warnings.

:func:`_run_dataset` turns one run's raw outputs (displacements, velocities, accelerations, the
contact force and friction coefficient the kernel recorded) into the variables of
:func:`~squealkit.transient.simulate` (normal and friction force, run-out, the frozen-time growth
rate sigma(t)); :func:`_attrs` says what the run was and what the integrator did.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import xarray as xr

from ..stability.eigen import eigenvalues
from ._driver import _MAX_EVENTS
from ._runs import _Run
from .contact import contact_geometry

_EVENT_NAMES = {1: "contact_opens", 2: "contact_closes", 3: "stick", 4: "slip"}
_STATUS = {0: "completed", 1: "diverged", 2: "failed"}


class TensileContactWarning(UserWarning):
    """The linear (paper's) contact law carried a pulling normal force: run with contact loss."""


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
