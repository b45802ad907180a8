"""Mode tracking by the modal assurance criterion (MAC) for models of any size.

An engine of the FE sweeps (:func:`~squealkit.stability.fe_stability_map`) and of the reduced sweeps
(:func:`~squealkit.solvers.reduction.reduced_sweep`); the small models' compiled tracking is in
:mod:`squealkit.stability.tracking`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

__all__ = ["mac"]


def mac(A: NDArray, B: NDArray) -> NDArray:
    """Modal assurance criterion between the columns of A and B (unit-norm columns).

    Parameters
    ----------
    A : ndarray, shape (n, p)
    B : ndarray, shape (n, q)

    Returns
    -------
    ndarray, shape (p, q)
        ``|a_i^H b_j|^2``.
    """
    return np.abs(A.conj().T @ B) ** 2


class MacTracker:
    """Mode tracking for large models: slots matched to the previous point's by MAC and eigenvalue.

    A point's modes (any number: modes enter and leave a frequency band) are assigned to
    the previous point's slots by the least total cost ``1 - MAC + |lambda_i - lambda_j| / scale``
    (``scipy.optimize.linear_sum_assignment``); a mode left over gets a new slot. Used by the
    FE sweeps, full (eigenvectors in the model's DOFs) and reduced (in an orthonormal basis's
    coordinates, where the MAC is the same).
    """

    def __init__(self) -> None:
        self.n_slots = 0

    def first(self, count: int) -> NDArray[np.intp]:
        """New slots for the ``count`` modes of a point with no predecessor."""
        slots = np.arange(self.n_slots, self.n_slots + count)
        self.n_slots += count
        return slots

    def match(self, prev: tuple[NDArray, NDArray, NDArray], lam: NDArray, X: NDArray) -> NDArray[np.intp]:
        """Slots of the modes ``(lam, X)`` given the previous point's ``(slots, lam, X)``."""
        p_slots, p_lam, p_X = prev
        slots = np.full(lam.size, -1, dtype=np.intp)
        if p_lam.size and lam.size:
            scale = max(np.max(np.abs(p_lam)), np.max(np.abs(lam)), 1e-300)
            cost = (1.0 - mac(p_X, X)) + np.abs(p_lam[:, None] - lam[None, :]) / scale
            rows, cols = linear_sum_assignment(cost)
            slots[cols] = p_slots[rows]
        new = slots < 0
        slots[new] = np.arange(self.n_slots, self.n_slots + int(new.sum()))
        self.n_slots += int(new.sum())
        return slots
