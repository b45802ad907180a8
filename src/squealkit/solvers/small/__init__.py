"""Compiled kernels of small (few-DOF) models over large grids of points.

- :mod:`~squealkit.solvers.small.roots`: all 2n eigenvalues of ``M s^2 + C s + K`` per point as
  the roots of the characteristic polynomial (Leibniz expansion, Aberth-Ehrlich iteration warm-started
  along a row, LAPACK where it does not converge), each with an a-posteriori error radius;
- :mod:`~squealkit.solvers.small.modes`: what those roots say: the point's verdict, one root per
  mode, growth rates, damping ratios and lock-in.

The names the analyses use are importable from ``squealkit.solvers.small``, as when this was one module.
"""

# internal kernels (no __all__: not part of the documented API), re-exported for the analyses that import them
# from here, as when this was one module; _radii_range is compiled by the warm-up, _REAL_RTOL and _locked_in
# are reused by mode tracking
from .modes import (  # noqa: F401
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
from .roots import (  # noqa: F401
    _radii_range,
    charpoly_table,
    inclusion_radii,
    permutations_table,
    quadratic_eigvals,
    quadratic_eigvals_stack,
)
