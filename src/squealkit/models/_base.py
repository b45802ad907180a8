"""The model abstraction: linear friction-coupled systems.

Every squealkit model is a frozen dataclass describing

    M x'' + C x' + K(mu, tan_theta) x = F(mu, tan_theta, q)

where the stiffness matrix and the load split into a structural part, a part carried by
the normal contact force and a part carried by the friction force (paper, eq. 4):

    K = K0 + (1 - mu tan_theta) Kn + s (mu + tan_theta) Kf
    F = F0 + q [(1 - mu tan_theta) fn + s (mu + tan_theta) ff]

``s`` is the sliding direction (+1 or -1). ``mu + tan_theta`` is the paper's equivalent
friction coefficient mu_e (eqs. 5-6). Matrices are computed for whole grids at once:
``mu`` and ``tan_theta`` broadcast, and ``stiffness_matrix`` returns shape ``(..., n, n)``.

Consistent contact kinematics (option ``kinematics = "consistent"``, beyond the paper) adds
the parts ``(Knx, Kfx)`` of :meth:`FrictionModel.slope_parts` that grow with the slope::

    K = K0 + g (Kn + s t Knx) + e (Kf + s t Kfx),   g = 1 - mu t, e = s (mu + t), t = tan_theta

so at a fixed slope the model still has the three-part form, with the contact parts
:meth:`FrictionModel.contact_parts` ``(Kn(t), Kf(t))``. The load is unchanged.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import (
    InputError,
    register_model_type,
    validate_angle,
    validate_finite,
    validate_positive,
    validate_sign,
)
from .friction import Stribeck, require_point_contact

__all__ = ["KINEMATICS", "FrictionModel", "SystemMatrices", "param"]

#: What an analysis says when it leaves a model's damping out because ``damped`` was not given.
_DAMPING_LEFT_OUT = ("The model's damping ({names}) is left out: the analysis is undamped unless asked "
                     "(paper eq. 7). Pass damped=True to include it, or damped=False to leave it out "
                     "without this warning.")

#: Kinds of scalar parameter and the validator that checks each.
_KINDS = {
    "positive": lambda n, v: validate_positive(n, v),
    "nonnegative": lambda n, v: validate_positive(n, v, allow_zero=True),
    "angle": validate_angle,
    "finite": validate_finite,
    "sign": validate_sign,
}

#: Contact kinematics a model may be built with (see :meth:`FrictionModel.slope_parts`).
KINEMATICS = ("paper", "consistent")


def validate_choice(name: str, value: object, choices: tuple[str, ...]) -> str:
    """Return ``value`` if it is one of ``choices`` (strings); anything else is rejected."""
    if not isinstance(value, str) or value not in choices:
        accepted = ", ".join(repr(c) for c in choices)
        raise InputError(f"Parameter {name}={value!r} must be one of {accepted}.")
    return value


def param(default: Any, *, unit: str, doc: str, kind: str = "positive",
          choices: tuple[str, ...] = (), plausible: tuple[float, float] | None = None) -> Any:
    """Declare a model parameter: a dataclass field with its unit, meaning and check.

    ``kind="choice"`` declares an option, one of the strings ``choices`` (e.g. the contact
    kinematics); it has no unit, no derivative and is not sampled.

    The declared ``unit`` is the SI unit the value is held in; a value given as text with its
    own unit (``"25 mm"``, ``"2.9 kHz"``) is converted to it on construction. ``plausible``
    ``(lo, hi)`` is the range of ``|value|`` a real one has: outside it, a bare number that a
    common unit slip (mm written as m, kHz as Hz) would bring inside is refused naming the slip,
    and any other value warns (see :mod:`squealkit._units`).
    """
    if kind not in _KINDS and kind not in ("array", "choice"):
        raise ValueError(f"unknown parameter kind {kind!r}")
    if (kind == "choice") != bool(choices) or (choices and default not in choices):
        raise ValueError(f"parameter kind {kind!r} with choices {choices!r} and default {default!r}")
    meta: dict[str, Any] = {"unit": unit, "doc": doc, "kind": kind}
    if choices:
        meta["choices"] = tuple(choices)
    if plausible is not None:
        meta["plausible"] = (float(plausible[0]), float(plausible[1]))
    return field(default=default, metadata=meta)


def declared_value(f: dataclasses.Field, value: Any, *, what: str = "") -> Any:
    """``value`` of the numeric field ``f`` in its declared unit: text with a unit converted, and a
    value outside the declared ``plausible`` range refused (a unit slip) or warned about.

    Other values (arrays, choices, None) come back as they are, for the field's own check.
    """
    from .._units import check_plausible, parse_quantity

    meta = f.metadata
    if meta.get("kind") not in _KINDS or value is None:
        return value
    doc = f"{what}{meta['doc']}"
    if isinstance(value, str):
        return parse_quantity(f.name, value, meta["unit"], plausible=meta.get("plausible"), what=doc)
    if "plausible" in meta and isinstance(value, int | float | np.floating | np.integer) \
            and not isinstance(value, bool) and math.isfinite(value):
        check_plausible(f.name, float(value), meta["unit"], meta["plausible"], what=doc)
    return value


def parameter_info(cls: Any) -> dict[str, dict[str, str]]:
    """Unit, meaning and kind of each field of ``cls`` declared with :func:`param`, in declaration order."""
    return {
        f.name: {"unit": f.metadata["unit"], "doc": f.metadata["doc"], "kind": f.metadata["kind"]}
        for f in dataclasses.fields(cls)
        if "unit" in f.metadata
    }


@dataclass(frozen=True)
class SystemMatrices:
    """Mass, damping and stiffness matrices of a model at given friction and slope.

    Attributes
    ----------
    M, C : ndarray, shape (n, n)
        Mass [kg] and damping [N s/m] matrices (constant).
    K : ndarray, shape (..., n, n)
        Stiffness matrix [N/m], one per grid point.
    """

    M: NDArray[np.float64]
    C: NDArray[np.float64]
    K: NDArray[np.float64]


@dataclass(frozen=True)
class FrictionModel(ABC):
    """Base of all linear friction-coupled models.

    Subclasses are frozen dataclasses whose fields are declared with :func:`param`;
    every field is validated on construction, so an instance is always physical.
    """

    #: Short name used in files and reports.
    kind: ClassVar[str] = "abstract"
    #: Names of the degrees of freedom, in the order of the state vector.
    dof_names: ClassVar[tuple[str, ...]] = ()
    #: What each degree of freedom is, in words (for figures and reports; may be empty).
    dof_descriptions: ClassVar[tuple[str, ...]] = ()

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            kind = f.metadata.get("kind")
            if kind in _KINDS:
                value = _KINDS[kind](f.name, declared_value(f, getattr(self, f.name), what="the "))
                object.__setattr__(self, f.name, value)
            elif kind == "choice":
                validate_choice(f.name, getattr(self, f.name), f.metadata["choices"])
        self._check_mass_matrix()

    def _check_mass_matrix(self) -> None:
        M = self.mass_matrix()
        if not np.allclose(M, M.T, rtol=1e-12, atol=0.0):
            raise InputError("The mass matrix M must be symmetric.")
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            raise InputError("The mass matrix M must be positive definite.") from None

    # -- what a subclass supplies ------------------------------------------------------
    @abstractmethod
    def mass_matrix(self) -> NDArray[np.float64]:
        """Mass matrix M [kg], shape (n, n)."""

    @abstractmethod
    def damping_matrix(self) -> NDArray[np.float64]:
        """Damping matrix C [N s/m], shape (n, n)."""

    @abstractmethod
    def stiffness_parts(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Structural, normal-contact and friction parts ``(K0, Kn, Kf)`` of K [N/m]."""

    @abstractmethod
    def load_parts(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Constant load F0 [N] and the run-out load vectors ``(fn, ff)`` [N/m]."""

    @property
    def sliding_direction(self) -> int:
        """+1 for the equations as printed, -1 for the disc sliding the other way."""
        return 1

    @property
    def kinematics_option(self) -> str:
        """``"paper"`` (eq. 2 as printed) or ``"consistent"``; see :meth:`slope_parts`."""
        return str(getattr(self, "kinematics", "paper"))

    def slope_parts(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        r"""Parts ``(Knx, Kfx)`` [N/m] of K that grow with the slope: zero for the paper's kinematics.

        The paper's gap (eq. 2) is ``delta = b.x - q``: the run-out is taken at the rest
        position of the contact. But the contact point moves with the pin along the inclined
        surface, ``q(v t + x1) ~ q(v t) + tan(theta) x1``; with consistent kinematics the gap
        is ``delta = b_t.x - q`` with ``b_t = b + s t fhat`` (``fhat`` the unit friction
        direction, -x1 for the pin-on-disc, ``t = tan(theta)``, ``s`` the sliding direction).

        *Derivation.* The normal force of eq. (2) is the gradient of the contact potential
        ``V = kc delta^2 / 2``: its components ``-N sin(theta)`` on x1, ``N cos(theta)`` on y1
        and ``-N cos(theta)`` on y2 with ``N = -kc delta / cos(theta)`` are exactly
        ``-dV/dx = -kc delta b_t`` (the paper keeps them and drops only the x1 term of the gap).
        Coulomb friction ``F_f = mu N`` acts along the surface's tangent, on the DOFs
        ``-kc delta s mu (f - s t b)`` (eq. 1). The contact force is then
        ``-kc delta u`` with ``u = g b + e f`` (``g = 1 - mu t``, ``e = s (mu + t)``), and

        .. math:: K_c = k_c\, u\, b_t^T = g K_n + e K_f + s t (g K_{nx} + e K_{fx}),
                  \quad K_{nx} = k_c\, b\, \hat f^T,\ K_{fx} = k_c\, f\, \hat f^T.

        At ``mu = 0``, ``u = b_t`` and ``K_c = kc b_t b_t^T`` is symmetric: the frictionless
        contact is conservative for any slope (the paper's ``kc u b^T`` is not: at
        ``tan(theta) = 0.5`` and ``mu = 0`` it flutters). With ``u = b_t + s mu w``,
        ``w = f - s t b``, the skew part is ``s mu kc (w b_t^T - b_t w^T) / 2``; for the
        pin-on-disc its Frobenius norm is ``mu kc (1 + t^2)``: friction alone, grown by the
        slope only through ``1 + tan^2(theta)``. The load ``q kc u`` is the paper's.

        Returns
        -------
        Knx, Kfx : ndarray, shape (n, n)

        Examples
        --------
        >>> from squealkit.models import PinOnDisc3DOF
        >>> m = PinOnDisc3DOF(kinematics="consistent")
        >>> K = m.stiffness_matrix(0.0, 0.5)
        >>> bool(np.allclose(K, K.T))
        True
        """
        n = self.n_dof
        if self.kinematics_option == "paper":
            return np.zeros((n, n)), np.zeros((n, n))
        pc = require_point_contact(self)
        return pc.kc * np.outer(pc.b, pc.fhat), pc.kc * np.outer(pc.f, pc.fhat)

    @property
    def slope_coupled(self) -> bool:
        """True when the contact parts depend on the slope (consistent kinematics)."""
        Knx, Kfx = self.slope_parts()
        return bool(np.any(Knx) or np.any(Kfx))

    def contact_parts(self, tan_theta: ArrayLike = 0.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Contact parts ``(Kn(t), Kf(t)) = (Kn + s t Knx, Kf + s t Kfx)`` [N/m] at slope(s) t.

        ``K = K0 + (1 - mu t) Kn(t) + s (mu + t) Kf(t)``; the paper's kinematics give the
        constant ``Kn``, ``Kf``.

        Parameters
        ----------
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.

        Returns
        -------
        Kn, Kf : ndarray, shape ``tan_theta.shape + (n, n)``
        """
        t = np.asarray(tan_theta, float)[..., None, None]
        _, Kn, Kf = (np.asarray(a, float) for a in self.stiffness_parts())
        Knx, Kfx = self.slope_parts()
        st = self.sliding_direction * t
        return Kn + st * Knx, Kf + st * Kfx

    def contact_normal(self, tan_theta: ArrayLike = 0.0) -> NDArray[np.float64]:
        """The gap's direction ``b_t`` [1]: ``delta = b_t . x - q`` (``b`` for the paper's kinematics).

        Raises InputError without a single point contact.

        Parameters
        ----------
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.

        Returns
        -------
        ndarray, shape ``tan_theta.shape + (n,)``
        """
        pc = require_point_contact(self)
        t = np.asarray(tan_theta, float)[..., None]
        if self.kinematics_option == "paper":
            return pc.b + 0.0 * t
        return pc.b + self.sliding_direction * t * pc.fhat

    # -- derived -----------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom n."""
        return len(self.dof_names)

    def stiffness_matrix(self, mu: ArrayLike, tan_theta: ArrayLike = 0.0) -> NDArray[np.float64]:
        """Stiffness matrix K(mu, tan_theta) [N/m] (paper, eq. 4).

        Parameters
        ----------
        mu : array_like
            Friction coefficient(s).
        tan_theta : array_like
            Slope(s) of the disc surface, tan(theta); broadcasts against ``mu``.

        Returns
        -------
        ndarray, shape ``broadcast(mu, tan_theta).shape + (n, n)``
        """
        mu_a, t_a = np.broadcast_arrays(np.asarray(mu, float), np.asarray(tan_theta, float))
        K0 = np.asarray(self.stiffness_parts()[0], float)
        Kn, Kf = self.contact_parts(t_a)
        g = (1.0 - mu_a * t_a)[..., None, None]
        e = (self.sliding_direction * (mu_a + t_a))[..., None, None]
        return K0 + g * Kn + e * Kf

    def load_vector(
        self, mu: ArrayLike, tan_theta: ArrayLike = 0.0, q: ArrayLike = 0.0
    ) -> NDArray[np.float64]:
        """Load vector F(mu, tan_theta, q) [N] (paper, eq. 4).

        Parameters
        ----------
        mu : array_like
            Friction coefficient(s).
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.
        q : array_like, default 0.0
            Height of the disc surface under the contact [m]; the three broadcast.

        Returns
        -------
        ndarray, shape ``broadcast(mu, tan_theta, q).shape + (n,)``
        """
        mu_a, t_a, q_a = np.broadcast_arrays(
            np.asarray(mu, float), np.asarray(tan_theta, float), np.asarray(q, float)
        )
        F0, fn, ff = self.load_parts()
        g = (1.0 - mu_a * t_a)[..., None]
        e = (self.sliding_direction * (mu_a + t_a))[..., None]
        return F0 + q_a[..., None] * (g * fn + e * ff)

    def matrices(self, mu: ArrayLike, tan_theta: ArrayLike = 0.0) -> SystemMatrices:
        """All three matrices at once; ``K`` has one matrix per grid point.

        Parameters
        ----------
        mu : array_like
            Friction coefficient(s).
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.

        Returns
        -------
        SystemMatrices
            ``M`` [kg] and ``C`` [N s/m] of shape (n, n), ``K`` [N/m] as :meth:`stiffness_matrix`.
        """
        return SystemMatrices(
            self.mass_matrix(), self.damping_matrix(), self.stiffness_matrix(mu, tan_theta)
        )

    def static_equilibrium(
        self, mu: float = 0.0, tan_theta: float = 0.0, q: float = 0.0
    ) -> NDArray[np.float64]:
        """Static deflection x solving K(mu, tan_theta) x = F(mu, tan_theta, q) [m].

        Parameters
        ----------
        mu : float, default 0.0
            Friction coefficient.
        tan_theta : float, default 0.0
            Slope ``tan(theta)`` [1] of the disc surface.
        q : float, default 0.0
            Height of the disc surface under the contact [m].

        Returns
        -------
        ndarray, shape (n,)
            The displacements [m].
        """
        K = self.stiffness_matrix(mu, tan_theta)
        F = self.load_vector(mu, tan_theta, q)
        return np.linalg.solve(K, F)

    # -- speed-dependent friction (see models/friction.py) -------------------------------
    def static_contact_force(
        self, mu: ArrayLike, tan_theta: ArrayLike = 0.0, q: ArrayLike = 0.0
    ) -> NDArray[np.float64]:
        """Contact force ``N cos(theta) = -kc (b . x - q)`` [N] in the static equilibrium (eq. 2).

        ``x`` solves ``K(mu, tan_theta) x = F(mu, tan_theta, q)``; the arguments broadcast.
        This is the force that multiplies the friction terms of eq. (4).

        Parameters
        ----------
        mu : array_like
            Friction coefficient(s).
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.
        q : array_like, default 0.0
            Height of the disc surface under the contact [m]; the three broadcast.

        Returns
        -------
        ndarray, shape ``broadcast(mu, tan_theta, q).shape``
            The contact force [N] (positive: pressing).

        Raises
        ------
        InputError
            If the model has no single point contact (see :func:`~squealkit.models.friction.point_contact`).

        Examples
        --------
        >>> from squealkit.models import get_preset
        >>> round(float(get_preset("lv2013").static_contact_force(0.0)), 4)   # of P = 10 N
        3.1484
        """
        pc = require_point_contact(self)
        mu_a, t_a, q_a = np.broadcast_arrays(
            np.asarray(mu, float), np.asarray(tan_theta, float), np.asarray(q, float)
        )
        K = self.stiffness_matrix(mu_a, t_a)
        F = self.load_vector(mu_a, t_a, q_a)
        x = np.linalg.solve(K, F[..., None])[..., 0]
        return -pc.kc * (np.sum(x * self.contact_normal(t_a), axis=-1) - q_a)

    def friction_damping_matrix(self, tan_theta: ArrayLike = 0.0) -> NDArray[np.float64]:
        """Direction matrix D [1] of the friction force's velocity dependence.

        With a speed-dependent friction coefficient ``mu(w)`` and the sliding speed
        ``w = V - s fhat . x'``, the friction force of eq. (4) linearised about steady sliding
        changes by ``-(dmu/dv) N0 D x'`` with ``D = (f - s tan_theta b) fhat^T``, ``N0`` the
        :meth:`static_contact_force`. (The friction force is ``N0 mu s f`` and the slope's
        share ``-N0 mu tan_theta b``, eq. 4; ``s fhat . x'`` is the contact's velocity along
        the disc's motion.)

        Parameters
        ----------
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.

        Returns
        -------
        ndarray, shape ``tan_theta.shape + (n, n)``

        Raises
        ------
        InputError
            If the model has no single point contact: the law is undefined for it.

        Examples
        --------
        >>> from squealkit.models import get_preset
        >>> get_preset("lv2013").friction_damping_matrix(0.0)[0].tolist()   # along x1 only
        [1.0, 0.0, 0.0]
        """
        pc = require_point_contact(self)
        t = np.asarray(tan_theta, float)[..., None]
        u = pc.f - self.sliding_direction * t * pc.b
        return u[..., :, None] * pc.fhat[None, :] + 0.0  # + 0.0: no signed zeros

    def friction_damping(
        self, law: Stribeck, mu: ArrayLike, tan_theta: ArrayLike = 0.0, *, speed: float
    ) -> NDArray[np.float64]:
        """Damping matrix ``dmu/dv(speed) N0 D`` [N s/m] of linearised speed-dependent friction.

        ``mu`` is the kinetic coefficient; ``N0`` is the static contact force at the
        coefficient ``law.mu(mu, speed)`` the contact has while sliding at ``speed`` [m/s]
        (on the mean surface, q = 0), ``D`` the :meth:`friction_damping_matrix`. Add it to C.

        Parameters
        ----------
        law : Stribeck
            The speed-dependent friction law.
        mu : array_like
            Kinetic friction coefficient(s).
        tan_theta : array_like, default 0.0
            Slope(s) ``tan(theta)`` [1] of the disc surface.
        speed : float
            Sliding speed [m/s] the law is linearised at.

        Returns
        -------
        ndarray, shape ``broadcast(mu, tan_theta).shape + (n, n)``

        Examples
        --------
        >>> from squealkit.models import get_preset
        >>> from squealkit.models.friction import Stribeck
        >>> Cf = get_preset("lv2013").friction_damping(Stribeck(0.6, 0.01), 0.4, speed=0.02)
        >>> round(float(Cf[0, 0]), 3)    # -(0.2 / 0.01) exp(-2) N0: negative damping on x1
        -8.997
        """
        mu_a, t_a = np.broadcast_arrays(np.asarray(mu, float), np.asarray(tan_theta, float))
        n0 = self.static_contact_force(law.mu(mu_a, speed), t_a)
        return (law.slope(mu_a, speed) * n0)[..., None, None] * self.friction_damping_matrix(t_a) + 0.0

    # -- parameters --------------------------------------------------------------------
    @classmethod
    def parameter_info(cls) -> dict[str, dict[str, str]]:
        """Each parameter's unit, meaning and kind, in declaration order."""
        return parameter_info(cls)

    def parameters(self) -> dict[str, Any]:
        """Parameter values in SI units (angles in radians), as plain Python objects."""
        out: dict[str, Any] = {}
        for name in self.parameter_info():
            v = getattr(self, name)
            out[name] = v.tolist() if isinstance(v, np.ndarray) else v
        return out

    def replace(self, **changes: Any) -> FrictionModel:
        """A new model with some parameters changed (validated); ``*_deg`` names accepted.

        Parameters
        ----------
        **changes
            ``name=value`` in SI units, or ``name_deg=value`` in degrees for an angle.

        Returns
        -------
        FrictionModel
            A new model of the same kind (this one is unchanged).

        Examples
        --------
        >>> from squealkit.models import PinOnDisc3DOF
        >>> PinOnDisc3DOF().replace(c1=0.0, alpha_deg=3.0).alpha  # doctest: +ELLIPSIS
        0.05235...
        """
        info = self.parameter_info()
        resolved: dict[str, Any] = {}
        for key, value in changes.items():
            name = key
            if key not in info and key.endswith("_deg") and info.get(key[:-4], {}).get("kind") == "angle":
                from .._units import parse_quantity

                name = key[:-4]
                value = math.radians(validate_finite(key, parse_quantity(key, value, "deg")))
            if name not in info:
                known = ", ".join(sorted(info))
                raise InputError(f"Unknown parameter {key!r} for model {self.kind!r}; known: {known}.")
            resolved[name] = value
        return dataclasses.replace(self, **resolved)

    def to_dict(self) -> dict[str, Any]:
        """``{"kind": ..., "parameters": {...}}``, enough to rebuild the model."""
        return {"kind": self.kind, "parameters": self.parameters()}

    def to_json(self) -> str:
        """The model as a JSON string (stored in result attributes)."""
        return json.dumps(self.to_dict(), sort_keys=True)

    def undamped(self) -> FrictionModel:
        """The same model with its damping matrix set to zero (paper, eq. 7)."""
        info = self.parameter_info()
        zeros = {
            k: (np.zeros_like(getattr(self, k)) if v["kind"] == "array" else 0.0)
            for k, v in info.items()
            if v["unit"].startswith("N s/m")
        }
        return self.replace(**zeros)


def damping_names(model: Any) -> str:
    """The model's nonzero damping parameters, e.g. ``"c1=220, c2=220"`` ("" when it has none).

    A model whose damping is not a parameter (a matrix model) says ``"C"`` when C is not zero.
    """
    if not isinstance(model, FrictionModel):
        return ""
    named = [f"{k}={getattr(model, k):g}" for k, v in model.parameter_info().items()
             if v["unit"].startswith("N s/m") and v["kind"] != "array" and getattr(model, k) != 0]
    if named:
        return ", ".join(named)
    return "C" if np.any(model.damping_matrix()) else ""


def resolve_damped(model: Any, damped: bool | None, *, stacklevel: int = 3) -> bool:
    """``damped`` of an analysis: as given, and False when not given (None), with a warning then
    if the model has damping, so that no damping is left out without a word."""
    if damped is not None:
        return bool(damped)
    names = damping_names(model)
    if names:
        warnings.warn(_DAMPING_LEFT_OUT.format(names=names), UserWarning, stacklevel=stacklevel)
    return False


register_model_type("friction", FrictionModel)  # validate_model knows it without importing models/
