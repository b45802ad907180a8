"""Moved to :mod:`squealkit.measurement.squeal.runout`; this path keeps working for one release."""

import warnings

from .squeal.runout import *  # noqa: F403
from .squeal.runout import __all__  # noqa: F401

warnings.warn("squealkit.measurement.runout is deprecated; use squealkit.measurement.squeal.runout (same meaning).",
              DeprecationWarning, stacklevel=2)
