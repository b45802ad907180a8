"""A design-of-experiments sweep of two or three design parameters on the reduced model.

Every design parameter changes the matrices linearly (:mod:`~squealkit.design.parameters`), so at
one operating point the model of a design ``p`` is exactly

    M(p) = M + sum_j (p_j - p0_j) dM_j,   likewise C(p) and K(p),

and on a basis V (``modal`` or ``pod``, built once at the nominal design, optionally enriched by
the modes of the full model at the corners of the sweep) the reduced matrices are the same sums of
projected matrices: a design point costs one small dense eigenvalue solve. Each reduced eigenpair
``(lambda, V y)`` is checked in the full model of its design by its backward error
``||P(lambda; p) V y|| / ((|lambda|^2 ||M(p)|| + |lambda| ||C(p)|| + ||K(p)||) ||V y||)``, computed
exactly without full-size products: ``P(lambda; p) V y`` is a combination of the blocks
``[M V, C V, K V, dM_j V, ...]`` with coefficients ``lambda^2, lambda, 1, (p_j - p0_j) lambda^2, ...``,
so its norm is ``||R (c kron y)||`` with R the triangular factor of the blocks (as
:func:`squealkit.solvers.reduction.reduce` does for the operating parameters), and the Frobenius
norms follow from the Gram matrix of the full matrices.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import xarray as xr
from numpy.typing import NDArray

from .. import __version__
from .._threads import honour_thread_limit
from .._validation import InputError, check_budget, validate_model
from ..fe.model import FEModel
from ..solvers.band import RESIDUAL_TOL, real_times
from ._study import OperatingPoint, operating_point
from .derivatives import _fe_solver, _parameter_coords, _solve_fe
from .parameters import DesignParameter, design_parameters

__all__ = ["doe_points", "doe_sweep"]

#: Singular value (of unit snapshots' remainders off the basis) above which a direction is added.
_ENRICH_TOL = 1e-6


def doe_points(params: Sequence[DesignParameter], values: Mapping[str, Any] | Any) -> NDArray[np.float64]:
    """The design points of a sweep, shape (points, parameters).

    Parameters
    ----------
    params : sequence of DesignParameter
    values : mapping or array_like
        ``NAME -> 1-D values``: the full factorial grid (a parameter not named stays nominal); or
        the points themselves, shape (points, parameters), in the order of ``params``.

    Returns
    -------
    ndarray, shape (points, parameters)
    """
    names = [p.name for p in params]
    if isinstance(values, Mapping):
        for key in values:
            if key not in names:
                raise InputError(f"DOE values for {key!r}: not a design parameter; known: {', '.join(names)}.")
        axes = []
        for p in params:
            v = np.atleast_1d(np.asarray(values.get(p.name, [p.nominal]), dtype=float))
            if v.ndim != 1 or v.size == 0 or not np.all(np.isfinite(v)):
                raise InputError(f"DOE values for {p.name!r} must be a non-empty 1-D list of finite numbers.")
            axes.append(v)
        return np.array(list(itertools.product(*axes)), dtype=float).reshape(-1, len(params))
    pts = np.asarray(values, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != len(params) or not np.all(np.isfinite(pts)) or pts.shape[0] == 0:
        raise InputError(f"DOE points must be finite, of shape (points, {len(params)}), got {pts.shape}.")
    return pts


class _Blocks:
    """The full matrices of the sweep (nominal M, C, K and each parameter's derivatives), projected,
    with the triangular factor and Gram matrix of the full-model residuals."""

    def __init__(self, model: FEModel, params: Sequence[DesignParameter], pt: OperatingPoint, V: NDArray) -> None:
        mats: list[tuple[Any, int, int]] = [
            (model.mass_matrix(), 2, -1),
            (model.damping_matrix(pt.disc_speed, pt.mu, pt.tan_theta), 1, -1),
            (model.stiffness_matrix(pt.disc_speed, pt.mu, pt.tan_theta), 0, -1),
        ]
        for j, p in enumerate(params):
            for power, A in zip((2, 1, 0), p.matrix_derivatives(model, disc_speed=pt.disc_speed, mu=pt.mu,
                                                                  tan_theta=pt.tan_theta), strict=True):
                if A.nnz:
                    mats.append((sp.csr_matrix(A), power, j))
        self.power = np.array([m[1] for m in mats])
        self.param = np.array([m[2] for m in mats])
        r = V.shape[1]
        AV = np.empty((V.shape[0], len(mats) * r), order="F")
        self.reduced = []
        for i, (A, _, _) in enumerate(mats):
            block = AV[:, i * r:(i + 1) * r]
            block[...] = A @ V
            self.reduced.append(V.T @ block)
        (raw, _), _ = sla.qr(AV, mode="raw", overwrite_a=True, check_finite=False)
        self.R = np.triu(raw[: raw.shape[1]])
        self.gram = np.array([[float(A.multiply(B).sum()) for B, _, _ in mats] for A, _, _ in mats])
        self.r = r

    def coefficients(self, dp: NDArray) -> NDArray:
        """The weight of each matrix in ``M(p), C(p), K(p)``: 1 for the nominal ones, ``dp_j`` for j's."""
        return np.where(self.param < 0, 1.0, dp[np.maximum(self.param, 0)])

    def solve(self, dp: NDArray, band: tuple[float, float]) -> tuple[NDArray, NDArray, NDArray]:
        """Eigenvalues in ``band`` [Hz] of the design ``p0 + dp`` and their full-model backward errors."""
        w = self.coefficients(dp)
        r = self.r
        Mr, Cr, Kr = (sum(w[i] * self.reduced[i] for i in np.flatnonzero(self.power == k)) for k in (2, 1, 0))
        L = np.linalg.cholesky(Mr)

        def congruent(A: NDArray) -> NDArray:
            return sla.solve_triangular(L, sla.solve_triangular(L, A.T, lower=True).T, lower=True)

        A = np.block([[np.zeros((r, r)), np.eye(r)], [-congruent(Kr), -congruent(Cr)]])
        lam, Z = sla.eig(A, check_finite=False, overwrite_a=True)
        f = lam.imag / (2 * math.pi)
        keep = np.isfinite(lam) & (f >= band[0]) & (f <= band[1])
        lam = lam[keep]
        Y = sla.solve_triangular(L, Z[:r, keep], lower=True, trans="T")
        Y = Y / np.linalg.norm(Y, axis=0)
        stacked = np.concatenate([Y * (w[i] * lam ** self.power[i]) for i in range(w.size)], axis=0)
        res = np.linalg.norm(real_times(self.R, stacked), axis=0)
        norms = []
        for k in (2, 1, 0):  # ||M(p)||_F, ||C(p)||_F, ||K(p)||_F from the Gram matrix
            idx = np.flatnonzero(self.power == k)
            norms.append(math.sqrt(max(float(w[idx] @ self.gram[np.ix_(idx, idx)] @ w[idx]), 0.0)))
        a = np.abs(lam)
        return lam, Y, res / (a**2 * norms[0] + a * norms[1] + norms[2])


def _basis(model: FEModel, params: Sequence[DesignParameter], pt: OperatingPoint, points: NDArray, method: str,
           band: Any, n_modes: int | None, enrich: bool) -> tuple[NDArray, tuple[float, float], str]:
    """The nominal reduced basis, with the full model's modes at the corners of the sweep if ``enrich``."""
    if method not in ("modal", "pod"):
        raise InputError(f"A DOE sweep runs on the reduced model: method 'modal' or 'pod', not {method!r}.")
    solver = _fe_solver(model, pt, method, band, n_modes)
    V = solver.reduced.V
    if enrich:
        lo, hi = points.min(axis=0), points.max(axis=0)
        cols = []
        for corner in itertools.product(*zip(lo, hi, strict=True)):
            changed = model
            for p, v in zip(params, corner, strict=True):
                changed = p.apply(changed, v)
            full = _solve_fe(changed, pt, _fe_solver(changed, pt, "sparse", solver.band, None))
            cols += [full.X.real, full.X.imag]
        S = np.hstack(cols)
        S = S / np.maximum(np.linalg.norm(S, axis=0), 1e-300)
        # what the nominal basis misses of the corners' modes, compressed: the directions of that
        # remainder above _ENRICH_TOL (on the built-in brake at 1422 DOFs: 37 vectors for 8 corners of
        # 35 modes, the backward errors at the corners from 7e-7 to below 1e-8)
        U, sv, _ = np.linalg.svd(S - V @ (V.T @ S), full_matrices=False)
        V = np.linalg.qr(np.hstack([V, U[:, sv > _ENRICH_TOL]]))[0]
    return np.ascontiguousarray(V), solver.band, solver.method


@honour_thread_limit
def doe_sweep(
    model: FEModel,
    parameters: Mapping[str, Any] | Sequence[DesignParameter],
    values: Mapping[str, Any] | Any,
    rpm: float | None = None,
    mu: float | None = None,
    theta: float = 0.0,
    *,
    disc_speed: float | None = None,
    method: str = "pod",
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
    enrich: bool = True,
    eta_max: float = RESIDUAL_TOL,
) -> xr.Dataset:
    """Largest growth rate over a design of experiments of design parameters, on the reduced FE model.

    Parameters
    ----------
    model : FEModel
        The nominal model.
    parameters : mapping or sequence of DesignParameter
        The ``[design]`` table or declared parameters (scales and point masses).
    values : mapping or array_like
        ``NAME -> values`` (full factorial grid), or the points, shape (points, parameters)
        (:func:`doe_points`).
    rpm : float
        Disc speed [rev/min] (>= 0; or ``disc_speed``).
    mu : float, optional
        Friction coefficient (default: the model's ``mu_ref``).
    theta : float, default 0.0
        Run-out incline [rad].
    disc_speed : float, optional
        Disc speed [rad/s], instead of ``rpm``.
    method : {"pod", "modal"}
        Reduced basis (built once at the nominal design).
    band : (float, float), optional
        Frequency band [Hz] of the modes (default: the squeal band 1-16 kHz).
    n_modes : int, optional
        Basis size.
    enrich : bool, default True
        Add to the basis what it misses of the full model's modes at the corners of the sweep
        (2^k band solves; the remainders off the basis, compressed by an SVD): a basis of the
        nominal design alone may not hold the modes of a changed one (the residuals say so); on
        the built-in brake a +-40 % sweep needed them.
    eta_max : float
        Backward error in the full model up to which a reduced eigenpair is trusted.

    Returns
    -------
    xarray.Dataset
        Over ``point``: ``max_growth_rate`` [1/s] and ``frequency_hz`` [Hz] of the least stable
        trusted mode in the band, ``n_unstable``, ``max_residual`` (largest full-model backward
        error), ``all_trusted``, ``change_size`` (``sqrt(sum(((p - p0) / step)^2))``: the size of the
        change in declared steps) and ``pareto`` (no other trusted point is both smaller a change
        and less unstable); over ``(point, parameter)``: ``value``. ``kind = "doe_sweep"``.
    """
    validate_model(model, kind="fe")
    params = design_parameters([parameters] if isinstance(parameters, DesignParameter) else parameters, model)
    if any(p.kind == "model" for p in params):
        raise InputError("A DOE sweep takes FE design parameters (scales, point masses).")
    pt = operating_point(model, rpm, mu, theta, disc_speed=disc_speed)
    points = doe_points(params, values)
    check_budget(f"A DOE sweep of {points.shape[0]} points", points=points.shape[0], seconds=1e-3 * points.shape[0])
    V, band_, method_ = _basis(model, params, pt, points, method, band, n_modes, enrich)
    blocks = _Blocks(model, params, pt, V)
    nominal = np.array([p.nominal for p in params])
    step = np.array([p.step for p in params])
    n = points.shape[0]
    sig, freq, n_unst, max_res = (np.full(n, math.nan) for _ in range(4))
    from ..stability.fe_sweep import _point_arrays

    for i, p in enumerate(points):
        try:
            lam, _Y, res = blocks.solve(p - nominal, band_)
        except np.linalg.LinAlgError:  # M(p) not positive definite: not a design
            continue
        _err, unstable, _v, _t = _point_arrays(lam, res, np.ones(lam.size, bool))
        trusted = res <= eta_max
        max_res[i] = res.max(initial=0.0)
        n_unst[i] = int(unstable.sum())
        if trusted.any():
            k = int(np.argmax(np.where(trusted, lam.real, -np.inf)))
            sig[i], freq[i] = lam.real[k], lam.imag[k] / (2 * math.pi)
    size = np.sqrt((((points - nominal) / step) ** 2).sum(axis=1))
    ok = np.isfinite(sig) & (max_res <= eta_max)
    pareto = np.zeros(n, dtype=bool)
    order = np.lexsort((sig, size))
    best = math.inf
    for i in order:  # by size, then growth rate: a point is on the front if it beats every smaller change
        if ok[i] and sig[i] < best:
            pareto[i], best = True, sig[i]
    return xr.Dataset(
        {
            "value": (("point", "parameter"), points, {"long_name": "design parameter value"}),
            "max_growth_rate": ("point", sig, {"units": "1/s", "long_name": "largest growth rate (trusted modes)"}),
            "frequency_hz": ("point", freq, {"units": "Hz", "long_name": "frequency of the least stable mode"}),
            "n_unstable": ("point", n_unst, {"long_name": "unstable modes"}),
            "max_residual": ("point", max_res, {"long_name": "largest backward error in the full model"}),
            "all_trusted": ("point", max_res <= eta_max, {"long_name": f"every pair's backward error <= {eta_max:g}"}),
            "change_size": ("point", size, {"units": "1", "long_name": "size of the change in declared steps",
                                            "formula": "sqrt(sum(((p - p0) / step)^2))"}),
            "pareto": ("point", pareto, {"long_name": "on the Pareto front (change size, largest growth rate)"}),
        },
        coords={"point": ("point", np.arange(n)), **_parameter_coords(params)},
        attrs={
            "kind": "doe_sweep",
            "title": "Design of experiments on the reduced model",
            **pt.attrs(),
            "method": method_, "basis_size": int(V.shape[1]), "band_hz": list(band_), "eta_max": eta_max,
            "enriched": int(bool(enrich)),
            "model": model.to_json(), "model_kind": model.kind,
            "design": json.dumps([p.to_dict() for p in params]),
            "squealkit_version": __version__,
        },
    )
