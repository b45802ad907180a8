"""Speed-dependent friction and the point contact it acts through.

The paper's friction force is ``mu N`` with a constant ``mu`` (eq. 3). With a Stribeck law
the coefficient depends on the sliding speed ``w`` of the disc past the pin,

    mu(w) = mu + (mu_static - mu) exp(-|w| / v_stribeck),

``mu`` the kinetic value (the law of :class:`squealkit.transient.Contact`). Linearised about
steady sliding at the disc speed ``V``, the friction coefficient is ``mu(V)`` and its slope
``dmu/dv(V)`` turns the friction force into a damping force: with ``w = V - s fhat . x'``
(``s fhat . x'`` is the pin's velocity along the disc's motion),

    F_f = mu(w) N  ->  dF_f = -(dmu/dv) N0 D x',   D = (f - s tan(theta) b) fhat^T,

where ``b`` and ``f`` are the contact's normal and friction directions (Kn = kc b b^T,
Kf = kc f b^T), ``N0`` the static contact force and ``s`` the sliding direction (see
:meth:`~squealkit.models.FrictionModel.friction_damping_matrix`). A falling law
(``dmu/dv < 0``) is negative damping along the sliding direction: a second way to squeal,
beside mode coupling.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import InputError, validate_positive

__all__ = ["Stribeck"]


@dataclass(frozen=True)
class Stribeck:
    """Stribeck friction: ``mu(v) = mu + (mu_static - mu) exp(-|v| / v_stribeck)``.

    ``mu`` is the kinetic coefficient (the friction that a stability sweep or a transient
    run is given); the law adds the static excess ``mu_static - mu`` at low speed. It is
    the law of :class:`squealkit.transient.Contact` (same names, same meaning).

    Parameters
    ----------
    mu_static : float
        Static friction coefficient, >= 0.
    v_stribeck : float
        Stribeck speed [m/s], > 0 (default 1e-2 m/s, as in ``Contact``).

    Examples
    --------
    >>> law = Stribeck(mu_static=0.6, v_stribeck=0.01)
    >>> round(float(law.mu(0.4, 0.01)), 6)            # 0.4 + 0.2 / e
    0.473576
    >>> round(float(law.slope(0.4, 0.01)), 4)         # -(0.2 / 0.01) / e  [s/m]
    -7.3576
    """

    mu_static: float
    v_stribeck: float = 1e-2

    def __post_init__(self) -> None:
        object.__setattr__(self, "mu_static", validate_positive("mu_static", self.mu_static, allow_zero=True))
        object.__setattr__(self, "v_stribeck", validate_positive("v_stribeck", self.v_stribeck))

    def mu(self, mu: ArrayLike, speed: ArrayLike) -> NDArray[np.float64]:
        """Friction coefficient at sliding speed ``speed`` [m/s], for kinetic coefficient(s) ``mu``.

        Parameters
        ----------
        mu : array_like
            Kinetic friction coefficient(s) (the value at high speed).
        speed : array_like
            Sliding speed(s) [m/s]; broadcasts against ``mu``.

        Returns
        -------
        ndarray
            ``mu + (mu_static - mu) exp(-|speed| / v_stribeck)``.
        """
        mu_a = np.asarray(mu, dtype=float)
        return mu_a + (self.mu_static - mu_a) * np.exp(-np.abs(np.asarray(speed, float)) / self.v_stribeck)

    def slope(self, mu: ArrayLike, speed: ArrayLike) -> NDArray[np.float64]:
        """``dmu/dv`` [s/m] at sliding speed ``speed`` > 0 (negative where friction falls with speed).

        Parameters
        ----------
        mu : array_like
            Kinetic friction coefficient(s).
        speed : array_like
            Sliding speed(s) [m/s], > 0; broadcasts against ``mu``.

        Returns
        -------
        ndarray
            ``-(mu_static - mu) / v_stribeck exp(-speed / v_stribeck)`` [s/m].
        """
        mu_a = np.asarray(mu, dtype=float)
        v = np.asarray(speed, float)
        return -np.sign(v) * (self.mu_static - mu_a) / self.v_stribeck * np.exp(-np.abs(v) / self.v_stribeck)

    def flat_at(self, speed: float) -> bool:
        """True when the law is exactly flat at ``speed``: ``exp(-|v| / v_stribeck)`` underflows
        to 0, so ``mu(v) = mu`` and the slope is 0 for every ``mu``.

        Parameters
        ----------
        speed : float
            Sliding speed [m/s].

        Returns
        -------
        bool
        """
        return bool(np.exp(-abs(float(speed)) / self.v_stribeck) == 0.0)

    def describe(self) -> str:
        return f"Stribeck mu_static={self.mu_static:g}, v_stribeck={self.v_stribeck:g} m/s"


@dataclass(frozen=True)
class PointContact:
    """A single point contact: ``Kn = kc b b^T``, ``Kf = kc f b^T``, ``fn = kc b``, ``ff = kc f``.

    Attributes
    ----------
    kc : float
        Contact stiffness [N/m].
    b : ndarray, shape (n,)
        Maps the state to the contact approach: ``b . x - q < 0`` in compression; the static
        contact force is ``N cos(theta) = -kc (b . x - q)`` (paper eq. 2).
    f : ndarray, shape (n,)
        Direction of the friction force on the DOFs (paper eq. 4: b = [0, 1, -1], f = [-1, 0, 0]).
    """

    kc: float
    b: NDArray[np.float64]
    f: NDArray[np.float64]

    @property
    def fhat(self) -> NDArray[np.float64]:
        """Unit friction direction; ``s fhat . x'`` is the contact's velocity along the disc's motion."""
        return self.f / max(float(np.linalg.norm(self.f)), 1e-300)


