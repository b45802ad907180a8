"""The arguments every design study shares, resolved and validated once.

:func:`~squealkit.design.eigen_derivatives`, :func:`~squealkit.design.countermeasures`,
:func:`~squealkit.design.doe_sweep` and :func:`~squealkit.design.robust_margins` all take a model,
an operating point (``rpm`` or ``disc_speed``, ``mu``, ``theta``) and, for an FE model, how to
solve it (``method``, ``band``, ``n_modes``, ``basis``). :func:`operating_point` and
:func:`resolve_study` turn them into one frozen value each, with one message per wrong input, so
the studies cannot drift apart in what they accept.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import InputError, validate_angle, validate_finite, validate_int, validate_model
from ..fe.model import FEModel, rpm_to_disc_speed
from .parameters import DesignParameter, design_parameters


@dataclass(frozen=True)
class OperatingPoint:
    """The operating point: disc speed (FE models; None for a small model), friction and run-out slope."""

    rpm: float | None
    disc_speed: float | None
    mu: float
    theta: float
    tan_theta: float

    @property
    def mu_e(self) -> float:
        """The effective friction ``mu + tan(theta)`` (paper eq. 6)."""
        return self.mu + self.tan_theta

    def attrs(self) -> dict[str, Any]:
        out = {"mu": self.mu, "theta": self.theta, "theta_deg": math.degrees(self.theta), "tan_theta": self.tan_theta}
        if self.rpm is not None:
            out.update(rpm=self.rpm, disc_speed=self.disc_speed)
        return out


def operating_point(model: Any, rpm: float | None = None, mu: float | None = None, theta: float = 0.0, *,
                    disc_speed: float | None = None) -> OperatingPoint:
    """The validated operating point of ``model``.

    An FE model needs its disc speed, as ``rpm`` [rev/min] or ``disc_speed`` [rad/s] (exactly one,
    >= 0; 0 only without a ``DR`` part, which is scaled by the inverse speed), and takes ``mu``
    from its ``mu_ref`` when not given; a small model has no disc speed and needs ``mu``.
    """
    theta = validate_angle("theta", theta)
    t = math.tan(theta)
    if not isinstance(model, FEModel):
        if rpm is not None or disc_speed is not None:
            name = "rpm" if rpm is not None else "disc_speed"
            raise InputError(f"Parameter {name} applies to FE models only; a {model.kind!r} model has no disc speed.")
        if mu is None:
            raise InputError("A small model needs the friction coefficient: mu=...")
        return OperatingPoint(None, None, validate_finite("mu", mu), theta, t)
    if (rpm is None) == (disc_speed is None):
        raise InputError("An FE model needs a disc speed: give rpm= [rev/min] or disc_speed= [rad/s], not both.")
    if rpm is not None:
        rpm = validate_finite("rpm", rpm)
        speed = float(rpm_to_disc_speed(rpm))
        name, value, unit = "rpm", rpm, "rev/min"
    else:
        speed = validate_finite("disc_speed", disc_speed)
        rpm = speed * 60.0 / (2 * math.pi)
        name, value, unit = "disc_speed", speed, "rad/s"
    if speed < 0.0 or (speed == 0.0 and model.DR is not None):
        need = "> 0 (the model's DR part is scaled by the inverse disc speed)" if model.DR is not None else ">= 0"
        raise InputError(f"Parameter {name}={value!r} {unit} must be {need}.")
    mu = float(model.mu_ref) if mu is None else validate_finite("mu", mu)
    return OperatingPoint(float(rpm), speed, mu, theta, t)


@dataclass(frozen=True)
class Study:
    """A validated study: the model, its design parameters, the operating point and how to solve an FE model
    (``method``; ``band`` [Hz] or None; ``n_modes``; ``basis`` (n, r) or None)."""

    model: Any
    params: tuple[DesignParameter, ...]
    point: OperatingPoint
    method: str
    band: tuple[float, float] | None
    n_modes: int | None
    basis: NDArray[np.float64] | None

    @property
    def is_fe(self) -> bool:
        return isinstance(self.model, FEModel)


def resolve_study(model: Any, parameters: Mapping[str, Any] | Sequence[DesignParameter] | DesignParameter,
                  rpm: float | None = None, mu: float | None = None, theta: float = 0.0, *,
                  disc_speed: float | None = None, method: str = "auto", band: Any = None, n_modes: Any = None,
                  basis: Any = None) -> Study:
    """The arguments of :func:`~squealkit.design.eigen_derivatives` and :func:`~squealkit.design.countermeasures`
    (the same for both), validated in one order: model, parameters, operating point, solver options."""
    from ..solvers.band import validate_band
    from ..stability.fe_sweep import METHODS

    validate_model(model)
    if isinstance(parameters, DesignParameter):
        parameters = [parameters]
    params = design_parameters(parameters, model)
    point = operating_point(model, rpm, mu, theta, disc_speed=disc_speed)
    if not isinstance(model, FEModel):
        if basis is not None:
            raise InputError(f"Parameter basis applies to FE models only, not to a {model.kind!r} model.")
        if method != "auto" or band is not None or n_modes is not None:
            raise InputError(f"method, band and n_modes apply to FE models only, not to a {model.kind!r} model.")
        return Study(model, params, point, "dense", None, None, None)
    if not isinstance(method, str) or method not in METHODS:
        raise InputError(f"Parameter method={method!r}; known: {', '.join(METHODS)}.")
    band = None if band is None else validate_band(band)
    n_modes = None if n_modes is None else validate_int("n_modes", n_modes, 1)
    V = None
    if basis is not None:
        V = np.asarray(basis, dtype=np.float64)
        if V.ndim != 2 or V.shape[0] != model.n_dof or not np.all(np.isfinite(V)):
            raise InputError(f"Parameter basis must be a finite {model.n_dof} x r matrix, got shape {V.shape}.")
        if method not in ("auto", "modal", "pod") or n_modes is not None:
            raise InputError("With basis=..., method and n_modes do not apply (the basis is the reduction).")
    return Study(model, params, point, method, band, n_modes, V)
