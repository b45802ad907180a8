"""Moved to :mod:`squealkit.solvers.small` (issue #28); this private path is that module, for one release."""

import sys

from ..solvers import small

sys.modules[__name__] = small
