"""Nonlinear steady states: squeal limit cycles by harmonic balance, their continuation in
friction, their stability, and the first Lyapunov coefficient at the Hopf point."""

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
from .hopf import HopfPoint, hopf_point, lyapunov_coefficient

__all__ = [
    "Branch",
    "HopfPoint",
    "LimitCycle",
    "SecondOrderSystem",
    "contact_system",
    "continue_branch",
    "floquet_multipliers",
    "harmonic_balance",
    "hopf_point",
    "limit_cycle_branch",
    "limit_cycle_branch_slope",
    "limit_cycle_summary",
    "lyapunov_coefficient",
]
