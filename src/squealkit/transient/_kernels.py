"""Moved to :mod:`squealkit.solvers.ode` (issue #28); this private path is that module, for one release."""

import sys

from ..solvers import ode

sys.modules[__name__] = ode
