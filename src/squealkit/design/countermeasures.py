"""Countermeasures: which declared change removes which unstable mode, and at what size of change.

For each unstable mode k and design parameter p (growth rate ``sigma_k(p)``, nominal ``p0``):

- the **effect** of the parameter is ``d sigma_k / d p`` times its declared ``step``: the change of
  the growth rate [1/s] a step of the parameter buys; parameters are ranked by its size;
- the **predicted** stabilising change is the first-order one, ``dp = -sigma_k / (d sigma_k / d p)``
  from the derivative at the nominal design (:mod:`~squealkit.design.derivatives`), signed: the
  smallest change of the parameter along the line to ``sigma_k = 0``;
- the **confirmed** change is the root of ``sigma_k(p) = 0`` found by Newton's method from the
  nominal design, each step a solve of the changed model (the mode followed by its shape, MAC)
  with the derivative from that solve's eigenvectors; once a step has crossed the root it is
  kept bracketed, and a bracket narrower than 1e-4 of the change confirms its stable end (the
  growth rate of a mode-coupling pair goes as the square root of the distance to its onset,
  where Newton crawls). It is the change that a solve shows to
  stabilise the mode; the relative difference of the two says how far first order carries.

A change that would take a scale or a mass below zero is not a countermeasure (``status
"beyond_range"``); a parameter without effect on the mode gives ``"no_effect"``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from .. import __version__
from .._threads import honour_thread_limit
from .._validation import validate_int
from ..fe.model import FEModel
from ..solvers.mac import mac
from ._study import OperatingPoint, resolve_study
from .derivatives import (
    _fe_solver,
    _mode_variables,
    _Modes,
    _nominal,
    _solve_fe,
    _solve_small,
    _study_attrs,
    _study_coords,
)
from .parameters import DesignParameter

__all__ = ["COUNTERMEASURE_STATUS", "countermeasures"]

#: Outcomes of the search for a stabilising change (``not_confirmed``: ``confirm=False``).
COUNTERMEASURE_STATUS = ("confirmed", "not_converged", "not_confirmed", "beyond_range", "no_effect", "lost")
#: Relative frequency window in which a changed model's mode is looked for.
_WINDOW = 0.1
#: Up to this many DOFs a confirmation solve is dense, above it a band solve around the mode.
_DENSE_CONFIRM = 300
#: A bracket [sigma > 0, sigma <= 0] this narrow, relative to the change, confirms its stable end.
_BRACKET_RTOL = 1e-4


def _track(modes: _Modes, lam_pred: complex, x_ref: Any, move: float) -> int | None:
    """The mode of ``modes`` that continues the reference mode: among the eigenvalues within the window
    around the predicted ``lam_pred`` (a tenth of it, plus the predicted ``move``: first order may be
    off by as much), those whose shape matches ``x_ref`` about as well as the best (MAC within 0.1),
    the one that grows fastest: the two roots of a mode-coupling pair have one shape, and the mode
    is stable only when both are."""
    near = np.abs(modes.lam - lam_pred) <= _WINDOW * abs(lam_pred) + move
    if not near.any():
        return None
    score = np.where(near, mac(modes.X, np.asarray(x_ref).reshape(-1, 1))[:, 0], -1.0)
    alike = score >= score.max() - 0.1
    return int(np.argmax(np.where(alike, modes.lam.real, -np.inf)))


def _confirming_solver(model: Any, pt: OperatingPoint, modes: _Modes, solver: Any):
    """A function ``solve(changed_model, lam_pred)`` solving a changed model as the study solved the
    nominal one: on the same basis for a reduced study; for a full one densely (small models) or in
    a band around the predicted eigenvalue."""
    if not isinstance(model, FEModel):
        return lambda m, lam: _solve_small(m, pt)
    if modes.V is not None:
        return lambda m, lam: _solve_fe(m, pt, solver, V=modes.V)
    if model.n_dof <= _DENSE_CONFIRM:
        return lambda m, lam: _solve_fe(m, pt, _fe_solver(m, pt, "dense", None, None))

    def solve(m: FEModel, lam: complex) -> _Modes:
        f = abs(lam.imag) / (2 * math.pi)
        return _solve_fe(m, pt, _fe_solver(m, pt, "sparse", ((1 - 2 * _WINDOW) * f, (1 + 2 * _WINDOW) * f), None))

    return solve


def _stabilise(model: Any, param: DesignParameter, pt: OperatingPoint, lam0: complex, x0: Any, d0: complex, solve: Any,
               max_solves: int) -> dict[str, Any]:
    """Safeguarded Newton on ``sigma(p) = 0`` from the nominal design (module docstring).

    Each step solves the changed model and takes the derivative from that solve's eigenvectors;
    once a step has crossed to ``sigma < 0`` the root is kept bracketed (a Newton step leaving
    the bracket is replaced by a bisection), so a growth rate that is not monotonic in the
    parameter does not throw the search off.
    """
    out: dict[str, Any] = {"predicted_value": math.nan, "confirmed_value": math.nan, "confirmed_growth_rate": math.nan,
                           "confirmed_frequency_hz": math.nan, "solves": 0}
    p0, s0, dl = param.nominal, lam0.real, complex(d0)
    if not (math.isfinite(dl.real) and abs(dl.real) * param.step > 1e-12 * abs(lam0)):
        return {**out, "status": "no_effect"}
    out["predicted_value"] = p0 - s0 / dl.real
    if out["predicted_value"] < param.lower:
        return {**out, "status": "beyond_range"}
    reach = 4.0 * abs(out["predicted_value"] - p0) + param.step
    p, lam, x = p0, lam0, x0
    up = (p0, s0)  # the last value with sigma > 0
    down: tuple[float, float] | None = None  # the value nearest to it with sigma <= 0
    at_down: dict[str, float] = {}
    for _ in range(max_solves):
        p_new = p - lam.real / dl.real if math.isfinite(dl.real) and dl.real != 0.0 else math.nan
        if down is not None and not (min(up[0], down[0]) < p_new < max(up[0], down[0])):
            p_new = 0.5 * (up[0] + down[0])  # bisection of the bracket
        if not math.isfinite(p_new) or abs(p_new - p0) > reach:  # first order does not carry this far
            break
        if p_new < param.lower:
            return {**out, "status": "beyond_range"}
        changed = param.apply(model, p_new)
        lam_pred = lam + dl * (p_new - p) if math.isfinite(abs(dl)) else lam
        modes = solve(changed, lam_pred)
        out["solves"] += 1
        j = _track(modes, lam_pred, x, abs(lam_pred - lam))
        if j is None:
            return {**out, "status": "lost"}
        step, p, lam, x = p_new - p, p_new, complex(modes.lam[j]), modes.X[:, j]
        out.update(confirmed_value=p, confirmed_growth_rate=lam.real, confirmed_frequency_hz=lam.imag / (2 * math.pi))
        if lam.real > 0:
            up = (p, lam.real)
        else:
            down = (p, lam.real)
            at_down = dict(confirmed_value=p, confirmed_growth_rate=lam.real,
                           confirmed_frequency_hz=lam.imag / (2 * math.pi))
        tiny = 1e-7 * max(abs(p - p0), param.step * 1e-3)
        if abs(lam.real) <= 1e-9 * abs(lam) or abs(step) <= tiny:
            return {**out, "status": "confirmed"}
        if down is not None and abs(up[0] - down[0]) <= _BRACKET_RTOL * abs(down[0] - p0):
            # a root where sigma is steep (the square root of a mode-coupling onset): the stable end
            # of a bracket narrower than _BRACKET_RTOL of the change is the confirmed value
            return {**out, **at_down, "status": "confirmed"}
        # the derivative matrices of a scale or a mass are those of the nominal model at any value
        at = changed if param.kind == "model" else model
        dl = complex(modes.derivatives(at, [param], pt, [j])[0, 0])
    return {**out, "status": "not_converged"}


@honour_thread_limit
def countermeasures(
    model: Any,
    parameters: Mapping[str, Any] | Sequence[DesignParameter],
    rpm: float | None = None,
    mu: float | None = None,
    theta: float = 0.0,
    *,
    disc_speed: float | None = None,
    method: str = "auto",
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
    basis: Any = None,
    confirm: bool = True,
    max_solves: int = 16,
) -> xr.Dataset:
    """Rank the declared changes for each unstable mode, with the smallest change that stabilises it.

    Parameters
    ----------
    model : FEModel or FrictionModel
        The nominal model.
    parameters : mapping or sequence of DesignParameter
        The ``[design]`` table (:func:`~squealkit.design.design_parameters`) or declared parameters.
    rpm : float, optional
        Disc speed [rev/min] (FE models, >= 0, or ``disc_speed``; refused for small models).
    mu : float, optional
        Friction coefficient (FE default: ``mu_ref``; required for small models).
    theta : float, default 0.0
        Run-out incline [rad].
    disc_speed : float, optional
        Disc speed [rad/s] of an FE model, instead of ``rpm``.
    method : {"auto", "dense", "sparse", "modal", "pod"}
        FE solver of the nominal design; a reduced study confirms on the same basis (with the
        full-model residual of each confirming solve), a full one by band solves around the mode.
    band : (float, float), optional
        Frequency band [Hz] of the modes considered (FE models).
    n_modes : int, optional
        Reduced basis size for ``modal``/``pod``.
    basis : array_like, shape (n, r), optional
        A reduced basis of the FE model's DOFs to study and confirm on, instead of one built by
        ``method`` (as :func:`~squealkit.design.eigen_derivatives`).
    confirm : bool, default True
        Confirm each predicted change by solves (Newton on ``sigma = 0``); False gives the
        first-order predictions only.
    max_solves : int, default 16
        Solves per mode and parameter at most (Newton converges in a few; a bisection of a
        bracket, where sigma is steep at its root as at a mode-coupling onset, takes more).

    Returns
    -------
    xarray.Dataset
        Over ``mode`` (the unstable ones): ``growth_rate`` [1/s], ``frequency_hz`` [Hz],
        ``residual``; over ``(mode, parameter)``: ``dgrowth_rate_dp``, ``dfrequency_hz_dp``,
        ``effect`` (``dgrowth_rate_dp * step`` [1/s per step]), ``rank`` (1: the largest
        ``|effect|`` for that mode), ``predicted_value``, ``predicted_change`` (from the nominal,
        first order), ``confirmed_value``, ``confirmed_change``, ``confirmed_growth_rate`` and
        ``confirmed_frequency_hz`` (of the last solve), ``prediction_error``
        (``|predicted - confirmed| / |confirmed|`` change), ``solves`` and ``status`` (one of
        :data:`COUNTERMEASURE_STATUS`). Coordinates as :func:`~squealkit.design.eigen_derivatives`;
        ``kind = "countermeasures"``.

    Examples
    --------
    >>> from squealkit.fe import FEModel
    >>> m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), KR=[[0.0, 1.0], [-1.0, 0.0]],
    ...                           D1=0.001 * np.eye(2))
    >>> ds = countermeasures(m, {"friction": "KR"}, rpm=60.0, mu=0.2)
    >>> str(ds.status.values[0, 0]), bool(ds.confirmed_value[0, 0] < 1.0)
    ('confirmed', True)
    """
    study = resolve_study(model, parameters, rpm, mu, theta, disc_speed=disc_speed, method=method, band=band,
                          n_modes=n_modes, basis=basis)
    max_solves = validate_int("max_solves", max_solves, 1)
    params, pt = study.params, study.point
    modes, solver, index, d = _nominal(study)
    shape = (index.size, len(params))
    rows: dict[str, np.ndarray] = {k: np.full(shape, math.nan) for k in (
        "predicted_value", "confirmed_value", "confirmed_growth_rate", "confirmed_frequency_hz")}
    solves = np.zeros(shape, dtype=np.int64)
    status = np.full(shape, "", dtype=object)
    solve = _confirming_solver(model, pt, modes, solver)
    for i, k in enumerate(index):
        lam0, x0 = complex(modes.lam[k]), modes.X[:, k]
        for j, p in enumerate(params):
            r = _stabilise(model, p, pt, lam0, x0, d[i, j], solve, max_solves if confirm else 0)
            if not confirm and r["status"] == "not_converged":
                r["status"] = "not_confirmed"
            for key in rows:
                rows[key][i, j] = r[key]
            solves[i, j], status[i, j] = r["solves"], r["status"]
    nominal = np.array([p.nominal for p in params])
    step = np.array([p.step for p in params])
    effect = d.real * step
    rank = np.argsort(np.argsort(-np.abs(effect), axis=1, kind="stable"), axis=1) + 1 if shape[1] else effect
    pred_change = rows["predicted_value"] - nominal
    conf_change = np.where(status == "confirmed", rows["confirmed_value"] - nominal, math.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        error = np.abs(pred_change - conf_change) / np.abs(conf_change)
    mp = ("mode", "parameter")
    return xr.Dataset(
        {
            **_mode_variables(study, modes, index, d),
            "effect": (mp, effect, {"units": "1/s", "long_name": "change of the growth rate per declared step"}),
            "rank": (mp, np.asarray(rank, dtype=np.int64), {"long_name": "rank by |effect| (1: largest)"}),
            "predicted_value": (mp, rows["predicted_value"], {"long_name": "first-order stabilising value"}),
            "predicted_change": (mp, pred_change, {"long_name": "first-order stabilising change from the nominal"}),
            "confirmed_value": (mp, np.where(status == "confirmed", rows["confirmed_value"], math.nan),
                                {"long_name": "stabilising value confirmed by solves (sigma = 0)"}),
            "confirmed_change": (mp, conf_change, {"long_name": "confirmed stabilising change from the nominal"}),
            "confirmed_growth_rate": (mp, rows["confirmed_growth_rate"],
                                      {"units": "1/s", "long_name": "growth rate at the last solve"}),
            "confirmed_frequency_hz": (mp, rows["confirmed_frequency_hz"],
                                       {"units": "Hz", "long_name": "frequency at the last solve"}),
            "prediction_error": (mp, error, {"long_name": "|predicted - confirmed| / |confirmed| change"}),
            "solves": (mp, solves, {"long_name": "confirming solves"}),
            "status": (mp, status.astype(str), {"long_name": "outcome of the search",
                                                "allowed": " ".join(COUNTERMEASURE_STATUS)}),
        },
        coords=_study_coords(study, index),
        attrs={
            "kind": "countermeasures",
            "title": "Countermeasures: the smallest change of each parameter that stabilises each unstable mode",
            **_study_attrs(study, modes, solver),
            "confirmed": int(bool(confirm)),
            "squealkit_version": __version__,
        },
    )
