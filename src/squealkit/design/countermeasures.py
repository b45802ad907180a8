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

How a changed model is solved: a reduced study on its basis, a small model densely. A full FE
study refines the one eigenpair at each Newton point from the derivative's prediction (nonlinear
inverse iteration in the full model, one sparse LU per iteration, to a backward error of 1e-12:
:class:`_Refiner`), and checks the confirmed value alone by a full solve around the mode with the
same tracking rule (among the modes of alike shape in the window, the one that grows fastest); a
point whose refinement fails, or a check that follows another eigenvalue, falls back to a full
solve per point. On the built-in brake (738 DOFs) the guide's study confirms 3x faster (CPU) with
the same statuses and changes to 1e-6 (``benchmarks/bench_design_confirm.py``).

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
#: Full FE studies refine the one eigenpair at each Newton point (:class:`_Refiner`) instead of a band solve.
_REFINE = True
#: Backward error in the full model at which a refined eigenpair is converged.
_REFINE_TOL = 1e-12
#: Nonlinear inverse iterations (one sparse LU each) allowed per point before a band solve is used instead.
_REFINE_ITERATIONS = 8
#: Smallest MAC of a refined shape with the previous point's for the refined pair to continue the mode.
_REFINE_MAC = 0.8


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


class _Refiner:
    """The eigenpair of a changed full FE model nearest a prediction, by nonlinear inverse iteration.

    A design parameter of an FE model changes the matrices linearly, ``M(p) = M + (p - p0) dM`` (likewise
    C, K: :mod:`~squealkit.design.parameters`), so a changed model needs no new FEModel. From the
    prediction ``(lambda, x)`` (the derivative's eigenvalue, the previous point's shape), Newton's method on
    ``P(lambda) x = 0, v^H x = 1`` (Ruhe 1973: ``u = P(lambda)^-1 P'(lambda) x``,
    ``lambda <- lambda - 1 / v^H u``, ``x <- u / v^H u``; one sparse LU per iteration, quadratic
    convergence) until the pair's backward error in the full model is below :data:`_REFINE_TOL`; the
    left eigenvector for the next derivative from the last LU (two adjoint solves). None when it does not
    converge, leaves the frequency window or changes shape (MAC below :data:`_REFINE_MAC`): the caller then
    solves the band as before.
    """

    def __init__(self, model: Any, pt: OperatingPoint, modes: _Modes) -> None:
        import scipy.sparse as sp

        self.model, self.pt = model, pt
        self.M, self.C, self.K = (sp.csc_matrix(A, dtype=complex) for A in (modes.M, modes.C, modes.K))
        self._derivatives: dict[str, tuple[Any, Any, Any]] = {}

    def derivative_matrices(self, param: DesignParameter) -> tuple[Any, Any, Any]:
        if param.name not in self._derivatives:
            import scipy.sparse as sp

            d = param.matrix_derivatives(self.model, disc_speed=self.pt.disc_speed, mu=self.pt.mu,
                                         tan_theta=self.pt.tan_theta)
            self._derivatives[param.name] = tuple(sp.csc_matrix(A, dtype=complex) for A in d)
        return self._derivatives[param.name]

    def __call__(self, param: DesignParameter, value: float, lam_pred: complex, x_ref: Any,
                 move: float) -> tuple[complex, Any, complex, float] | None:
        """``(lambda, x, d lambda / d p, backward error)`` at ``param = value``, or None."""
        import scipy.sparse.linalg as spla

        from ..solvers.band import pencil_backward_errors
        from .derivatives import eigenvalue_derivatives

        dM, dC, dK = self.derivative_matrices(param)
        h = value - param.nominal
        M, C, K = self.M + h * dM, self.C + h * dC, self.K + h * dK
        x = np.asarray(x_ref, dtype=complex)
        v = x / np.vdot(x, x)  # v^H x = 1
        lam = complex(lam_pred)
        for _ in range(_REFINE_ITERATIONS):
            try:
                lu = spla.splu((lam * lam) * M + lam * C + K)
            except RuntimeError:  # exactly singular: leave it to a band solve
                return None
            u = lu.solve((2 * lam) * (M @ x) + C @ x)
            vu = np.vdot(v, u)
            if not np.isfinite(vu) or vu == 0:
                return None
            lam, x = lam - 1.0 / vu, u / vu
            eta = float(pencil_backward_errors(M, C, K, np.array([lam]), x[:, None])[0])
            if eta <= _REFINE_TOL:
                break
        else:
            return None
        if abs(lam - lam_pred) > _WINDOW * abs(lam_pred) + move:
            return None
        x = x / np.linalg.norm(x)
        if mac(x[:, None], np.asarray(x_ref).reshape(-1, 1) / np.linalg.norm(x_ref))[0, 0] < _REFINE_MAC:
            return None
        y = np.ones_like(x)
        for _ in range(2):  # the left null vector of the nearly singular P(lambda_last)^H
            y = lu.solve(y, trans="H")
            y /= np.linalg.norm(y)
        dl = complex(eigenvalue_derivatives(M, C, [lam], x[:, None], y[:, None], dM, dC, dK)[0])
        eta = float(pencil_backward_errors(M, C, K, np.array([lam]), x[:, None])[0])
        return lam, x, dl, eta


