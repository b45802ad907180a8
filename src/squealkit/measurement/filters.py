"""Moved to :mod:`squealkit.measurement.signal.filters`; this path keeps working for one release."""

import warnings

from .signal.filters import *  # noqa: F403
from .signal.filters import __all__  # noqa: F401

warnings.warn("squealkit.measurement.filters is deprecated; use squealkit.measurement.signal.filters (same meaning).",
              DeprecationWarning, stacklevel=2)
