"""Moved to :mod:`squealkit.fe.model` (import from :mod:`squealkit.fe`); this path is kept for one release."""

import warnings

from ..fe.model import FE_MATRICES, FEModel, rpm_to_disc_speed, rpm_to_omega

__all__ = ["FE_MATRICES", "FEModel", "rpm_to_disc_speed", "rpm_to_omega"]

warnings.warn("squealkit.models.fe moved to squealkit.fe.model: import FEModel from squealkit.fe "
              "(the old path is kept for one release).", DeprecationWarning, stacklevel=2)
