"""The paper's linear equations (eq. 4) as a plain first-order system for SciPy's solvers.

Independent of the compiled kernel: built from the model's public ``stiffness_matrix`` and
``load_vector``. Used by the accuracy tests and the benchmark as the reference.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..models import FrictionModel
from .profiles import SurfaceProfile

__all__ = ["first_order_rhs"]


def first_order_rhs(
    model: FrictionModel, *, mu: float, profile: SurfaceProfile, speed: float, x_start: float = 0.0
) -> Callable[[float, np.ndarray], np.ndarray]:
    """``f(t, z)`` with ``z = [x, x']`` for ``M x'' + C x' + K(mu, t(t)) x = F(mu, t(t), q(t))`` (eq. 4).

    The linear contact of the paper only (no loss of contact, constant friction): a reference for
    :func:`~squealkit.transient.simulate` to be checked against with SciPy's ``solve_ivp``.

    Parameters
    ----------
    model : FrictionModel
        The model: its ``mass_matrix``, ``damping_matrix``, ``stiffness_matrix`` and ``load_vector``.
    mu : float
        Friction coefficient.
    profile : SurfaceProfile
        Disc surface: ``q`` and ``tan(theta)`` at ``x = x_start + speed * t``.
    speed : float
        Sliding speed v [m/s].
    x_start : float, default 0.0
        Position on the profile at t = 0 [m].

    Returns
    -------
    callable
        ``rhs(t, z)`` -> ``dz/dt`` (an array of ``2 n`` for ``n`` DOFs), for ``scipy.integrate.solve_ivp``.
    """
    n = model.n_dof
    Minv = np.linalg.inv(model.mass_matrix())
    C = model.damping_matrix()

    def rhs(t: float, z: np.ndarray) -> np.ndarray:
        q, tan_theta = profile.evaluate(x_start + speed * t)
        K = model.stiffness_matrix(mu, tan_theta)
        F = model.load_vector(mu, tan_theta, q)
        x, v = z[:n], z[n:]
        return np.concatenate([v, Minv @ (F - C @ v - K @ x)])

    return rhs
