"""What every stability map shares: the instability threshold and the variables of its result.

Below both the small models' maps (:mod:`~squealkit.stability.eigen`) and the FE sweeps
(:mod:`~squealkit.stability.fe_sweep`), which import it; :func:`~squealkit.stability.stability_map`
(:mod:`~squealkit.stability.maps`) dispatches to the one or the other above them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ._verdicts import VERDICTS, derived_quantities

__all__ = ["UNSTABLE_RTOL", "derived_variables", "eigen_variables"]

#: A mode is unstable when sigma > UNSTABLE_RTOL * |lambda|: undamped stable modes have
#: real parts at rounding level (~1e-13 |lambda|), far below this.
UNSTABLE_RTOL = 1e-9
#: Points per compiled call of :func:`derived_variables`.
_BLOCK = 1 << 16


def derived_variables(lam: NDArray, err: NDArray, thr: NDArray, verdict: NDArray, lock_in_rtol: float):
    """Growth rate, frequency, damping ratio, flags and per-point summaries of eigenvalues over a grid.

    The compiled :func:`~squealkit.stability._verdicts.derived_quantities` on the grid flattened to
    ``(points, modes)``, reshaped back.

    Parameters
    ----------
    lam, err : ndarray, shape (..., n)
        Eigenvalues [1/s] and their error radii.
    thr, verdict : ndarray, shape (...)
        Instability threshold and verdict code of each grid point.
    lock_in_rtol : float
        Relative frequency tolerance of the lock-in flag.

    Returns
    -------
    tuple of ndarray
        ``sigma, omega, zeta, unstable`` of shape ``(..., n)`` and ``smax, any_unstable, lock_in``
        of shape ``(...)``.
    """
    n = lam.shape[-1]
    grid = lam.shape[:-1]
    flat = np.ascontiguousarray(lam.reshape(-1, n))
    err_f, thr_f, verdict_f = np.ascontiguousarray(err.reshape(-1, n)), thr.ravel(), verdict.ravel()
    # per point, so in blocks: a signal's Python handler runs between compiled calls (a tile of a streamed
    # map is 2**20 points, 0.23 s in one call on a loaded machine)
    parts = [derived_quantities(flat[a:a + _BLOCK], err_f[a:a + _BLOCK], thr_f[a:a + _BLOCK],
                                verdict_f[a:a + _BLOCK], lock_in_rtol) for a in range(0, max(1, flat.shape[0]), _BLOCK)]
    whole = parts[0] if len(parts) == 1 else tuple(np.concatenate(x) for x in zip(*parts, strict=True))
    return tuple(a.reshape(grid + a.shape[1:]) for a in whole)


def eigen_variables(dims, sigma, omega, zeta, err, unstable, verdict, smax, any_u, locked, lock_in_rtol,
                     err_name: str = "error radius of the eigenvalue") -> dict:
    """The per-mode and per-point variables of a stability map over ``dims`` (grid dims + ``mode``),
    from :func:`derived_variables`: one builder for every map (small models in
    :mod:`~squealkit.stability.eigen`, FE models in :mod:`~squealkit.stability.fe_sweep`)."""
    point = dims[:-1]
    return {
        "growth_rate": (dims, sigma, {"units": "1/s", "long_name": "growth rate sigma (real part)"}),
        "omega": (dims, omega, {"units": "rad/s", "long_name": "damped circular frequency omega_d"}),
        "frequency_hz": (dims, omega / (2 * math.pi), {"units": "Hz", "long_name": "frequency"}),
        "damping_ratio": (dims, zeta, {"units": "1", "long_name": "damping ratio -sigma/|lambda|"}),
        "growth_rate_error": (dims, err, {"units": "1/s", "long_name": err_name}),
        "unstable": (dims, unstable,
                     {"long_name": "mode unstable (sigma beyond 1e-9 |lambda|_max by more than its error)"}),
        "verdict": (point, verdict,
                    {"long_name": "stability verdict", "flag_values": np.arange(len(VERDICTS), dtype=np.int8),
                     "flag_meanings": " ".join(VERDICTS)}),
        "max_growth_rate": (point, smax, {"units": "1/s", "long_name": "largest growth rate"}),
        "any_unstable": (point, any_u, {"long_name": "unstable: flutter or divergence"}),
        "lock_in": (point, locked,
                    {"long_name": "lock-in: an unstable oscillating mode nearer another in frequency than in growth",
                     "rtol": lock_in_rtol}),
    }
