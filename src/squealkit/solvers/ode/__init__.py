"""Compiled integration of M x'' + C x' + f(x, x', q, tan_theta) = F0, and the monodromy matrix.

Kernels, one module each:

- :mod:`.rk4`: ``integrate_chunk``, fixed-step classical RK4;
- :mod:`.dp5`: ``integrate_adaptive``, Dormand-Prince 5(4) with error control, dense output and
  event location (the helpers it shares with Rodas4 are in :mod:`.events`);
- :mod:`.rosenbrock`: ``integrate_rosenbrock``, Rodas4, linearly implicit with the analytic Jacobian,
  for stiff friction laws;
- :mod:`.periodic`: ``monodromy_rk4``, the one RK4 monodromy matrix of a periodic linear system,
  used by ``monodromy`` (Floquet: the transient model on a periodic run-out) and by the limit
  cycles' Floquet multipliers (:func:`squealkit.nonlinear.continuation.floquet_multipliers`).

The right-hand side they all integrate, the contact force of eq. 4, and its Jacobian are in
:mod:`.force`. Each integrator inlines it (numba ``inline="always"``) at one call site in its
step loop only: every inlined copy costs seconds of compile time on a first run (issue #27).

Private (no ``__all__``: not part of the documented API): :mod:`squealkit.transient._setup` prepares
the arrays and :mod:`squealkit.transient._driver` calls the kernels. Each call advances a
batch of R independent runs by one chunk of steps, in parallel over runs (``prange``).
"""

# internal kernels, re-exported for the transient driver, Floquet and the limit cycles that import them from here
from .dp5 import integrate_adaptive  # noqa: F401
from .events import EVENT_CONTACT_CLOSES, EVENT_CONTACT_OPENS, EVENT_SLIP, EVENT_STICK  # noqa: F401
from .force import _bundle as _bundle  # private, for the tests of the force law
from .force import _jacobian as _jacobian
from .force import _rhs as _rhs
from .periodic import _sampled_monodromy as _sampled_monodromy  # private, for the test of numba's cache
from .periodic import monodromy, monodromy_rk4, sampled_rhs  # noqa: F401
from .rk4 import integrate_chunk  # noqa: F401
from .rosenbrock import integrate_rosenbrock  # noqa: F401
