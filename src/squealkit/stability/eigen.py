"""Complex eigenvalue analysis over friction and run-out slope (paper §3, eqs. 7-8).

The eigenvalues ``lambda = sigma + j omega_d`` of ``M x'' + C x' + K(mu, tan_theta) x = 0``
decide stability: a mode with ``sigma > 0`` grows (paper eq. 8). This module computes
them for whole grids of ``mu`` and ``theta`` at once and labels the result.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from .. import __version__
from .._validation import InputError, validate_array_finite
from ..models import FrictionModel
from ._kernels import derived_quantities, permutations_table, quadratic_eigvals, select_modes
from .tracking import track_column, track_modes, track_rows

__all__ = [
    "UNSTABLE_RTOL",
    "eigenvalues",
    "stability_map",
    "stability_summary",
    "unstable_threshold",
]

#: A mode is unstable when sigma > UNSTABLE_RTOL * |lambda|: undamped stable modes have
#: real parts at rounding level (~1e-13 |lambda|), far below this.
UNSTABLE_RTOL = 1e-9
#: Largest n solved by the compiled characteristic-polynomial kernel; larger models use
#: LAPACK on the 2n x 2n state matrix.
_KERNEL_MAX_DOF = 4
_CHUNK = 4096
#: Points per block between progress reports.
_BLOCK = 1 << 18
#: Grid points per tile of a streamed (zarr) or distributed sweep.
_TILE_POINTS = 1 << 20


@lru_cache(maxsize=8)
def _perms(n: int) -> tuple[np.ndarray, np.ndarray]:
    return permutations_table(n)


def unstable_threshold(lam: NDArray[np.complexfloating]) -> NDArray[np.float64]:
    """Growth rate [1/s] above which each point counts as unstable (per grid point)."""
    return UNSTABLE_RTOL * np.max(np.abs(lam), axis=-1)


def _state_matrix_eigvals(M, C, K) -> NDArray[np.complex128]:
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.zeros((*K.shape[:-2], 2 * n, 2 * n))
    A[..., :n, n:] = np.eye(n)
    A[..., n:, :n] = -Minv @ K
    A[..., n:, n:] = -Minv @ C
    return np.linalg.eigvals(A)


def _all_roots(model: FrictionModel, g: NDArray, e: NDArray, damped: bool, row: int) -> NDArray[np.complex128]:
    """All 2n eigenvalues for flat arrays of the contact factors g and e (rows of ``row`` points)."""
    M = np.ascontiguousarray(model.mass_matrix(), dtype=float)
    C = np.ascontiguousarray(model.damping_matrix() if damped else np.zeros_like(M), dtype=float)
    K0, Kn, Kf = (np.ascontiguousarray(x, dtype=float) for x in model.stiffness_parts())
    n = M.shape[0]
    if n > _KERNEL_MAX_DOF:
        K = K0 + g[:, None, None] * Kn + e[:, None, None] * Kf
        return _state_matrix_eigvals(M, C, K)
    roots = np.empty((g.shape[0], 2 * n), dtype=np.complex128)
    perms, signs = _perms(n)
    quadratic_eigvals(M, C, K0, Kn, Kf, g, e, perms, signs, roots, _CHUNK, row)
    return roots


def eigenvalues(
    model: FrictionModel,
    mu: ArrayLike,
    tan_theta: ArrayLike = 0.0,
    *,
    damped: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> NDArray[np.complex128]:
    """Complex eigenvalues lambda = sigma + j omega [1/s] of the model (paper eqs. 7-8).

    One eigenvalue per mode: of each conjugate pair the one with ``omega >= 0``; of real
    pairs (overdamped or divergent modes) the larger. Modes are ordered by frequency,
    lowest first, at each point (use :func:`stability_map` for tracked modes).

    Parameters
    ----------
    model : FrictionModel
        The system.
    mu, tan_theta : array_like
        Friction coefficient and run-out slope; broadcast against each other.
    damped : bool
        Include the damping matrix C. The paper's sweep (eq. 7) is undamped.
    progress : callable, optional
        Called as ``progress(done, total)`` with point counts while working.

    Returns
    -------
    ndarray, shape ``broadcast(mu, tan_theta).shape + (n,)``

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> lam = eigenvalues(get_preset("lv2013"), mu=0.0)
    >>> bool(np.all(np.abs(lam.real) < 1e-9 * np.abs(lam)))   # undamped, no friction
    True
    """
    mu_a = validate_array_finite("mu", mu)
    t_a = validate_array_finite("tan_theta", tan_theta)
    mu_b, t_b = np.broadcast_arrays(mu_a, t_a)
    shape = mu_b.shape
    g = np.ascontiguousarray((1.0 - mu_b * t_b).ravel())
    e = np.ascontiguousarray((model.sliding_direction * (mu_b + t_b)).ravel())
    n = model.n_dof
    out = np.empty((g.shape[0], n), dtype=np.complex128)
    total = g.shape[0]
    # the last axis is a row: solved on its own, so a row's numbers never depend on the others
    row = max(1, shape[-1]) if shape else 1
    block = max(1, _BLOCK // row) * row
    for start in range(0, max(total, 1), block):
        stop = min(total, start + block)
        if stop <= start:
            break
        roots = _all_roots(model, g[start:stop], e[start:stop], damped, row)
        select_modes(roots, out[start:stop])
        if progress is not None:
            progress(stop, total)
    return out.reshape((*shape, n))


def stability_map(
    model: FrictionModel,
    mu: ArrayLike,
    theta: ArrayLike = 0.0,
    *,
    damped: bool = False,
    track: bool = True,
    lock_in_rtol: float = 1e-3,
    progress: Callable[[int, int], None] | None = None,
    store: str | Path | None = None,
    client: Any = None,
    tile_points: int = _TILE_POINTS,
) -> xr.Dataset:
    """Eigenvalues over a grid of friction ``mu`` and run-out incline ``theta`` (paper Fig. 2).

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : array_like, 1-D
        Friction coefficients.
    theta : array_like, 1-D
        Incline angles of the disc surface run-out [rad]; ``tan(theta)`` enters the model.
    damped : bool
        Include damping (False reproduces the paper's undamped eq. 7).
    track : bool
        Follow each mode across the grid (see :func:`~squealkit.stability.track_modes`);
        otherwise modes are ordered by frequency at each point.
    lock_in_rtol : float
        Relative frequency tolerance for the ``lock_in`` flag.
    progress : callable, optional
        ``progress(done, total)`` during the eigenvalue computation.
    store : path, optional
        Stream the result into this zarr store (``.zarr``) tile by tile (blocks of whole
        ``mu`` rows, about ``tile_points`` points each) instead of building it in memory;
        the store is opened lazily (dask-backed) and returned. For grids larger than memory.
    client : distributed.Client, optional
        Compute the tiles on this Dask cluster (needs ``store``, on a file system the
        workers share). Numbers are identical to the local run: each ``mu`` row is solved
        and tracked on its own, from a first column tracked up front.
    tile_points : int
        Grid points per tile when streaming.

    Returns
    -------
    xarray.Dataset
        Dims ``(mu, theta, mode)``. Variables: ``growth_rate`` sigma [1/s], ``omega``
        [rad/s], ``frequency`` [Hz], ``damping_ratio`` [1], ``unstable`` (bool), and per
        grid point ``max_growth_rate`` [1/s], ``any_unstable`` and ``lock_in``.
        Coordinates: ``mu``, ``theta`` [rad], ``theta_deg``, ``tan_theta``, ``mu_e``
        (= mu + tan theta, eq. 6). Units in ``attrs``; the model as JSON in ``attrs``.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = stability_map(get_preset("lv2013"), np.linspace(0, 0.8, 9),
    ...                    np.radians(np.linspace(-8, 8, 5)))
    >>> sorted(ds.sizes.items())
    [('mode', 3), ('mu', 9), ('theta', 5)]
    """
    mu_a = validate_array_finite("mu", mu)
    th_a = validate_array_finite("theta", theta)
    if mu_a.ndim > 1 or th_a.ndim > 1:
        raise InputError("mu and theta must be 1-D grids (or numbers).")
    mu_a = np.atleast_1d(mu_a)
    th_a = np.atleast_1d(th_a)
    if np.any(np.abs(th_a) >= math.pi / 2):
        raise InputError("Parameter theta must lie strictly between -90 and 90 deg.")
    tan_t = np.tan(th_a)
    if store is None and client is not None:
        raise InputError("A cluster run streams its result to zarr: pass store='....zarr' with client.")
    if store is None:
        lam = eigenvalues(model, mu_a[:, None], tan_t[None, :], damped=damped, progress=progress)
        # lowest frequency first; tracking keeps the order of the first grid point
        if track:
            lam = track_modes(lam)
        return _dataset(model, mu_a, th_a, lam, damped=damped, tracked=track, lock_in_rtol=lock_in_rtol)
    if Path(store).suffix.lower() != ".zarr":
        raise InputError(f"Parameter store={str(store)!r} must be a zarr store ending in .zarr.")
    if isinstance(tile_points, bool) or not isinstance(tile_points, int) or tile_points < 1:
        raise InputError(f"Parameter tile_points={tile_points!r} must be an integer >= 1.")
    return _stream_map(model, mu_a, th_a, damped=damped, track=track, lock_in_rtol=lock_in_rtol,
                       progress=progress, store=store, client=client, tile_points=tile_points)


def _tile(arg: tuple) -> xr.Dataset:
    """One block of whole mu rows of a stability map (a task of a streamed sweep)."""
    model, mu, theta, first, damped, track, lock_in_rtol = arg
    lam = eigenvalues(model, mu[:, None], np.tan(theta)[None, :], damped=damped)
    if track:
        lam = track_rows(lam, first)
    return _dataset(model, mu, theta, lam, damped=damped, tracked=track, lock_in_rtol=lock_in_rtol)


def _stream_map(model, mu, theta, *, damped, track, lock_in_rtol, progress, store, client, tile_points):
    from ..scale import lazy_template, stream_to_zarr

    n_th = theta.size
    rows = max(1, min(mu.size, -(-tile_points // n_th)))
    if client is not None:  # enough tiles to keep every worker thread busy
        threads = max(1, sum(client.nthreads().values()))
        rows = max(1, min(rows, -(-mu.size // (4 * threads))))
    # the first column, tracked along mu: each point is the cold first point of its row,
    # so these are the same numbers the tiles compute for their column 0
    first = eigenvalues(model, mu[:, None], np.tan(theta[:1])[None, :], damped=damped)[:, 0]
    first = track_column(first) if track else first
    sample = _tile((model, mu[:1], theta, first[:1], damped, track, lock_in_rtol))
    template = lazy_template(sample, "mu", mu, rows)
    pieces = [(_tile, (model, mu[a:a + rows], theta, first[a:a + rows], damped, track, lock_in_rtol),
               a, min(mu.size, a + rows)) for a in range(0, mu.size, rows)]
    return stream_to_zarr(store, template, "mu", pieces, client=client, progress=progress,
                          weights=[(b - a) * n_th for *_, a, b in pieces], name="squealkit-stability")


def _dataset(model, mu, theta, lam, *, damped, tracked, lock_in_rtol) -> xr.Dataset:
    n = lam.shape[-1]
    grid = lam.shape[:-1]
    flat = np.ascontiguousarray(lam.reshape(-1, n))
    sigma, omega, zeta, unstable, smax, any_u, locked = (
        a.reshape(grid + a.shape[1:]) for a in derived_quantities(flat, UNSTABLE_RTOL, lock_in_rtol)
    )
    dims = ("mu", "theta", "mode")
    n = lam.shape[-1]
    tan_t = np.tan(theta)
    ds = xr.Dataset(
        data_vars={
            "growth_rate": (dims, sigma, {"units": "1/s", "long_name": "growth rate sigma (real part)"}),
            "omega": (dims, omega, {"units": "rad/s", "long_name": "damped circular frequency omega_d"}),
            "frequency": (dims, omega / (2 * math.pi), {"units": "Hz", "long_name": "frequency"}),
            "damping_ratio": (dims, zeta, {"units": "1", "long_name": "damping ratio -sigma/|lambda|"}),
            "unstable": (dims, unstable, {"long_name": "mode unstable (sigma > 1e-9 |lambda|)"}),
            "max_growth_rate": (("mu", "theta"), smax, {"units": "1/s", "long_name": "largest growth rate"}),
            "any_unstable": (("mu", "theta"), any_u, {"long_name": "some mode unstable"}),
            "lock_in": (("mu", "theta"), locked,
                        {"long_name": "two modes coalesced in frequency, one unstable", "rtol": lock_in_rtol}),
        },
        coords={
            "mu": ("mu", mu, {"units": "1", "long_name": "friction coefficient"}),
            "theta": ("theta", theta, {"units": "rad", "long_name": "run-out incline angle"}),
            "theta_deg": ("theta", np.degrees(theta), {"units": "deg", "long_name": "run-out incline angle"}),
            "tan_theta": ("theta", tan_t, {"units": "1", "long_name": "run-out slope mu_theta (eq. 5)"}),
            "mu_e": (("mu", "theta"), mu[:, None] + tan_t[None, :],
                     {"units": "1", "long_name": "equivalent friction mu + tan(theta) (eq. 6)"}),
            "mode": ("mode", np.arange(n), {"long_name": "mode index (tracked)" if tracked else "mode index"}),
        },
        attrs={
            "title": "Complex eigenvalues over friction and run-out incline",
            "model": model.to_json(),
            "model_kind": model.kind,
            "damped": int(damped),
            "tracked": int(tracked),
            "unstable_rtol": UNSTABLE_RTOL,
            "reference": "Lv, Zhang & Yu, J. Vibroeng. 15(2) 2013, eqs. (4), (7), (8); Fig. 2",
            "squealkit_version": __version__,
        },
    )
    return ds


def stability_summary(ds: xr.Dataset) -> dict[str, object]:
    """Headline numbers of a stability map (what ``squealkit stability --json`` prints).

    Returns
    -------
    dict
        ``unstable_fraction`` (share of grid points with an unstable mode),
        ``max_growth_rate`` [1/s], ``unstable_omega_rad_s`` and ``unstable_frequency_hz``
        ([min, max] over unstable points of the frequency of the most unstable mode, or
        None), ``lock_in_fraction``, and the grid extent.
    """
    # reductions only, computed in one pass: a streamed (dask-backed) map is never loaded whole
    any_u = ds["any_unstable"]
    w_top = ds["omega"].where(ds["growth_rate"] == ds["max_growth_rate"]).max("mode")
    w_u = w_top.where(any_u)
    r = xr.Dataset({
        "unstable_fraction": any_u.mean(), "lock_in_fraction": ds["lock_in"].mean(),
        "max_growth_rate": ds["max_growth_rate"].max(), "w_min": w_u.min(), "w_max": w_u.max(),
        "any": any_u.any(),
    }).compute()
    out: dict[str, object] = {
        "grid_points": int(any_u.size),
        "mu_range": [float(ds.mu.min()), float(ds.mu.max())],
        "theta_deg_range": [float(ds.theta_deg.min()), float(ds.theta_deg.max())],
        "damped": bool(ds.attrs.get("damped", 0)),
        "unstable_fraction": float(r["unstable_fraction"]),
        "lock_in_fraction": float(r["lock_in_fraction"]),
        "max_growth_rate": float(r["max_growth_rate"]),
        "unstable_omega_rad_s": None,
        "unstable_frequency_hz": None,
    }
    if bool(r["any"]):
        lo, hi = float(r["w_min"]), float(r["w_max"])
        out["unstable_omega_rad_s"] = [lo, hi]
        out["unstable_frequency_hz"] = [lo / (2 * math.pi), hi / (2 * math.pi)]
    return out
