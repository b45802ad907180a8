"""The runs of a transient simulation: a model, a friction coefficient, a surface profile and a speed each.

:func:`_as_runs` broadcasts the entry points' arguments into validated :class:`_Run` records (one per run
of a batch); the integrator's name is checked here too, once for every entry point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .._validation import InputError, validate_finite, validate_plausible
from ..models import FrictionModel
from .profiles import Smooth, SurfaceProfile

#: The integrators of :func:`~squealkit.transient.simulate`.
METHODS = ("dopri5", "rosenbrock", "rk4")


Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class _Run:
    model: FrictionModel
    mu: float
    profile: SurfaceProfile
    speed: float


def _validate_model(model: object) -> FrictionModel:
    if not isinstance(model, FrictionModel):
        raise InputError(f"Parameter model must be a squealkit FrictionModel; got {type(model).__name__}.")
    return model


def _validate_method(method: object) -> str:
    if method not in METHODS:
        raise InputError(f"Parameter method={method!r} must be one of {', '.join(map(repr, METHODS))}.")
    return str(method)


def _as_runs(models, mus, profiles, speeds) -> list[_Run]:
    R = max(len(models), len(mus), len(profiles), len(speeds))
    out = []
    for seq, name in ((models, "model"), (mus, "mu"), (profiles, "profile"), (speeds, "speed")):
        if len(seq) not in (1, R):
            raise InputError(f"Batch parameter {name} has {len(seq)} entries; expected 1 or {R}.")
    def pick(seq, i):
        return seq[i if len(seq) > 1 else 0]

    for i in range(R):
        profile = pick(profiles, i)
        if profile is None:
            profile = Smooth()
        if not isinstance(profile, SurfaceProfile):
            raise InputError(f"Parameter profile must be a SurfaceProfile; got {type(profile).__name__}.")
        out.append(
            _Run(
                _validate_model(pick(models, i)),
                validate_finite("mu", pick(mus, i)),
                profile,
                validate_plausible("speed", pick(speeds, i)),
            )
        )
    return out
