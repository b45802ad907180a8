"""Moved to :mod:`squealkit.measurement.squeal.events`; this path keeps working for one release."""

import warnings

from .squeal.events import *  # noqa: F403
from .squeal.events import __all__  # noqa: F401

warnings.warn("squealkit.measurement.events is deprecated; use squealkit.measurement.squeal.events (same meaning).",
              DeprecationWarning, stacklevel=2)
