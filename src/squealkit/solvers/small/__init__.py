"""Compiled kernels of small (few-DOF) models over large grids of points.

:mod:`~squealkit.solvers.small.roots`: all 2n eigenvalues of ``M s^2 + C s + K`` per point as the
roots of the characteristic polynomial (Leibniz expansion, Aberth-Ehrlich iteration warm-started
along a row, LAPACK where it does not converge), each with an a-posteriori error radius.

What those roots say (the point's verdict, one root per mode, growth rates, damping ratios and
lock-in) is the stability analysis' reading of them: :mod:`squealkit.stability._verdicts` (it was
``solvers/small/modes.py``; issue #28: the solvers know no analysis).
"""

# internal kernels (no __all__: not part of the documented API), re-exported for the analyses that import them
# from here, as when this was one module; _radii_range is compiled by the warm-up
from .roots import (  # noqa: F401
    _radii_range,
    charpoly_table,
    inclusion_radii,
    permutations_table,
    quadratic_eigvals,
    quadratic_eigvals_stack,
)
