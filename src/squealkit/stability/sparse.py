"""Moved to :mod:`squealkit.solvers.band` (and the LU to :mod:`squealkit.solvers.lu`); this path is kept
for one release."""

import warnings

from ..solvers.band import (
    BAND_HZ,
    DENSE_MAX_DOF,
    RESIDUAL_TOL,
    DenseParts,
    EigenSolution,
    ShiftInvert,
    backward_errors,
    band_eigs,
    dense_eigs,
    dense_parts,
    pencil_backward_errors,
    real_times,
    validate_band,
)
from ..solvers.lu import PermutedLU, factorize, fill_reducing_order

# the old private names, for code that reached into this module
_ShiftInvert = ShiftInvert
_PermutedLU = PermutedLU
_factorize = factorize
_real_times = real_times
_backward = pencil_backward_errors

__all__ = [
    "BAND_HZ",
    "DENSE_MAX_DOF",
    "RESIDUAL_TOL",
    "DenseParts",
    "EigenSolution",
    "backward_errors",
    "band_eigs",
    "dense_eigs",
    "dense_parts",
    "fill_reducing_order",
    "validate_band",
]

warnings.warn("squealkit.stability.sparse moved to squealkit.solvers.band (the old path is kept for one release).",
              DeprecationWarning, stacklevel=2)
