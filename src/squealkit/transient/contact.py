"""Contact laws of the transient solver: the paper's linear law and the effects that bound squeal.

The paper (eqs. 1-4) keeps the pin pressed on the disc whatever the motion and the friction
force equal to ``mu N`` in a fixed direction: the equations are linear and an unstable run grows
without bound. A real rig is bounded by

- loss of contact: the normal force cannot pull, ``N >= 0``;
- friction that follows the sign of the relative sliding velocity ``w`` of disc and pin,
  regularised as ``mu tanh(w / v_reg)`` (``v_reg`` [m/s] sets the width of the
  stick band; smaller is closer to Coulomb's law but stiffer to integrate);
- friction that depends on speed (Stribeck): ``mu(w) = mu + (mu_static - mu) exp(-|w| / v_stribeck)``
  with ``mu`` the kinetic value; falling friction with speed adds negative damping.

With them an unstable run settles on a limit cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validation import InputError, validate_positive
from ..models.friction import Stribeck, point_contact

__all__ = ["Contact"]


@dataclass(frozen=True)
class Contact:
    """Which nonlinear contact effects the transient solver includes.

    Parameters
    ----------
    separation : bool
        Loss of contact: the normal force is clamped at ``N >= 0``.
    sign_friction : bool
        Friction follows the sign of the sliding velocity, ``mu tanh(w / v_reg)``.
    v_reg : float
        Regularisation speed [m/s] of the sign law (default 1e-3 m/s, 5 % of the paper's v).
    mu_static : float or None
        Static friction coefficient of the Stribeck law; ``None`` for speed-independent friction.
    v_stribeck : float
        Stribeck speed [m/s].

    Examples
    --------
    >>> Contact().is_linear, Contact.nonlinear().is_linear
    (True, False)
    """

    separation: bool = False
    sign_friction: bool = False
    v_reg: float = 1e-3
    mu_static: float | None = None
    v_stribeck: float = 1e-2

    def __post_init__(self) -> None:
        object.__setattr__(self, "v_reg", validate_positive("v_reg", self.v_reg))
        object.__setattr__(self, "v_stribeck", validate_positive("v_stribeck", self.v_stribeck))
        if self.mu_static is not None:
            object.__setattr__(self, "mu_static", validate_positive("mu_static", self.mu_static, allow_zero=True))

    @classmethod
    def linear(cls) -> Contact:
        """The paper's law: permanent contact, friction mu N in a fixed direction (eqs. 2-3)."""
        return cls()

    @classmethod
    def nonlinear(cls, *, v_reg: float = 1e-3, mu_static: float | None = None, v_stribeck: float = 1e-2) -> Contact:
        """Loss of contact and velocity-sign friction (and Stribeck friction if ``mu_static`` is given).

        Parameters
        ----------
        v_reg : float, default 1e-3
            Regularisation speed [m/s] of the sign law ``mu tanh(w / v_reg)``.
        mu_static : float, optional
            Static friction coefficient of a Stribeck law (default: speed-independent friction).
        v_stribeck : float, default 1e-2
            Stribeck speed [m/s].

        Returns
        -------
        Contact
        """
        return cls(True, True, v_reg, mu_static, v_stribeck)

    @property
    def is_linear(self) -> bool:
        return not (self.separation or self.sign_friction or self.mu_static is not None)

    @property
    def friction_law(self) -> Stribeck | None:
        """The Stribeck law (for :func:`squealkit.stability.eigenvalues`), or None for constant mu."""
        return None if self.mu_static is None else Stribeck(self.mu_static, self.v_stribeck)

    def sliding_mu(self, mu: float, speed: float) -> float:
        """Friction coefficient in steady sliding at ``speed`` [m/s]: ``mu(speed) tanh(speed / v_reg)``
        with the Stribeck and sign laws this contact includes (``mu`` with neither).

        Parameters
        ----------
        mu : float
            Kinetic friction coefficient.
        speed : float
            Sliding speed [m/s].

        Returns
        -------
        float
        """
        out = float(mu) if self.mu_static is None else float(self.friction_law.mu(mu, speed))
        return out * math.tanh(speed / self.v_reg) if self.sign_friction else out

    def describe(self) -> str:
        if self.is_linear:
            return "linear (paper eqs. 1-4)"
        parts = []
        if self.separation:
            parts.append("loss of contact N>=0")
        if self.sign_friction:
            parts.append(f"friction mu tanh(w/v_reg), v_reg={self.v_reg:g} m/s")
        if self.mu_static is not None:
            parts.append(f"Stribeck mu_static={self.mu_static:g}, v_stribeck={self.v_stribeck:g} m/s")
        return "; ".join(parts)

    def options(self) -> np.ndarray:
        """The kernel's flag vector (see :mod:`squealkit.solvers.ode`)."""
        return np.array(
            [
                0.0 if self.is_linear else 1.0,
                float(self.separation),
                float(self.sign_friction),
                float(self.mu_static is not None),
                self.v_reg,
                0.0 if self.mu_static is None else self.mu_static,
                self.v_stribeck,
            ]
        )


def as_contact(contact: Contact | str) -> Contact:
    """Accept a :class:`Contact` or the names ``"linear"`` / ``"nonlinear"``."""
    if isinstance(contact, Contact):
        return contact
    if contact == "linear":
        return Contact.linear()
    if contact == "nonlinear":
        return Contact.nonlinear()
    raise InputError(f"Parameter contact={contact!r} must be 'linear', 'nonlinear' or a Contact.")


def contact_geometry(model) -> tuple[bool, float, np.ndarray, np.ndarray]:
    """Single point contact of a model: ``(ok, kc, b, f)`` with Kn = kc b b^T, Kf = kc f b^T.

    ``b`` maps the state to the contact approach (``b.x - q`` < 0 in compression) and ``f``
    is the direction of the friction force; fn = kc b and ff = kc f (paper eq. 4 has
    b = [0, 1, -1], f = [-1, 0, 0]). ``ok`` is False when the model's contact terms do not
    have this structure (then only the linear law is available).
    """
    pc = point_contact(model)
    if pc is None:
        n = model.n_dof
        return False, 0.0, np.zeros(n), np.zeros(n)
    return True, pc.kc, pc.b, pc.f
