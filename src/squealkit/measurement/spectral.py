"""Moved to :mod:`squealkit.measurement.signal.spectral`; this path keeps working for one release."""

import warnings

from .signal.spectral import *  # noqa: F403
from .signal.spectral import __all__  # noqa: F401

warnings.warn("squealkit.measurement.spectral is deprecated; use squealkit.measurement.signal.spectral (same meaning).",
              DeprecationWarning, stacklevel=2)
