"""Moved to :mod:`squealkit.measurement.squeal.criteria`; this path keeps working for one release."""

import warnings

from .squeal.criteria import *  # noqa: F403
from .squeal.criteria import __all__  # noqa: F401

warnings.warn("squealkit.measurement.criteria is deprecated; use squealkit.measurement.squeal.criteria (same meaning).",
              DeprecationWarning, stacklevel=2)
