"""Sensitivity of the critical friction to the model parameters: exact derivatives at onset.

One :func:`~squealkit.stability.critical_friction` call finds the onset; the derivative
``d mu_crit / d p`` of every parameter then follows from the eigenvectors there, without
solving for the onset again:

- **Hopf onset** (damped): a simple eigenvalue lambda crosses the imaginary axis. Along
  the boundary ``sigma(mu, p) = 0``, so ``d mu_crit / d p = -(d sigma / d p) / (d sigma / d mu)``
  with the eigenvalue derivatives of :func:`~squealkit.stability.eigenvalue_sensitivity`.
- **Mode coupling** (undamped, or C = 0): two eigenvalues coalesce at a double root
  lambda_c, where their derivatives are infinite. ``F = (lambda_1 - lambda_2)^2`` is smooth
  through the coalescence and vanishes on the boundary; near it
  ``F = -8 f_p dp / f_lambda_lambda + ...`` with ``f = det(lambda^2 M + lambda C + K)``, so
  ``d mu_crit / d p = -F_p / F_mu = -f_p / f_mu``, both at lambda_c (the boundary is where
  ``f = f_lambda = 0``; moving along it, ``df = f_p dp + f_mu dmu = 0``). By Jacobi's formula
  ``f_p = c psi0^H Q_p phi0`` with phi0, psi0 the right and left null vectors of
  ``Q(lambda_c)`` and the same c for every parameter, so

      d mu_crit / d p = -(psi0^H Q_p phi0) / (psi0^H Q_mu phi0),   Q_p = lambda_c^2 dM + lambda_c dC + dK,

  exact at the coalescence, with no limit to take. The same formula covers divergence
  (lambda_c = 0, a double root at the origin).

``method="fd"`` keeps the central difference of two more critical-friction searches per
parameter, as a check.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .._threads import honour_thread_limit
from .._validation import InputError, validate_model, validate_positive
from ..models import FrictionModel
from ..models._base import resolve_damped
from ..models.friction import Stribeck
from .critical import CriticalFriction, critical_friction
from .modes import _dlambda, _matrix_derivatives, _parts, _quadratic_eig, _stiffness, _unit_largest

__all__ = ["critical_friction_sensitivity"]

_METHODS = ("exact", "fd")


def _parameter_names(model: FrictionModel, parameters: Sequence[str] | None, damped: bool) -> list[str]:
    info = model.parameter_info()
    if parameters is None:
        return [
            k for k, v in info.items()
            if v["kind"] in ("positive", "nonnegative", "angle", "finite")
            and (damped or not v["unit"].startswith("N s/m"))
        ]
    names = list(parameters)
    for name in names:
        if name not in info:
            raise InputError(f"Unknown parameter {name!r} for model {model.kind!r}.")
    return names


@honour_thread_limit
def critical_friction_sensitivity(
    model: FrictionModel,
    theta: float = 0.0,
    *,
    damped: bool | None = None,
    parameters: Sequence[str] | None = None,
    rel_step: float = 1e-4,
    method: str = "exact",
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> list[dict[str, object]]:
    """Sensitivity of the critical friction to each model parameter.

    The elasticity ``(p / mu_crit) d mu_crit / d p`` is the percent change of mu_crit per
    percent change of p: the parameter with the largest positive elasticity buys the most
    margin when raised. Rows are sorted by ``|elasticity|``.

    Parameters
    ----------
    model : FrictionModel
    theta : float
        Run-out incline [rad].
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping.
    parameters : sequence of str, optional
        Parameter names; default every scalar continuous parameter.
    rel_step : float
        Relative step of ``method="fd"``.
    method : {"exact", "fd"}
        ``"exact"``: derivatives at the onset from its eigenvectors (module notes), one
        critical-friction search in all. ``"fd"``: central differences of two more searches
        per parameter (a parameter whose step leaves its range is skipped).
    friction, speed : Stribeck and float, optional
        Speed-dependent friction and the sliding speed [m/s], as for
        :func:`~squealkit.stability.critical_friction`; with them the derivatives are central
        differences (``"fd"``): the exact formulas cover speed-independent friction.

    Returns
    -------
    list of dict
        ``parameter``, ``value``, ``unit``, ``dmu_dp`` (per unit of p) and ``elasticity``.

    Examples
    --------
    Hoffmann's threshold ``((a - d)^2 + 4 b^2) / (4 b k3)`` (``d`` includes k3) goes as 1/k3
    where a = d, as with the default supports, and does not depend on the mass:

    >>> from squealkit.models import Hoffmann2002
    >>> rows = {r["parameter"]: r for r in critical_friction_sensitivity(Hoffmann2002())}
    >>> round(rows["k3"]["elasticity"], 9), abs(rows["m"]["elasticity"]) < 1e-12
    (-1.0, True)
    """
    validate_model(model)
    damped = resolve_damped(model, damped)
    if method not in _METHODS:
        raise InputError(f"Parameter method={method!r} must be one of {', '.join(map(repr, _METHODS))}.")
    fr = {} if friction is None else {"friction": friction, "speed": speed}
    if fr:
        method = "fd"
    base = critical_friction(model, theta, damped=damped, **fr)
    if base.status != "onset" or not math.isfinite(base.mu_critical):
        raise InputError("The model has no friction onset at this theta; sensitivity is undefined.")
    names = _parameter_names(model, parameters, damped)
    if method == "fd":
        derivs = _fd_derivatives(model, base, names, validate_positive("rel_step", rel_step), fr)
    else:
        derivs = _exact_derivatives(model, base, names)
    info = model.parameter_info()
    rows = []
    for name, d in derivs.items():
        value = float(getattr(model, name))
        rows.append({
            "parameter": name,
            "value": value,
            "unit": info[name]["unit"],
            "dmu_dp": d,
            "elasticity": d * value / base.mu_critical,
        })
    rows.sort(key=lambda r: -abs(float(r["elasticity"])))  # type: ignore[arg-type]
    return rows


def _fd_derivatives(model: FrictionModel, base: CriticalFriction, names: list[str], rel_step: float,
                    fr: dict) -> dict:
    out: dict[str, float] = {}
    for name in names:
        value = float(getattr(model, name))
        h = rel_step * abs(value) if value != 0 else rel_step
        try:
            up = critical_friction(model.replace(**{name: value + h}), base.theta, damped=base.damped, **fr)
            dn = critical_friction(model.replace(**{name: value - h}), base.theta, damped=base.damped, **fr)
        except InputError:
            continue  # a step outside the allowed range (e.g. a zero damping)
        out[name] = (up.mu_critical - dn.mu_critical) / (2 * h)
    return out


def _exact_derivatives(model: FrictionModel, base: CriticalFriction, names: list[str]) -> dict[str, float]:
    t = math.tan(base.theta)
    mu_c = base.mu_critical
    M, C, K0, Kn, Kf = _parts(model, base.damped)
    # the root that grows just above mu_crit, as critical_friction_curve picks the onset mode
    lam_up, _, _ = _quadratic_eig(M, C, _stiffness(model, K0, Kn, Kf, mu_c + 1e-6 * max(1.0, abs(mu_c)), t))
    grow = lam_up[np.argmax(lam_up.real)]
    lam, phi, psi = _quadratic_eig(M, C, _stiffness(model, K0, Kn, Kf, mu_c, t))
    # det Q is even in lambda without damping: eigenvalues leave the imaginary axis only by
    # colliding (mode coupling, or divergence at 0); with damping a simple root crosses it
    if not np.any(C):
        return _coalescence(model, M, C, K0, Kn, Kf, mu_c, t, lam, grow, names)
    return _hopf(model, M, C, K0, Kn, Kf, mu_c, t, lam, phi, psi, grow, names)


def _coalescence(model, M, C, K0, Kn, Kf, mu_c, t, lam, grow, names) -> dict[str, float]:
    """``-(psi0^H Q_p phi0) / (psi0^H Q_mu phi0)`` at the double root (module notes)."""
    pair = np.argsort(np.abs(lam - grow))[:2]
    # the mean of a root cluster is well conditioned; the undamped double root is on the axis
    lam_c = 1j * abs(lam[pair].mean().imag)
    Q = lam_c**2 * M + lam_c * C + _stiffness(model, K0, Kn, Kf, mu_c, t)
    U, _s, Vh = np.linalg.svd(Q)
    phi0, psi0 = Vh[-1].conj(), U[:, -1]

    def along(dM: NDArray, dC: NDArray, dK: NDArray) -> complex:
        return complex(psi0.conj() @ (lam_c**2 * dM + lam_c * dC + dK) @ phi0)

    den = along(*_matrix_derivatives(model, "mu", mu_c, t, False)[:3])
    out = {}
    for name in names:
        num = along(*_matrix_derivatives(model, name, mu_c, t, False)[:3])
        out[name] = -(num / den).real + 0.0  # real: Q(lambda_c) is real on the axis; + 0.0: no -0
    return out


def _hopf(model, M, C, K0, Kn, Kf, mu_c, t, lam, phi, psi, grow, names) -> dict[str, float]:
    """``-(d sigma / d p) / (d sigma / d mu)`` of the crossing root at sigma = 0."""
    k = int(np.argmin(np.abs(lam - grow)))

    def crossing(mu: float, k: int, lam, phi, psi):
        dmu = _matrix_derivatives(model, "mu", mu, t, True)[:3]
        d = _dlambda(M, C, *dmu, lam[k:k + 1], _unit_largest(phi[:, k:k + 1]), _unit_largest(psi[:, k:k + 1]))
        return complex(d[0])

    # mu_crit is where sigma first exceeds 1e-9 |lambda|: one Newton step onto sigma = 0
    mu0 = mu_c - lam[k].real / crossing(mu_c, k, lam, phi, psi).real
    lam, phi, psi = _quadratic_eig(M, C, _stiffness(model, K0, Kn, Kf, mu0, t))
    k = int(np.argmin(np.abs(lam - grow)))
    lam_k, phi_k, psi_k = lam[k:k + 1], _unit_largest(phi[:, k:k + 1]), _unit_largest(psi[:, k:k + 1])
    dsig_dmu = crossing(mu0, k, lam, phi, psi).real
    out = {}
    for name in names:
        dM, dC, dK, _, _ = _matrix_derivatives(model, name, mu0, t, True)
        out[name] = -float(_dlambda(M, C, dM, dC, dK, lam_k, phi_k, psi_k)[0].real) / dsig_dmu + 0.0
    return out
