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
from .._validation import InputError, validate_angle, validate_finite, validate_model
from ..fe.model import FEModel, rpm_to_disc_speed
from .parameters import DesignParameter, design_parameters

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


@dataclass(frozen=True)
class _Point:
    """The operating point: disc speed (FE models), friction and run-out slope."""

    rpm: float | None
    disc_speed: float | None
    mu: float
    theta: float
    tan_theta: float

    def attrs(self) -> dict[str, Any]:
        out = {"mu": self.mu, "theta": self.theta, "theta_deg": math.degrees(self.theta), "tan_theta": self.tan_theta}
        if self.rpm is not None:
            out.update(rpm=self.rpm, disc_speed=self.disc_speed)
        return out


def _point(model: Any, rpm: float | None, mu: float | None, theta: float) -> _Point:
    theta = validate_angle("theta", theta)
    t = math.tan(theta)
    if isinstance(model, FEModel):
        if rpm is None:
            raise InputError("An FE model needs a disc speed: rpm=... [rev/min].")
        rpm = validate_finite("rpm", rpm)
        if not rpm > 0:
            raise InputError(f"Parameter rpm={rpm!r} must be > 0 rev/min.")
        mu = model.mu_ref if mu is None else validate_finite("mu", mu)
        return _Point(rpm, float(rpm_to_disc_speed(rpm)), float(mu), theta, t)
    if rpm is not None:
        raise InputError(f"Parameter rpm applies to FE models only; a {model.kind!r} model has no disc speed.")
    if mu is None:
        raise InputError("A small model needs the friction coefficient: mu=...")
    return _Point(None, None, validate_finite("mu", mu), theta, t)


def _pencil(model: Any, pt: _Point) -> tuple[Any, Any, Any]:
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

    def derivatives(self, model: Any, params: Sequence[DesignParameter], pt: _Point, index: Any) -> NDArray:
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


def _fe_solver(model: FEModel, pt: _Point, method: str, band: Any, n_modes: int | None):
    from ..stability.fe_sweep import FESolver

    samples = (np.array([pt.disc_speed]), np.array([pt.mu + pt.tan_theta])) if method == "pod" else None
    return FESolver(model, method, band, n_modes, samples)


def _solve_fe(model: FEModel, pt: _Point, solver: Any, V: NDArray | None = None) -> _Modes:
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


def _solve_small(model: Any, pt: _Point) -> _Modes:
    from ..stability.modes import mode_shapes, modes

    ds = modes(model, pt.mu, pt.theta, damped=True)
    lam = ds.growth_rate.values + 1j * ds.omega.values
    X = mode_shapes(ds).T
    M, C, K = _pencil(model, pt)
    from ..solvers.band import pencil_backward_errors

    return _Modes(lam, X, pencil_backward_errors(M, C, K, lam, X), ds.unstable.values.astype(bool), M, C, K, None,
                  "dense")


def _solve(model: Any, pt: _Point, method: str, band: Any, n_modes: int | None,
           basis: Any = None) -> tuple[_Modes, Any]:
    if isinstance(model, FEModel):
        if basis is not None:
            V = np.asarray(basis, dtype=np.float64)
            if V.ndim != 2 or V.shape[0] != model.n_dof or not np.all(np.isfinite(V)):
                raise InputError(f"Parameter basis must be a finite {model.n_dof} x r matrix, got shape {V.shape}.")
            if method not in ("auto", "modal", "pod") or n_modes is not None:
                raise InputError("With basis=..., method and n_modes do not apply (the basis is the reduction).")
            from types import SimpleNamespace

            from ..solvers.band import validate_band

            solver = SimpleNamespace(method="basis", band=None if band is None else validate_band(band), reduced=None)
            return _solve_fe(model, pt, solver, V=V), solver
        solver = _fe_solver(model, pt, method, band, n_modes)
        return _solve_fe(model, pt, solver), solver
    if basis is not None:
        raise InputError(f"Parameter basis applies to FE models only, not to a {model.kind!r} model.")
    if method != "auto" or band is not None or n_modes is not None:
        raise InputError(f"method, band and n_modes apply to FE models only, not to a {model.kind!r} model.")
    return _solve_small(model, pt), None


def _params(model: Any, parameters: Any) -> tuple[DesignParameter, ...]:
    if isinstance(parameters, DesignParameter):
        parameters = [parameters]
    return design_parameters(parameters, model)


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
        Disc speed [rev/min] (FE models; required there, refused for small models).
    mu : float, optional
        Friction coefficient (FE default: the model's ``mu_ref``; required for small models).
    theta : float, default 0.0
        Run-out incline [rad]; ``mu + tan(theta)`` enters the friction parts.
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
    validate_model(model)
    params = _params(model, parameters)
    pt = _point(model, rpm, mu, theta)
    modes, solver = _solve(model, pt, method, band, n_modes, basis)
    index = np.flatnonzero(modes.unstable) if unstable_only else np.arange(modes.lam.size)
    d = modes.derivatives(model, params, pt, index)
    return _dataset(model, params, pt, modes, index, d, solver)


def _dataset(model: Any, params: Sequence[DesignParameter], pt: _Point, modes: _Modes, index: NDArray, d: NDArray,
             solver: Any) -> xr.Dataset:
    lam = modes.lam[index]
    md, mp = ("mode",), ("mode", "parameter")
    return xr.Dataset(
        {
            "growth_rate": (md, lam.real, {"units": "1/s", "long_name": "growth rate sigma"}),
            "frequency_hz": (md, lam.imag / (2 * math.pi), {"units": "Hz", "long_name": "frequency"}),
            "residual": (md, modes.residual[index], {"long_name": "backward error in the full model"}),
            "unstable": (md, modes.unstable[index]),
            "dgrowth_rate_dp": (mp, d.real, {"units": "1/s per unit of the parameter",
                                             "long_name": "d sigma / d p"}),
            "dfrequency_hz_dp": (mp, d.imag / (2 * math.pi), {"units": "Hz per unit of the parameter",
                                                             "long_name": "d f / d p"}),
        },
        coords={"mode": ("mode", index, {"long_name": "index of the mode in the solve"}), **_parameter_coords(params)},
        attrs={
            "kind": "eigen_derivatives",
            "title": "Eigenvalue derivatives with respect to design parameters",
            **pt.attrs(),
            "method": modes.method,
            "basis_size": 0 if modes.V is None else int(modes.V.shape[1]),
            "band_hz": "all" if solver is None or solver.band is None else list(solver.band),
            "model": model.to_json(), "model_kind": model.kind,
            "design": json.dumps([p.to_dict() for p in params]),
            "reference": "d lambda/dp = -y^H (lambda^2 dM + lambda dC + dK) x / y^H (2 lambda M + C) x "
                         "(Nobari, Ouyang & Bannister, J. Sound Vib. 338, 2015)",
            "squealkit_version": __version__,
        },
    )
