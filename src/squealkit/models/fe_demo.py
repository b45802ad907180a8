"""Moved to :mod:`squealkit.fe.demo`; this path is kept for one release."""

import warnings

from ..fe.demo import FE_MATRIX_NAMES, FEDemoGeometry, build_fe_demo, fe_demo_dofs, write_fe_demo

__all__ = ["FE_MATRIX_NAMES", "FEDemoGeometry", "build_fe_demo", "fe_demo_dofs", "write_fe_demo"]

warnings.warn("squealkit.models.fe_demo moved to squealkit.fe.demo (the old path is kept for one release).",
              DeprecationWarning, stacklevel=2)
