"""Moved to :mod:`squealkit.measurement.formats.readers`; this path keeps working for one release."""

import warnings

from .formats.readers import *  # noqa: F403
from .formats.readers import __all__  # noqa: F401

warnings.warn("squealkit.measurement.readers is deprecated; use squealkit.measurement.formats.readers (same meaning).",
              DeprecationWarning, stacklevel=2)
