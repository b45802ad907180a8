"""Moved to :mod:`squealkit.measurement.signal.tacho`; this path keeps working for one release."""

import warnings

from .signal.tacho import *  # noqa: F403
from .signal.tacho import __all__  # noqa: F401

warnings.warn("squealkit.measurement.tacho is deprecated; use squealkit.measurement.signal.tacho (same meaning).",
              DeprecationWarning, stacklevel=2)