def point_contact(model) -> PointContact | None:
    """The model's single point contact, or None if its contact terms do not have that form.

    ``kc`` is recovered as ``|fn|^2 / trace(Kn)``; the structure is checked to 1e-9 of the
    largest contact entry.
    """
    _, Kn, Kf = (np.asarray(a, float) for a in model.stiffness_parts())
    _, fn, ff = (np.asarray(a, float) for a in model.load_parts())
    tr = float(np.trace(Kn))
    if tr <= 0 or not np.any(fn):
        return None
    kc = float(fn @ fn) / tr
    b, f = fn / kc, ff / kc
    scale = max(np.abs(Kn).max(), np.abs(Kf).max(), 1e-300)
    ok = np.allclose(Kn, kc * np.outer(b, b), rtol=0, atol=1e-9 * scale) and np.allclose(
        Kf, kc * np.outer(f, b), rtol=0, atol=1e-9 * scale
    )
    return PointContact(kc, b, f) if ok else None


def require_point_contact(model) -> PointContact:
    """:func:`point_contact`, or an InputError saying why a speed-dependent law needs one."""
    pc = point_contact(model)
    if pc is None:
        raise InputError(
            f"Speed-dependent friction needs a model with one point contact (Kn = kc b b^T, Kf = kc f b^T, "
            f"fn = kc b, ff = kc f); this {model.kind!r} model has none. Use constant friction, or give the "
            "contact's fn and ff."
        )
    return pc


def validate_friction(model, friction: Stribeck | None, speed: object) -> tuple[Stribeck | None, float | None]:
    """Check a friction law and sliding speed given to a stability function; returns them.

    ``friction=None`` (constant friction) takes no speed; a law needs ``speed`` > 0 [m/s]
    and a model with one point contact.
    """
    if friction is None:
        if speed is not None:
            raise InputError(f"Parameter speed={speed!r} only matters with a speed-dependent friction law; "
                             "pass friction=Stribeck(...) too, or leave speed out.")
        return None, None
    if not isinstance(friction, Stribeck):
        raise InputError(f"Parameter friction must be a Stribeck law or None; got {type(friction).__name__}.")
    if speed is None:
        raise InputError("A speed-dependent friction law needs the sliding speed: pass speed=V [m/s].")
    v = validate_positive("speed", speed)
    require_point_contact(model)
    return friction, v