def _confirming_solver(model: Any, pt: OperatingPoint, modes: _Modes, solver: Any):
    """A function ``solve(changed_model, lam_pred, exact=False)`` solving a changed model as the study solved
    the nominal one: on the same basis for a reduced study; for a full one densely (small models) or in a
    band around the predicted eigenvalue: +-2 windows of it (the window of :func:`_track` around a
    prediction that may be off by as much), or with ``exact`` (``lam_pred`` an eigenvalue, the window
    centred on it) just the window's frequencies, ``f +- _WINDOW |lambda| / 2 pi``."""
    if not isinstance(model, FEModel):
        return lambda m, lam, exact=False: _solve_small(m, pt)
    if modes.V is not None:
        return lambda m, lam, exact=False: _solve_fe(m, pt, solver, V=modes.V)
    if model.n_dof <= _DENSE_CONFIRM:
        return lambda m, lam, exact=False: _solve_fe(m, pt, _fe_solver(m, pt, "dense", None, None))

    def solve(m: FEModel, lam: complex, exact: bool = False) -> _Modes:
        f = abs(lam.imag) / (2 * math.pi)
        half = _WINDOW * abs(lam) / (2 * math.pi) if exact else 2 * _WINDOW * f
        return _solve_fe(m, pt, _fe_solver(m, pt, "sparse", (max(f - half, 0.0), f + half), None))

    return solve


def _stabilise(model: Any, param: DesignParameter, pt: OperatingPoint, lam0: complex, x0: Any, d0: complex,
               solve: Any, max_solves: int, refine: _Refiner | None = None) -> dict[str, Any]:
    """Safeguarded Newton on ``sigma(p) = 0`` from the nominal design (module docstring).

    Each step solves the changed model and takes the derivative from that solve's eigenvectors;
    once a step has crossed to ``sigma < 0`` the root is kept bracketed (a Newton step leaving
    the bracket is replaced by a bisection), so a growth rate that is not monotonic in the
    parameter does not throw the search off.

    With ``refine`` (a full FE study), a step refines the one eigenpair from the prediction
    (:class:`_Refiner`) instead of solving a band, and the confirmed value is then checked by one
    band solve with the same tracking as before (:func:`_track`: the mode among those of alike shape
    in the window that grows fastest); if the band solve follows another eigenvalue, the search is
    redone with band solves throughout. A step whose refinement fails solves the band.
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
    at_down: dict[str, Any] = {}
    for _ in range(max_solves):
        p_new = p - lam.real / dl.real if math.isfinite(dl.real) and dl.real != 0.0 else math.nan
        if down is not None and not (min(up[0], down[0]) < p_new < max(up[0], down[0])):
            p_new = 0.5 * (up[0] + down[0])  # bisection of the bracket
        if not math.isfinite(p_new) or abs(p_new - p0) > reach:  # first order does not carry this far
            break
        if p_new < param.lower:
            return {**out, "status": "beyond_range"}
        lam_pred = lam + dl * (p_new - p) if math.isfinite(abs(dl)) else lam
        out["solves"] += 1
        got = None if refine is None else refine(param, p_new, lam_pred, x, abs(lam_pred - lam))
        if got is not None:
            step, p = p_new - p, p_new
            lam, x, dl_next = complex(got[0]), got[1], got[2]
        else:
            changed = param.apply(model, p_new)
            modes = solve(changed, lam_pred)
            j = _track(modes, lam_pred, x, abs(lam_pred - lam))
            if j is None:
                return {**out, "status": "lost"}
            step, p, lam, x = p_new - p, p_new, complex(modes.lam[j]), modes.X[:, j]
            dl_next = None
        out.update(confirmed_value=p, confirmed_growth_rate=lam.real, confirmed_frequency_hz=lam.imag / (2 * math.pi))
        if lam.real > 0:
            up = (p, lam.real)
        else:
            down = (p, lam.real)
            at_down = dict(confirmed_value=p, confirmed_growth_rate=lam.real,
                           confirmed_frequency_hz=lam.imag / (2 * math.pi), lam=lam, x=x)
        tiny = 1e-7 * max(abs(p - p0), param.step * 1e-3)
        found = None
        if abs(lam.real) <= 1e-9 * abs(lam) or abs(step) <= tiny:
            found = {"lam": lam, "x": x}
        elif down is not None and abs(up[0] - down[0]) <= _BRACKET_RTOL * abs(down[0] - p0):
            # a root where sigma is steep (the square root of a mode-coupling onset): the stable end
            # of a bracket narrower than _BRACKET_RTOL of the change is the confirmed value
            found = at_down
        if found is not None:
            result = {**out, **{k: v for k, v in found.items() if k.startswith("confirmed")}, "status": "confirmed"}
            if refine is None:
                return result
            # the band solve with the tracking rule must follow the same eigenvalue, else redo with band solves
            value = result["confirmed_value"]
            modes = solve(param.apply(model, value), found["lam"], exact=True)
            result["solves"] += 1
            j = _track(modes, found["lam"], found["x"], 0.0)
            if j is not None and abs(modes.lam[j] - found["lam"]) <= 1e-8 * abs(found["lam"]):
                return result
            again = _stabilise(model, param, pt, lam0, x0, d0, solve, max_solves)
            return {**again, "solves": again["solves"] + result["solves"]}
        if dl_next is not None:
            dl = dl_next
        else:
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
    refine = _Refiner(model, pt, modes) if _REFINE and study.is_fe and modes.V is None else None
    for i, k in enumerate(index):
        lam0, x0 = complex(modes.lam[k]), modes.X[:, k]
        for j, p in enumerate(params):
            r = _stabilise(model, p, pt, lam0, x0, d[i, j], solve, max_solves if confirm else 0, refine)
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
