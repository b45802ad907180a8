"""Compiled integration of M x'' + C x' + f(x, x', q, tan_theta) = F0, and the monodromy matrix.

Kernels, one module each:

- :mod:`.bundles`: the named bundles every kernel takes (state, model, forcing, span or steps,
  tableau, control, outputs, log), so that a kernel's signature is a handful of names;
- :mod:`.adaptive`: the one driver loop of the error-controlled methods (step-size control, dense
  output into the samples, contact and stick/slip events, divergence, counters), compiled around a
  method's step (the helpers it calls are in :mod:`.events`);
- :mod:`.dp5`: ``integrate_adaptive``, Dormand-Prince 5(4): its step in that loop;
- :mod:`.rosenbrock`: ``integrate_rosenbrock``, Rodas4, linearly implicit with the analytic Jacobian,
  for stiff friction laws: its step in the same loop;
- :mod:`.rk4`: ``integrate_chunk``, fixed-step classical RK4 (the same bundles, its own loop);
- :mod:`.periodic`: ``monodromy_rk4``, the one RK4 monodromy matrix of a periodic linear system,
  used by ``monodromy`` (Floquet: the transient model on a periodic run-out) and by the limit
  cycles' Floquet multipliers (:func:`squealkit.nonlinear.continuation.floquet_multipliers`).

The right-hand side they all integrate, the contact force of eq. 4, and its Jacobian are in
:mod:`.force`. Each integrator inlines it (numba ``inline="always"``) at one call site in its
step only: every inlined copy costs seconds of compile time on a first run (issue #27).

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
