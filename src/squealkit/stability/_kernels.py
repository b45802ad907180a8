"""Old private path of the small-model kernels (issue #28), for one release: the roots are now
:mod:`squealkit.solvers.small` (the engine), the verdicts, modes and lock-in
:mod:`squealkit.stability._verdicts` (the analysis)."""

from ..solvers.small import (  # noqa: F401
    _radii_range,
    charpoly_table,
    inclusion_radii,
    permutations_table,
    quadratic_eigvals,
    quadratic_eigvals_stack,
)
from ._verdicts import (  # noqa: F401
    _REAL_RTOL,
    DIVERGENCE,
    FLUTTER,
    INDETERMINATE,
    STABLE,
    UNDECIDED,
    ZERO_ROOT_REACH,
    _locked_in,
    classify_points,
    derived_quantities,
    select_modes,
)
