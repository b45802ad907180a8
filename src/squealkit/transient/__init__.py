"""Transient time simulation with disc surface run-out (paper section 4, eqs. 9-11).

>>> from squealkit.models import get_preset
>>> from squealkit.transient import SineRunOut, simulate
>>> ds = simulate(get_preset("lv2013"), mu=0.4, profile=SineRunOut(0.08e-3, 1e-3), duration=0.01)
>>> sorted(ds.data_vars)[:3]
['friction_force', 'growth_rate', 'mu_e']
"""

from .. import _accessor  # noqa: F401  (registers ds.squeal.plot() on the results)
from .contact import Contact
from .profiles import ConstantIncline, DiscRunOut, RandomRoughness, SampledProfile, SineRunOut, Smooth, SurfaceProfile
from .simulate import (
    AliasingWarning,
    TensileContactWarning,
    response_envelope,
    simulate,
    simulate_batch,
    simulate_blocks,
    step_bound,
    transient_summary,
)

__all__ = [
    "AliasingWarning",
    "ConstantIncline",
    "Contact",
    "DiscRunOut",
    "RandomRoughness",
    "SampledProfile",
    "SineRunOut",
    "Smooth",
    "SurfaceProfile",
    "TensileContactWarning",
    "response_envelope",
    "simulate",
    "simulate_batch",
    "simulate_blocks",
    "step_bound",
    "transient_summary",
]
