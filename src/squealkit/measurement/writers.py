"""Moved to :mod:`squealkit.measurement.formats.writers`; this path keeps working for one release."""

import warnings

from .formats.writers import *  # noqa: F403
from .formats.writers import __all__  # noqa: F401

warnings.warn("squealkit.measurement.writers is deprecated; use squealkit.measurement.formats.writers (same meaning).",
              DeprecationWarning, stacklevel=2)
