"""What counts as squeal and how it ties to the disc: SAE J2521 criteria and levels
(:mod:`.criteria`), tonal components linked into events (:mod:`.events`), the surface run-out
split into macro and micro (:mod:`.runout`)."""

from .criteria import SETUPS, SquealCriteria, squeal_criteria, time_weighted_level
from .events import SquealEvent
from .runout import incline, revolution_frequency, split_runout, surface_speed

__all__ = ["SETUPS", "SquealCriteria", "SquealEvent", "incline", "revolution_frequency", "split_runout",
           "squeal_criteria", "surface_speed", "time_weighted_level"]
