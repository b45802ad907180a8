"""The parametric eigenproblem shared by the two estimates of :func:`~squealkit.design.robust_margins`.

Every model becomes ``lambda^2 M(p) + lambda C(p) + K(p)`` in n (reduced) unknowns, with the
matrices of a batch of parameter rows from a module-level builder (pickled to Dask workers):
``builder(payload, X) -> (S, 3, n, n)`` (M, C, K per row). Its eigenvalues are scaled by
``gamma = sqrt(||K|| / ||M||)`` so that the blocks of the companion pencil are O(1).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

#: Relative growth rate below which a mode counts as neutral, not unstable (as the stability maps).
_UNSTABLE_RTOL = 1e-9

def _linear_matrices(payload: tuple[NDArray, NDArray], X: NDArray) -> NDArray:
    """``fixed + sum_j X_j parts_j`` (an FE model's scale factors): shape (S, 3, n, n)."""
    fixed, parts = payload
    return fixed[None] + np.einsum("sd,dkij->skij", X, parts)


def _model_matrices(payload: tuple, X: NDArray) -> NDArray:
    """``M, C, K`` of a small model at each parameter row (:func:`~squealkit.uncertainty.squeal_propensity`'s
    samples: ``model.replace``, or the rig's model)."""
    from ..stability.modes import _parts, _stiffness
    from ..uncertainty import _sample_models

    model, names, mu, t, damped = payload
    out = []
    for m in _sample_models(model, names, X):
        M, C, K0, Kn, Kf = _parts(m, damped)
        out.append((M, C, _stiffness(m, K0, Kn, Kf, mu, t)))
    return np.asarray(out, dtype=float)


def _gamma(mats: NDArray) -> float:
    """Eigenvalue scale ``sqrt(||K|| / ||M||)`` (Fan, Lin & Van Dooren 2004): O(1) blocks of the pencil."""
    nm, nk = np.linalg.norm(mats[0]), np.linalg.norm(mats[2])
    return math.sqrt(nk / nm) if nk > 0 and nm > 0 else 1.0


def _state_matrices(mats: NDArray, gamma: float) -> NDArray:
    """The state matrices ``[[0, I], [-M^-1 K / g^2, -M^-1 C / g]]`` of ``lambda = g nu`` (scaled) of each
    ``(M, C, K)`` of a batch (S, 3, n, n): shape (S, 2n, 2n). An eigenvector is ``[x; nu x]``."""
    S, _, n, _ = mats.shape
    MK = np.linalg.solve(mats[:, 0], np.concatenate([mats[:, 2] / gamma**2, mats[:, 1] / gamma], axis=2))
    A = np.zeros((S, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :] = -MK
    return A


def _state_eigvals(mats: NDArray, gamma: float) -> NDArray:
    """All ``2n`` eigenvalues of each ``(M, C, K)`` of a batch (S, 3, n, n): shape (S, 2n), one LAPACK
    ``geev`` each (no vectors)."""
    return gamma * np.linalg.eigvals(_state_matrices(mats, gamma))


def _state_eig(mats: NDArray, gamma: float) -> tuple[NDArray, NDArray]:
    """Eigenvalues (S, 2n) and unit displacement eigenvectors ``x`` (S, n, 2n) of each ``(M, C, K)`` of a batch."""
    n = mats.shape[-1]
    w, Z = np.linalg.eig(_state_matrices(mats, gamma))
    x = Z[:, :n, :]
    norm = np.linalg.norm(x, axis=1, keepdims=True)
    return gamma * w, x / np.where(norm > 0, norm, 1.0)


def _pencil(mats: NDArray, gamma: float) -> tuple[NDArray, NDArray]:
    """The scaled companion pencil ``A - nu B`` of one ``(M, C, K)``: ``A = [[0, I], [-K/g^2, -C/g]]``,
    ``B = diag(I, M)``; its eigenvector is ``[x; nu x]`` and ``lambda = g nu``."""
    n = mats.shape[-1]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -mats[2] / gamma**2
    A[n:, n:] = -mats[1] / gamma
    B = np.eye(2 * n)
    B[n:, n:] = mats[0]
    return A, B


def _in_band(lam: NDArray, lo: float, hi: float) -> NDArray[np.bool_]:
    f = lam.imag / (2 * math.pi)
    return np.isfinite(lam) & (f >= lo) & (f <= hi)


def _threshold(lam: NDArray) -> NDArray:
    """Growth rate above which a mode is unstable, per row: ``1e-9 max |lambda|`` (as the stability maps)."""
    return _UNSTABLE_RTOL * np.max(np.abs(np.where(np.isfinite(lam), lam, 0.0)), axis=-1)


def _modes_in_band(lam: NDArray, lo: float, hi: float) -> NDArray[np.intp]:
    """Indices of the eigenvalues in the band, by frequency."""
    idx = np.flatnonzero(_in_band(lam, lo, hi))
    return idx[np.lexsort((-lam.real[idx], lam.imag[idx]))]

