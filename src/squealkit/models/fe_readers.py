"""Moved to :mod:`squealkit.fe.readers` (one module per format); this path is kept for one release."""

import warnings

from ..fe.readers import READERS, load_fe_model, read_mat, read_matrices, read_mtx, read_op4, register_reader

__all__ = ["READERS", "load_fe_model", "read_mat", "read_matrices", "read_mtx", "read_op4", "register_reader"]

warnings.warn("squealkit.models.fe_readers moved to squealkit.fe.readers (the old path is kept for one release).",
              DeprecationWarning, stacklevel=2)
