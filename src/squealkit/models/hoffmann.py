"""Hoffmann, Fischer, Allgaier and Gaul's (2002) minimal model of mode-coupling instability.

A point mass on a moving belt, held by two springs inclined to the sliding direction and
pressed on the belt through a contact spring (Mech. Res. Commun. 29 (2002) 197-205).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError
from ._base import FrictionModel, param

__all__ = ["Hoffmann2002"]


@dataclass(frozen=True)
class Hoffmann2002(FrictionModel):
    r"""Hoffmann et al.'s (2002) 2-DOF mass-on-belt model, with run-out slope as in the paper.

    State ``x = [x, y]``: displacement along and normal to the belt [m]. Springs ``k1`` and
    ``k2`` act along unit vectors at angles ``alpha1``, ``alpha2`` from the sliding
    direction; the contact spring ``k3`` carries the normal force ``N = k3 y`` and the
    friction force ``mu N`` acts along x. With a surface slope the friction terms take
    ``mu_e = mu + tan_theta`` exactly as in Lv et al.'s eq. (4).

    The undamped system flutters (mode-coupling) where the discriminant of
    ``m^2 s^4 + m (a + d) s^2 + a d - b (b - mu k3) = 0`` turns negative, i.e. above

    .. math:: \mu_{crit} = \frac{(a - d)^2 + 4 b^2}{4 b k_3}

    with ``a = K11``, ``d = K22`` (k3 included) and ``b = K21`` (see
    :meth:`mu_critical_closed_form`).

    The defaults are illustrative (the structure is Hoffmann's; the values are chosen so
    that the two modes lie close and flutter sets in near mu = 0.22).

    Parameters
    ----------
    m : float, default 1.0
        Mass [kg], > 0.
    k1, k2 : float, default 1.0e6, 0.6e6
        Support springs [N/m], > 0.
    k3 : float, default 0.8e6
        Contact spring [N/m], > 0; the normal force is ``k3 y``.
    alpha1, alpha2 : float, default radians(30), radians(150)
        Angles of ``k1`` and ``k2`` from the sliding direction [rad].
    c : float, default 0.0
        Viscous damping on both DOFs [N s/m], >= 0.
    sliding : {+1, -1}, default +1
        Sliding direction of the belt.
    """

    kind: ClassVar[str] = "hoffmann"
    dof_names: ClassVar[tuple[str, ...]] = ("x", "y")
    dof_descriptions: ClassVar[tuple[str, ...]] = ("along the belt", "normal to the belt")

    m: float = param(1.0, unit="kg", doc="mass")
    k1: float = param(1.0e6, unit="N/m", doc="first support spring")
    k2: float = param(0.6e6, unit="N/m", doc="second support spring")
    k3: float = param(0.8e6, unit="N/m", doc="contact spring (normal force k3 y)")
    alpha1: float = param(math.radians(30.0), unit="rad", doc="angle of k1 from the sliding direction", kind="finite")
    alpha2: float = param(math.radians(150.0), unit="rad", doc="angle of k2 from the sliding direction", kind="finite")
    c: float = param(0.0, unit="N s/m", doc="viscous damping on both DOFs", kind="nonnegative")
    sliding: int = param(1, unit="1", doc="sliding direction, +1 or -1", kind="sign")

    @property
    def sliding_direction(self) -> int:
        return self.sliding

    def _support(self) -> NDArray[np.float64]:
        K = np.zeros((2, 2))
        for k, a in ((self.k1, self.alpha1), (self.k2, self.alpha2)):
            d = np.array([math.cos(a), math.sin(a)])
            K += k * np.outer(d, d)
        return K

    def mass_matrix(self) -> NDArray[np.float64]:
        return self.m * np.eye(2)

    def damping_matrix(self) -> NDArray[np.float64]:
        return self.c * np.eye(2)

    def stiffness_parts(self):
        Kn = np.array([[0.0, 0.0], [0.0, self.k3]])
        Kf = np.array([[0.0, -self.k3], [0.0, 0.0]])
        return self._support(), Kn, Kf

    def load_parts(self):
        return np.zeros(2), np.array([0.0, self.k3]), np.array([-self.k3, 0.0])

    def mu_critical_closed_form(self) -> float:
        """Flutter threshold of the undamped model on a flat belt (tan_theta = 0).

        Returns the smallest ``mu`` (of the model's sliding sense) at which the two
        eigenvalue pairs coalesce; ``inf`` if the supports do not couple the DOFs.
        """
        K0, Kn, _ = self.stiffness_parts()
        a, b, d = K0[0, 0], K0[1, 0], K0[1, 1] + Kn[1, 1]
        if b == 0.0:
            return math.inf
        mu = float(((a - d) ** 2 + 4.0 * b * b) / (4.0 * b * self.k3))
        mu *= self.sliding
        if mu < 0:
            raise InputError(
                "This Hoffmann model flutters only for friction of the other sign; "
                "flip its sliding direction."
            )
        return mu
