"""Stability of friction-coupled systems: complex eigenvalues, critical friction, tolerances."""

from ._solve import IndeterminateWarning
from .critical import (
    ONSET_STATUS,
    CriticalFriction,
    RunoutTolerance,
    critical_friction,
    critical_friction_curve,
    critical_friction_sensitivity,
    runout_tolerance,
)
from .eigen import (
    UNSTABLE_RTOL,
    VERDICTS,
    eigenvalues,
    stability_map,
    stability_summary,
    stability_verdict,
    unstable_threshold,
)
from .ensemble import ModelEnsemble, ensemble_onset, ensemble_unstable
from .tracking import lock_in, track_modes

__all__ = [
    "ONSET_STATUS",
    "UNSTABLE_RTOL",
    "VERDICTS",
    "CriticalFriction",
    "IndeterminateWarning",
    "ModelEnsemble",
    "RunoutTolerance",
    "critical_friction",
    "critical_friction_curve",
    "critical_friction_sensitivity",
    "eigenvalues",
    "ensemble_onset",
    "ensemble_unstable",
    "lock_in",
    "runout_tolerance",
    "stability_map",
    "stability_summary",
    "stability_verdict",
    "track_modes",
    "unstable_threshold",
]
