"""Stability of friction-coupled systems: complex eigenvalues, critical friction, tolerances,
mode shapes and sensitivities."""

from .. import _accessor  # noqa: F401  (registers ds.squeal.plot() on the results)
from ._schema import UNSTABLE_RTOL
from ._solve import IndeterminateWarning
from .critical import (
    ONSET_STATUS,
    REALISTIC_MU_MAX,
    CriticalFriction,
    RunoutTolerance,
    UnrealisticFrictionWarning,
    critical_friction,
    critical_friction_curve,
    runout_tolerance,
)
from .eigen import (
    VERDICTS,
    eigenvalues,
    stability_summary,
    stability_verdict,
    unstable_threshold,
)
from .ensemble import ModelEnsemble, ensemble_onset, ensemble_unstable
from .fe_sweep import fe_critical_friction, fe_modes, fe_stability_map, modes_to_vtk
from .maps import stability_map
from .modes import eigenvalue_sensitivity, mode_shapes, modes, modes_summary, onset_modes
from .sensitivity import critical_friction_sensitivity
from .tracking import lock_in, track_modes

__all__ = [
    "ONSET_STATUS",
    "REALISTIC_MU_MAX",
    "UNSTABLE_RTOL",
    "VERDICTS",
    "CriticalFriction",
    "IndeterminateWarning",
    "ModelEnsemble",
    "RunoutTolerance",
    "UnrealisticFrictionWarning",
    "critical_friction",
    "critical_friction_curve",
    "critical_friction_sensitivity",
    "eigenvalue_sensitivity",
    "eigenvalues",
    "ensemble_onset",
    "ensemble_unstable",
    "fe_critical_friction",
    "fe_modes",
    "fe_stability_map",
    "lock_in",
    "mode_shapes",
    "modes",
    "modes_summary",
    "modes_to_vtk",
    "onset_modes",
    "runout_tolerance",
    "stability_map",
    "stability_summary",
    "stability_verdict",
    "track_modes",
    "unstable_threshold",
]
