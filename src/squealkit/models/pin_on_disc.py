"""The 3-DOF pin-on-disc model of Lv, Zhang and Yu (2013), paper section 2.

State vector ``x = [x1, y1, y2]``: the pin's horizontal and vertical displacement and the
disc's vertical displacement [m]. Equations of motion: paper eqs. (1)-(4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ._base import KINEMATICS, FrictionModel, param

__all__ = ["PinOnDisc3DOF"]


@dataclass(frozen=True)
class PinOnDisc3DOF(FrictionModel):
    r"""Pin-on-disc squeal model with disc surface run-out (paper eqs. 1-4).

    The defaults are the paper's rig (preset ``lv2013``): section 3 for masses and
    stiffnesses, section 4 for damping, load and speed.

    Parameters
    ----------
    m1, m2 : float
        Pin and disc modal masses [kg].
    k1, k2, k3 : float
        Pin bending, pin tensile and disc out-of-plane modal stiffnesses [N/m].
    kc : float
        Normal contact stiffness between pin and disc [N/m].
    c1, c2, c3 : float
        Dampers beside k1, k2, k3 [N s/m]. The paper's eigenvalue sweep is undamped.
    alpha : float
        Incline of the pin spring k2 from the vertical [rad] (paper: 2 deg).
    P : float
        Axial load on the pin [N].
    sliding : int
        Sliding direction, +1 or -1. ``+1`` uses eq. (4) exactly as printed; ``-1`` is the
        disc sliding the other way, which reverses the friction force and the slope the
        pin sees, i.e. ``(mu, tan_theta) -> (-mu, -tan_theta)`` in the friction terms. It is
        the mirror image of the rig and gives the same eigenvalues as eq. (4) with
        ``alpha -> -alpha``. With ``alpha = 2 deg`` the printed equations never lose
        stability for ``mu <= 0.8``; the published Fig. 2 (lock-in at 14997-15317 rad/s)
        needs ``sliding = -1``, which is the preset's value.
    kinematics : {"paper", "consistent"}, default "paper"
        Contact kinematics: ``"paper"`` is eq. (2) as printed; ``"consistent"`` (beyond the
        paper) adds the slope the pin sees where it is displaced along the surface, a gap with
        ``tan(theta) x1`` (see :meth:`slope_parts`).

    Notes
    -----
    The stiffness matrix is (eq. 4, with :math:`\mu_e = \mu + \tan\theta`)

    .. math::
        K = \begin{bmatrix}
        k_1 + k_2 s^2 & k_2 cs - k_c\mu_e & k_c\mu_e \\
        k_2 cs & k_2 c^2 + k_c g & -k_c g \\
        0 & -k_c g & k_3 + k_c g \end{bmatrix},\quad g = 1 - \mu\tan\theta.

    Examples
    --------
    >>> model = PinOnDisc3DOF()
    >>> model.stiffness_matrix([0.0, 0.4], 0.0).shape
    (2, 3, 3)
    """

    kind: ClassVar[str] = "pin_on_disc"
    dof_names: ClassVar[tuple[str, ...]] = ("x1", "y1", "y2")
    dof_descriptions: ClassVar[tuple[str, ...]] = ("pin, horizontal", "pin, vertical", "disc, vertical")

    m1: float = param(0.033, unit="kg", doc="pin mass (paper §3)")
    m2: float = param(4.35, unit="kg", doc="disc modal mass (paper §3)")
    k1: float = param(8.545e6, unit="N/m", doc="pin bending stiffness, m1 (2 pi 2561 Hz)^2")
    k2: float = param(9.755e7, unit="N/m", doc="pin tensile stiffness, m1 (2 pi 8653 Hz)^2")
    k3: float = param(9.452e8, unit="N/m", doc="disc stiffness, m2 (2 pi 2346 Hz)^2")
    kc: float = param(4.632e7, unit="N/m", doc="contact stiffness, pin axial E A / L")
    c1: float = param(220.0, unit="N s/m", doc="damper beside k1 (paper §4)", kind="nonnegative")
    c2: float = param(220.0, unit="N s/m", doc="damper beside k2 (paper §4)", kind="nonnegative")
    c3: float = param(220.0, unit="N s/m", doc="damper beside k3 (paper §4)", kind="nonnegative")
    alpha: float = param(math.radians(2.0), unit="rad", doc="pin incline (paper §3: 2 deg)", kind="angle")
    P: float = param(10.0, unit="N", doc="axial load on the pin (paper §4)", kind="nonnegative")
    sliding: int = param(-1, unit="1", doc="sliding direction, +1 as printed, -1 reversed", kind="sign")
    kinematics: str = param("paper", unit="", kind="choice", choices=KINEMATICS,
                            doc="contact kinematics: 'paper' (eq. 2) or 'consistent' (gap with tan(theta) x1)")

    @property
    def sliding_direction(self) -> int:
        return self.sliding

    def mass_matrix(self) -> NDArray[np.float64]:
        return np.diag([self.m1, self.m1, self.m2])

    def damping_matrix(self) -> NDArray[np.float64]:
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        c1, c2, c3 = self.c1, self.c2, self.c3
        return np.array(
            [
                [c1 + c2 * s * s, c2 * c * s, 0.0],
                [c2 * c * s, c2 * c * c, 0.0],
                [0.0, 0.0, c3],
            ]
        )

    def stiffness_parts(self):
        s, c = math.sin(self.alpha), math.cos(self.alpha)
        k1, k2, k3, kc = self.k1, self.k2, self.k3, self.kc
        K0 = np.array(
            [
                [k1 + k2 * s * s, k2 * c * s, 0.0],
                [k2 * c * s, k2 * c * c, 0.0],
                [0.0, 0.0, k3],
            ]
        )
        Kn = kc * np.array([[0.0, 0.0, 0.0], [0.0, 1.0, -1.0], [0.0, -1.0, 1.0]])
        Kf = kc * np.array([[0.0, -1.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
        return K0, Kn, Kf

    def load_parts(self):
        F0 = np.array([0.0, -self.P, 0.0])
        fn = self.kc * np.array([0.0, 1.0, -1.0])
        ff = self.kc * np.array([-1.0, 0.0, 0.0])
        return F0, fn, ff
