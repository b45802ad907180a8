"""Nonlinear steady states: squeal limit cycles by harmonic balance, their continuation in
friction or run-out slope, their stability (monodromy matrix or Hill's method), the first
Lyapunov coefficient at the Hopf point, and the sound level a cycle makes."""

from .. import _accessor  # noqa: F401  (registers ds.squeal.plot() on the results)
from .continuation import (
    Branch,
    continue_branch,
    floquet_multipliers,
    limit_cycle_branch,
    limit_cycle_branch_slope,
    limit_cycle_summary,
)
from .harmonic_balance import LimitCycle, SecondOrderSystem, contact_system, harmonic_balance
from .hill import hill_exponents
from .hopf import HopfPoint, hopf_point, lyapunov_coefficient
from .level import read_transfer_csv, sound_level

__all__ = [
    "Branch",
    "HopfPoint",
    "LimitCycle",
    "SecondOrderSystem",
    "contact_system",
    "continue_branch",
    "floquet_multipliers",
    "harmonic_balance",
    "hill_exponents",
    "hopf_point",
    "limit_cycle_branch",
    "limit_cycle_branch_slope",
    "limit_cycle_summary",
    "lyapunov_coefficient",
    "read_transfer_csv",
    "sound_level",
]
