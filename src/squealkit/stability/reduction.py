"""Moved to :mod:`squealkit.solvers.reduction`; this path is kept for one release."""

import warnings

from ..solvers.reduction import (
    MATRIX_NAMES,
    SNAPSHOT_TOL,
    ReducedModel,
    as_fe_model,
    count_below,
    modal_basis,
    pod_basis,
    reduce,
    reduced_eigs,
    reduced_solve,
    reduced_sweep,
)

# the old private names, for code that reached into this module
_as_model = as_fe_model
_count_below = count_below
_reduced_solve = reduced_solve

__all__ = [
    "MATRIX_NAMES",
    "SNAPSHOT_TOL",
    "ReducedModel",
    "modal_basis",
    "pod_basis",
    "reduce",
    "reduced_eigs",
    "reduced_sweep",
]

warnings.warn("squealkit.stability.reduction moved to squealkit.solvers.reduction (the old path is kept for one "
              "release).", DeprecationWarning, stacklevel=2)
