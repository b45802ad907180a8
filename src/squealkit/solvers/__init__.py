"""Numerical engines with no analysis vocabulary: compiled small-model eigenvalue kernels
(:mod:`~squealkit.solvers.small`) and ODE integrators (:mod:`~squealkit.solvers.ode`)."""
