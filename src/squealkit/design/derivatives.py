"""Eigenvalue derivatives of the unstable modes with respect to design parameters, without a re-solve.

At an operating point the modes are the eigenpairs of ``P(lambda) = lambda^2 M + lambda C + K``.
For a simple eigenvalue lambda with right eigenvector x (``P x = 0``) and left eigenvector y
(``y^H P = 0``), first-order perturbation gives (e.g. Nobari, Ouyang & Bannister, J. Sound Vib.
338, 2015, for non-symmetric, non-proportionally damped systems)::

    d lambda / d p = -y^H (lambda^2 dM + lambda dC + dK) x / y^H (2 lambda M + C) x

with ``dM, dC, dK`` the derivative matrices of the design parameter
(:meth:`~squealkit.design.DesignParameter.matrix_derivatives`). The right eigenvectors come from
the solve that found the modes; the left eigenvector of each mode of interest follows from one
LU of ``P(lambda)`` already at the eigenvalue (inverse iteration with the adjoint: two
triangular solves), so no eigenvalue problem is solved again. ``d sigma / d p`` and
``d f / d p = Im(d lambda / d p) / 2 pi`` are the derivatives of the growth rate and the frequency.

For a reduced model (``method="modal"`` or ``"pod"``, basis V) everything is done on the reduced
problem: ``V^T M V`` and the projected derivatives ``V^T dM V`` etc., so the derivatives are those
of the reduced eigenvalues, each pair's backward error in the full model telling whether the
reduced eigenvalue is the brake's.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import xarray as xr
from numpy.typing import NDArray

from .. import __version__
from .._threads import honour_thread_limit
from ..fe.model import FEModel
from ._study import OperatingPoint, Study, resolve_study
from .parameters import DesignParameter

__all__ = ["eigen_derivatives", "eigenvalue_derivatives", "left_eigenvectors"]


# -- the linear algebra -------------------------------------------------------------------


def left_eigenvectors(M: Any, C: Any, K: Any, lam: Any, *, iterations: int = 2) -> NDArray[np.complex128]:
    """Left eigenvectors ``y`` (``y^H P(lambda) = 0``) of the given eigenvalues, by inverse iteration.

    One LU of ``P(s_k)`` per eigenvalue, at ``s_k = lambda_k (1 + 1e-10 (1 + j))`` (an exact eigenvalue
    would make it exactly singular), so that a solve with its adjoint is dominated by the left null
    vector: ``iterations`` solves with ``P^H`` from a fixed start vector leave the other left
    eigenvectors in it at ``(1e-10 |lambda| / gap)^iterations``.

    Parameters
    ----------
    M, C, K : sparse or dense matrices, shape (n, n)
    lam : array_like, shape (k,)
        Eigenvalues [1/s], each simple.
    iterations : int
        Adjoint solves per eigenvalue (2: one to find the direction, one to refine it).

    Returns
    -------
    ndarray of complex, shape (n, k)
        Unit 2-norm columns.
    """
    lam = np.atleast_1d(np.asarray(lam, dtype=complex))
    n = M.shape[0]
    rng = np.random.default_rng(0)  # a fixed start: the result does not depend on it beyond rounding
    start = rng.standard_normal(n) + 1j * rng.standard_normal(n)
    Y = np.empty((n, lam.size), dtype=complex)
    for k, lk in enumerate(lam):
        sk = lk + 1e-10 * (abs(lk) or 1.0) * (1 + 1j)
        P = sk * sk * M + sk * C + K
        y = start / np.linalg.norm(start)
        if sp.issparse(P):
            lu = spla.splu(sp.csc_matrix(P, dtype=complex))
            for _ in range(iterations):
                y = lu.solve(y, trans="H")
                y /= np.linalg.norm(y)
        else:
            factor = sla.lu_factor(np.asarray(P, dtype=complex), check_finite=False)
            for _ in range(iterations):
                y = sla.lu_solve(factor, y, trans=2, check_finite=False)
                y /= np.linalg.norm(y)
        Y[:, k] = y
    return Y


def eigenvalue_derivatives(M: Any, C: Any, lam: Any, X: Any, Y: Any, dM: Any, dC: Any, dK: Any) -> NDArray:
    """``d lambda / d p = -y^H (lambda^2 dM + lambda dC + dK) x / y^H (2 lambda M + C) x`` for each pair.

    Parameters
    ----------
    M, C : sparse or dense matrices, shape (n, n)
        Mass and damping at the operating point.
    lam : array_like, shape (k,)
        Eigenvalues [1/s].
    X, Y : ndarray, shape (n, k)
        Right and left eigenvectors.
    dM, dC, dK : sparse or dense matrices, shape (n, n)
        Derivatives of M, C, K per unit of the parameter.

    Returns
    -------
    ndarray of complex, shape (k,)
        [1/s per unit of the parameter].

    Examples
    --------
    ``x'' + k x = 0`` has ``lambda = j sqrt(k)``: ``d lambda / d k = j / (2 sqrt(k))``.

    >>> one = np.eye(1)
    >>> complex(eigenvalue_derivatives(one, 0 * one, [2j], one, one, 0 * one, 0 * one, one)[0])
    0.25j
    """
    lam = np.atleast_1d(np.asarray(lam, dtype=complex))
    X, Y = np.asarray(X, dtype=complex), np.asarray(Y, dtype=complex)
    num = np.einsum("ik,ik->k", Y.conj(), (dM @ X) * lam**2 + (dC @ X) * lam + dK @ X)
    den = np.einsum("ik,ik->k", Y.conj(), (M @ X) * (2 * lam) + C @ X)
    return -num / den + 0.0  # + 0.0: no negative zeros


# -- one operating point ------------------------------------------------------------------


def _pencil(model: Any, pt: OperatingPoint) -> tuple[Any, Any, Any]:
    """``M, C, K`` at the point: sparse for an FE model, dense for a small one (damping included)."""
    if isinstance(model, FEModel):
        return (model.mass_matrix(), model.damping_matrix(pt.disc_speed, pt.mu, pt.tan_theta),
                model.stiffness_matrix(pt.disc_speed, pt.mu, pt.tan_theta))
    from ..stability.modes import _parts, _stiffness

    M, C, K0, Kn, Kf = _parts(model, True)
    return M, C, _stiffness(model, K0, Kn, Kf, pt.mu, pt.tan_theta)


@dataclass
class _Modes:
    """The modes at one point in the space the derivatives are taken in (full DOFs or basis coordinates).

    ``project`` maps a full-size matrix into that space (identity, or ``V^T A V``).
    """

    lam: NDArray[np.complex128]
    X: NDArray[np.complex128]
    residual: NDArray[np.float64]
    unstable: NDArray[np.bool_]
    M: Any
    C: Any
    K: Any
    V: NDArray[np.float64] | None
    method: str

    def project(self, A: Any) -> Any:
        if self.V is None:
            return A
        return self.V.T @ np.asarray(A @ self.V)

    def derivatives(self, model: Any, params: Sequence[DesignParameter], pt: OperatingPoint, index: Any) -> NDArray:
        """``d lambda / d p``, shape (len(index), len(params)), of the modes ``index``."""
        index = np.atleast_1d(np.asarray(index, dtype=np.intp))
        out = np.zeros((index.size, len(params)), dtype=complex)
        if index.size == 0:
            return out
        lam, X = self.lam[index], self.X[:, index]
        Y = left_eigenvectors(self.M, self.C, self.K, lam)
        for j, p in enumerate(params):
            dM, dC, dK = (self.project(A) for A in p.matrix_derivatives(model, disc_speed=pt.disc_speed, mu=pt.mu,
                                                                          tan_theta=pt.tan_theta))
            out[:, j] = eigenvalue_derivatives(self.M, self.C, lam, X, Y, dM, dC, dK)
        return out


def _fe_solver(model: FEModel, pt: OperatingPoint, method: str, band: Any, n_modes: int | None):
    from ..stability.fe_sweep import FESolver

    samples = (np.array([pt.disc_speed]), np.array([pt.mu + pt.tan_theta])) if method == "pod" else None
    return FESolver(model, method, band, n_modes, samples)


def _solve_fe(model: FEModel, pt: OperatingPoint, solver: Any, V: NDArray | None = None) -> _Modes:
    """The modes of an FE model by ``solver`` (an FESolver), or on the fixed basis ``V``."""
    from threadpoolctl import threadpool_limits

    from ..solvers import reduction
    from ..stability.fe_sweep import _point_arrays

    with threadpool_limits(1, user_api="blas"):
        if V is not None or solver.reduced is not None:
            red = solver.reduced if V is None else reduction.reduce(model, V)
            lo, hi = solver.band if solver.band is not None else (0.0, math.inf)
            lam, Yc, res = reduction.reduced_solve(red, pt.disc_speed, pt.mu + pt.tan_theta, lo, hi)
            proj = red.projected
            M, C, K = (np.asarray(A.toarray()) for A in (proj.mass_matrix(),
                                                          proj.damping_matrix(pt.disc_speed, pt.mu, pt.tan_theta),
                                                          proj.stiffness_matrix(pt.disc_speed, pt.mu, pt.tan_theta)))
            X, basis, method = Yc, red.V, solver.method
        else:
            sol = solver.solve(pt.disc_speed, pt.mu, pt.tan_theta)
            lam, X, res = sol.eigenvalues, sol.vectors, sol.residuals
            M, C, K = _pencil(model, pt)
            basis, method = None, solver.method
    _err, unstable, _verdict, _thr = _point_arrays(lam, np.where(np.isfinite(res), res, 0.0), np.ones(lam.size, bool))
    return _Modes(lam, X, res, unstable, M, C, K, basis, method)


def _solve_small(model: Any, pt: OperatingPoint) -> _Modes:
    from ..stability.modes import mode_shapes, modes

    ds = modes(model, pt.mu, pt.theta, damped=True)
    lam = ds.growth_rate.values + 1j * ds.omega.values
    X = mode_shapes(ds).T
    M, C, K = _pencil(model, pt)
    from ..solvers.band import pencil_backward_errors

    return _Modes(lam, X, pencil_backward_errors(M, C, K, lam, X), ds.unstable.values.astype(bool), M, C, K, None,
                  "dense")


def _solve(study: Study) -> tuple[_Modes, Any]:
    """The nominal modes of a study, and the FE solver (None for a small model)."""
    model, pt = study.model, study.point
    if not study.is_fe:
        return _solve_small(model, pt), None
    if study.basis is not None:
        from types import SimpleNamespace

        solver = SimpleNamespace(method="basis", band=study.band, reduced=None)
        return _solve_fe(model, pt, solver, V=study.basis), solver
    solver = _fe_solver(model, pt, study.method, study.band, study.n_modes)
    return _solve_fe(model, pt, solver), solver


def _nominal(study: Study, *, unstable_only: bool = True) -> tuple[_Modes, Any, NDArray[np.intp], NDArray]:
    """The nominal solve of a study: its modes, the solver, the modes kept (the unstable ones, or all) and
    their derivatives ``d lambda / d p`` (kept modes, parameters)."""
    modes, solver = _solve(study)
    index = np.flatnonzero(modes.unstable) if unstable_only else np.arange(modes.lam.size)
    return modes, solver, index, modes.derivatives(study.model, study.params, study.point, index)


def _mode_variables(study: Study, modes: _Modes, index: NDArray, d: NDArray) -> dict[str, Any]:
    """The variables over ``mode`` and ``(mode, parameter)`` that a derivative study and a countermeasure
    study share."""
    lam = modes.lam[index]
    md, mp = ("mode",), ("mode", "parameter")
    per = "per unit of the parameter"
    return {
        "growth_rate": (md, lam.real, {"units": "1/s", "long_name": "growth rate sigma"}),
        "frequency_hz": (md, lam.imag / (2 * math.pi), {"units": "Hz", "long_name": "frequency"}),
        "residual": (md, modes.residual[index], {"long_name": "backward error in the full model"}),
        "dgrowth_rate_dp": (mp, d.real, {"units": f"1/s {per}", "long_name": "d sigma / d p"}),
        "dfrequency_hz_dp": (mp, d.imag / (2 * math.pi), {"units": f"Hz {per}", "long_name": "d f / d p"}),
    }


def _study_coords(study: Study, index: NDArray) -> dict[str, Any]:
    return {"mode": ("mode", index, {"long_name": "index of the mode in the solve"}),
            **_parameter_coords(study.params)}


def _study_attrs(study: Study, modes: _Modes, solver: Any) -> dict[str, Any]:
    """The attributes a derivative study and a countermeasure study share."""
    return {
        **study.point.attrs(),
        "method": modes.method,
        "basis_size": 0 if modes.V is None else int(modes.V.shape[1]),
        "band_hz": "all" if solver is None or solver.band is None else list(solver.band),
        "model": study.model.to_json(), "model_kind": study.model.kind,
        "design": json.dumps([p.to_dict() for p in study.params]),
    }


def _parameter_coords(params: Sequence[DesignParameter]) -> dict[str, Any]:
    return {
        "parameter": ("parameter", [p.name for p in params], {"long_name": "design parameter"}),
        "parameter_kind": ("parameter", [p.kind for p in params]),
        "parameter_unit": ("parameter", [p.unit for p in params]),
        "parameter_nominal": ("parameter", np.array([p.nominal for p in params]), {"long_name": "nominal value"}),
        "parameter_step": ("parameter", np.array([p.step for p in params]),
                           {"long_name": "size of change parameters are compared by"}),
    }


@honour_thread_limit
def eigen_derivatives(
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
    unstable_only: bool = True,
    basis: Any = None,
) -> xr.Dataset:
    """Derivatives of the growth rate and frequency of each unstable mode w.r.t. each design parameter.

    One solve finds the modes; the derivatives follow from their right and left eigenvectors
    (module docstring), for every parameter at once.

    Parameters
    ----------
    model : FEModel or FrictionModel
        The nominal model.
    parameters : mapping or sequence of DesignParameter
        The ``[design]`` table (see :func:`~squealkit.design.design_parameters`), or declared parameters.
    rpm : float, optional
        Disc speed [rev/min] (FE models, >= 0, or ``disc_speed``; refused for small models).
    mu : float, optional
        Friction coefficient (FE default: the model's ``mu_ref``; required for small models).
    theta : float, default 0.0
        Run-out incline [rad]; ``mu + tan(theta)`` enters the friction parts.
    disc_speed : float, optional
        Disc speed [rad/s] of an FE model, instead of ``rpm``.
    method : {"auto", "dense", "sparse", "modal", "pod"}
        FE solver (:func:`~squealkit.stability.fe_modes`); ``modal``/``pod`` give the derivatives of
        the reduced model's eigenvalues.
    band : (float, float), optional
        Frequency band [Hz] of the modes considered (FE models).
    n_modes : int, optional
        Reduced basis size for ``modal``/``pod``.
    unstable_only : bool, default True
        Keep the unstable modes only; False keeps every mode found.
    basis : array_like, shape (n, r), optional
        A reduced basis of the FE model's DOFs to take the derivatives on (the reduced model
        ``V^T A V`` of an orthonormalised V, each pair checked in the full model), instead of one
        built by ``method``; the ``band`` then defaults to all modes of the reduced model.

    Returns
    -------
    xarray.Dataset
        Over ``mode``: ``growth_rate`` [1/s], ``frequency_hz`` [Hz], ``residual`` (backward error
        in the full model), ``unstable``; over ``(mode, parameter)``: ``dgrowth_rate_dp``
        [1/s per unit of the parameter] and ``dfrequency_hz_dp`` [Hz per unit]. Coordinates
        ``parameter`` with ``parameter_kind``, ``parameter_unit``, ``parameter_nominal``,
        ``parameter_step``. Attributes: ``kind = "eigen_derivatives"``, the operating point,
        ``method``, ``basis_size``, ``model`` and ``design`` (JSON).

    Examples
    --------
    >>> from squealkit.fe import FEModel
    >>> m = FEModel.from_matrices(M=np.eye(2), K1=np.diag([1.0, 1.2]), KR=[[0.0, 1.0], [-1.0, 0.0]],
    ...                           D1=0.001 * np.eye(2))
    >>> ds = eigen_derivatives(m, {"friction": "KR", "damping": "D1"}, rpm=60.0, mu=0.2)
    >>> ds.sizes["mode"], bool(ds.dgrowth_rate_dp.sel(parameter="damping")[0] < 0)
    (1, True)
    """
    study = resolve_study(model, parameters, rpm, mu, theta, disc_speed=disc_speed, method=method, band=band,
                          n_modes=n_modes, basis=basis)
    modes, solver, index, d = _nominal(study, unstable_only=unstable_only)
    return xr.Dataset(
        {**_mode_variables(study, modes, index, d), "unstable": (("mode",), modes.unstable[index])},
        coords=_study_coords(study, index),
        attrs={
            "kind": "eigen_derivatives",
            "title": "Eigenvalue derivatives with respect to design parameters",
            **_study_attrs(study, modes, solver),
            "reference": "d lambda/dp = -y^H (lambda^2 dM + lambda dC + dK) x / y^H (2 lambda M + C) x "
                         "(Nobari, Ouyang & Bannister, J. Sound Vib. 338, 2015)",
            "squealkit_version": __version__,
        },
    )
