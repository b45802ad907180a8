"""The finite element side of squealkit, in one place.

- :mod:`~squealkit.fe.model`: :class:`FEModel`, a brake given by its sparse matrices
  ``M, D1, DG, DR, D4, K1, KR, KGeo``, with ``C(disc_speed, mu)`` and ``K(disc_speed, mu)``;
- :mod:`~squealkit.fe.readers`: the exported matrices read from files, one module per format
  behind one table of formats (:data:`~squealkit.fe.readers.READERS`);
- :mod:`~squealkit.fe.demo`: the built-in disc and pads (scikit-fem), with its mesh;
- :mod:`~squealkit.fe.energy` and :mod:`~squealkit.fe.surface`: the friction work of each mode
  per node with its energy balance, the bodies and surface of the mesh the modes are drawn on.

The numerical engines are in :mod:`squealkit.solvers`, the analyses (maps, onset, modes of FE
models) in :mod:`squealkit.stability`.
"""

from .energy import mode_energy
from .model import FE_MATRICES, FEModel, rpm_to_disc_speed, rpm_to_omega
from .readers import READERS, load_fe_model, read_matrices, register_reader
from .surface import mode_surface

__all__ = [
    "FE_MATRICES",
    "READERS",
    "FEModel",
    "load_fe_model",
    "mode_energy",
    "mode_surface",
    "read_matrices",
    "register_reader",
    "rpm_to_disc_speed",
    "rpm_to_omega",
]
