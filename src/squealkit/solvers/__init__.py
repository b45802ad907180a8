"""Numerical engines, without analysis vocabulary.

- :mod:`~squealkit.solvers.lu`: the pluggable sparse LU (SuperLU; MKL PARDISO where installed,
  ``pip install squealkit[fast]``, chosen by a measured rule; a dense LAPACK LU; any backend
  registered or passed per call; ``SQUEALKIT_LU`` forces one);
- :mod:`~squealkit.solvers.band`: eigenvalues of ``lambda^2 M + lambda C + K``, all of them
  (dense) or in a frequency band (shift-invert block Krylov-Schur walks, one LU per shift);
- :mod:`~squealkit.solvers.reduction`: modal and POD bases, projection, reduced solves with
  full-model backward errors;
- :mod:`~squealkit.solvers.subspace`: the commercial codes' projection on the real modes of
  ``(M, K_sym)`` for the largest models, with full-model residuals;
- :mod:`~squealkit.solvers.memory`: the memory of those solves estimated before they start, and
  the limit (``SQUEALKIT_MEMORY``);
- :mod:`~squealkit.solvers.mac`: mode tracking by MAC;
- :mod:`~squealkit.solvers.small`: the compiled eigenvalue kernels of small (few-DOF) models;
- :mod:`~squealkit.solvers.ode`: the compiled time integrators (DP5, Rodas4, RK4, event location)
  and the one RK4 monodromy of Floquet analysis and limit cycles.

The analyses built on them (stability maps, onset, modes of FE models) are in
:mod:`squealkit.stability`.
"""

from .band import BAND_HZ, DENSE_MAX_DOF, EigenSolution, backward_errors, band_eigs, dense_eigs, dense_parts
from .lu import (
    LU_BACKENDS,
    DenseLU,
    PardisoLU,
    PermutedLU,
    factorize,
    fill_reducing_order,
    get_lu_backend,
    lu_backend,
    register_lu_backend,
    set_lu_backend,
    use_lu_backend,
)
from .reduction import ReducedModel, modal_basis, pod_basis, reduce, reduced_eigs, reduced_sweep
from .subspace import SubspaceBasis, subspace_basis, subspace_eigs

__all__ = [
    "BAND_HZ",
    "DENSE_MAX_DOF",
    "LU_BACKENDS",
    "DenseLU",
    "EigenSolution",
    "PardisoLU",
    "PermutedLU",
    "ReducedModel",
    "SubspaceBasis",
    "backward_errors",
    "band_eigs",
    "dense_eigs",
    "dense_parts",
    "factorize",
    "fill_reducing_order",
    "get_lu_backend",
    "lu_backend",
    "modal_basis",
    "pod_basis",
    "reduce",
    "reduced_eigs",
    "reduced_sweep",
    "register_lu_backend",
    "set_lu_backend",
    "subspace_basis",
    "subspace_eigs",
    "use_lu_backend",
]
