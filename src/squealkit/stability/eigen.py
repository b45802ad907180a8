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
from .._deprecation import TAN_THETA_WHY as _TAN_THETA_WHY
from .._deprecation import keyword_only
from .._threads import honour_thread_limit, limit_threads, thread_limit, threads_for
from .._validation import (
    InputError,
    check_budget,
    check_memory,
    validate_array_finite,
    validate_dataset,
    validate_int,
    validate_model,
)
from ..models import FrictionModel
from ..models.friction import Stribeck, validate_friction
from ..solvers.small import (
    charpoly_table,
    permutations_table,
    quadratic_eigvals,
    quadratic_eigvals_stack,
)
from ._schema import UNSTABLE_RTOL, derived_variables, eigen_variables
from ._solve import VERDICTS, lapack_roots, solve_points
from .tracking import carry_along, track_column, track_modes, track_rows

__all__ = [
    "UNSTABLE_RTOL",
    "VERDICTS",
    "eigenvalues",
    "stability_summary",
    "stability_verdict",
    "unstable_threshold",
]

#: Largest n solved by the compiled characteristic-polynomial kernel; larger models use
#: LAPACK on the 2n x 2n state matrix.
_KERNEL_MAX_DOF = 4
_CHUNK = 4096
#: Points per compiled call (a block) and between progress reports. A signal's Python handler runs
#: only between compiled calls: 2**16 points take about 0.05 s on one thread (0.16 s on a loaded
#: machine), so a SIGTERM is honoured that soon (2**18 made it 0.66 s); the calls' own overhead is
#: small (the root buffers are kept from one block to the next).
_BLOCK = 1 << 16
#: Grid points per tile of a streamed (zarr) or distributed sweep.
_TILE_POINTS = 1 << 20
#: A lower bound of the time of one map point of a 3-DOF model [s] (measured 3-5.5 us on one
#: thread, streamed to zarr included), for the work budget.
_SECONDS_PER_POINT = 1e-6


@lru_cache(maxsize=8)
def _perms(n: int) -> tuple[np.ndarray, np.ndarray]:
    return permutations_table(n)


def unstable_threshold(lam: NDArray[np.complexfloating]) -> NDArray[np.float64]:
    """Growth rate [1/s] above which each point counts as unstable (per grid point).

    Parameters
    ----------
    lam : ndarray of complex, shape (..., n)
        Eigenvalues [1/s] at each point, the modes along the last axis.

    Returns
    -------
    ndarray, shape ``lam.shape[:-1]``
        ``UNSTABLE_RTOL * max |lambda|`` [1/s] over the modes of each point.
    """
    return UNSTABLE_RTOL * np.max(np.abs(lam), axis=-1)


def _matrices(
    model: FrictionModel, damped: bool, friction: Stribeck | None = None, speed: float | None = None,
    mu: NDArray | None = None, tan_theta: NDArray | None = None,
) -> tuple[NDArray, ...]:
    """The model's matrices stacked as models: M, C, K0, Kn, Kf, each (S, n, n).

    S = 1, one model for every point, unless a speed-dependent ``friction`` law is given:
    its linearisation adds the damping ``dmu/dv N0 D`` (``FrictionModel.friction_damping``)
    at each point of the flat arrays ``mu`` (kinetic) and ``tan_theta``, whether or not
    ``damped`` (it belongs to the friction law, not to the structure); or the model's contact
    parts depend on the slope (consistent kinematics, ``FrictionModel.contact_parts``). Then
    S is the number of points (broadcast views of the shared matrices), each point solved on
    its own.
    """
    M = np.asarray(model.mass_matrix(), dtype=float)
    C = np.asarray(model.damping_matrix(), dtype=float) if damped else np.zeros_like(M)
    K0, Kn, Kf = (np.asarray(x, dtype=float) for x in model.stiffness_parts())
    per_point = model.slope_coupled and tan_theta is not None
    if per_point:
        Kn, Kf = model.contact_parts(tan_theta)
    # The friction damping vanishes at every point when the law is flat at this speed or the
    # model has no static load (N0 = 0); decided from the law and the model, never from the
    # points, so that any split of a grid into blocks solves each point the same way.
    if friction is not None and not friction.flat_at(speed) and np.any(model.load_parts()[0]):
        Cf = model.friction_damping(friction, mu, tan_theta, speed=speed)
        return (np.broadcast_to(M, Cf.shape), C + Cf, *(np.broadcast_to(a, Cf.shape) for a in (K0, Kn, Kf)))
    if per_point:
        shape = Kn.shape
        return (np.broadcast_to(M, shape), np.broadcast_to(C, shape), np.broadcast_to(K0, shape), Kn, Kf)
    return tuple(np.ascontiguousarray(a[None]) for a in (M, C, K0, Kn, Kf))


#: Entries of a model's matrices beyond this (SI units) are no physical brake's, and the
#: characteristic polynomial of a few DOFs would overflow double precision.
_MAX_MAGNITUDE = 1e30


def check_magnitudes(M: NDArray, C: NDArray, K0: NDArray, Kn: NDArray, Kf: NDArray) -> None:
    """One-line error for matrices whose magnitudes no physical model has (e.g. a mass of
    1e-300 kg or a stiffness of 1e300 N/m, usually a unit mistake), instead of an overflow
    deep in the solver."""
    diag = np.abs(np.diagonal(M, axis1=-2, axis2=-1))
    small = diag[(diag > 0) & (diag < 1.0 / _MAX_MAGNITUDE)]
    if small.size:
        raise InputError(f"The model's mass matrix has a diagonal entry of {small.min():.3g} kg, below "
                         f"{1 / _MAX_MAGNITUDE:g} kg: no physical model has it (check the parameters' units).")
    for name, a, unit in (("mass", M, "kg"), ("damping", C, "N s/m"), ("stiffness", K0, "N/m"),
                          ("normal-contact stiffness", Kn, "N/m"), ("friction stiffness", Kf, "N/m")):
        big = float(np.max(np.abs(a))) if a.size else 0.0
        if big > _MAX_MAGNITUDE:
            raise InputError(f"The model's {name} matrix has an entry of {big:.3g} {unit}, above "
                             f"{_MAX_MAGNITUDE:g} {unit}: no physical model has it (check the parameters' units).")


def check_contact_factors(Kn: NDArray, Kf: NDArray, g: NDArray, e: NDArray,
                          slope: tuple[NDArray, NDArray, NDArray] | None = None) -> None:
    """One-line error, before the compiled kernels, for contact factors that make the stiffness
    overflow: ``g Kn`` and ``e Kf`` (``g = 1 - mu tan(theta)``, ``e = s (mu + tan(theta))``)
    beyond :data:`_MAX_MAGNITUDE` N/m, e.g. at ``mu = 1e300``; the kernels would meet inf/NaN."""
    for name, f, K, what in (("friction", e, Kf, "mu + tan(theta)"), ("normal-contact", g, Kn, "1 - mu tan(theta)")):
        if f.size == 0:
            continue
        i = int(np.argmax(np.abs(f)))
        worst = abs(float(f.flat[i]))
        scale = float(np.max(np.abs(K))) if K.size else 0.0
        if slope is not None:
            scale *= 1.0 + float(np.max(np.abs(slope[2]), initial=0.0))
        if not math.isfinite(worst) or worst * scale > _MAX_MAGNITUDE:
            raise InputError(f"The contact factor {what} = {worst:.3g} makes the {name} stiffness reach "
                             f"{worst * scale:.3g} N/m, above {_MAX_MAGNITUDE:g} N/m: no physical model has it "
                             "(check mu and theta).")


def _solve_block(mats: tuple[NDArray, ...], g: NDArray, e: NDArray, row: int, high_precision: bool = True,
                 out: tuple[NDArray, ...] | None = None, work: dict | None = None,
                 slope: tuple[NDArray, NDArray, NDArray] | None = None):
    """Modes, error radii, verdicts and thresholds of flat arrays of contact factors g, e.

    ``out`` receives the results (see :func:`~squealkit.stability._solve.solve_points`);
    ``work`` is a dict that keeps the kernel's root buffers from one block to the next of a
    grid (fresh buffers of this size cost more in page faults than the roots themselves).
    ``slope = (Knx, Kfx, st)``: consistent contact kinematics, point i with
    ``K = K0 + g Kn + e Kf + st[i] (g Knx + e Kfx)`` (``st = s tan(theta)``).
    """
    M, C, K0, Kn, Kf = mats
    check_contact_factors(Kn, Kf, g, e, slope)
    if M.shape[0] > 1:
        res = _solve_each(mats, g, e, high_precision)
        if out is not None:
            for o, r in zip(out, res, strict=True):
                o[...] = r
        return res
    n = M.shape[-1]
    P = g.shape[0]
    which = np.zeros(P, dtype=np.int64)
    if slope is not None:
        # the refinement stages take each point's own contact parts
        Knx, Kfx, st = slope
        Kn_p = Kn[0] + st[:, None, None] * Knx
        Kf_p = Kf[0] + st[:, None, None] * Kfx
        check = (*(np.broadcast_to(a[0], Kn_p.shape) for a in (M, C, K0)), Kn_p, Kf_p)
        which_check = np.arange(P, dtype=np.int64)
    else:
        check, which_check = mats, which
    if n > _KERNEL_MAX_DOF:
        Kc = check[2][which_check] + g[:, None, None] * check[3][which_check] + e[:, None, None] * check[4][which_check]
        roots, radii = lapack_roots(np.broadcast_to(M[0], Kc.shape), np.broadcast_to(C[0], Kc.shape), Kc)
        roots = np.ascontiguousarray(roots)
        radii = np.ascontiguousarray(radii)
        even = None
    else:
        work = {} if work is None else work
        if work.get("size", 0) < P:
            work.update(size=P, roots=np.empty((P, 2 * n), dtype=np.complex128), radii=np.empty((P, 2 * n)),
                        even=np.empty(P, dtype=np.bool_))
        roots, radii, even = work["roots"][:P], work["radii"][:P], work["even"][:P]
        perms, signs = _perms(n)
        if slope is None:
            table = charpoly_table(M[0], C[0], K0[0], Kn[0], Kf[0], perms, signs)
            Knx = Kfx = np.empty((0, 0))
            st = np.empty(0)
        else:
            table = np.empty((0, 0, 0))  # the per-point Leibniz expansion takes the slope terms
            Knx, Kfx = np.ascontiguousarray(slope[0], dtype=float), np.ascontiguousarray(slope[1], dtype=float)
            st = np.ascontiguousarray(slope[2], dtype=float)
        quadratic_eigvals(M[0], C[0], K0[0], Kn[0], Kf[0], g, e, perms, signs, table, Knx, Kfx, st, roots, radii,
                          even, _CHUNK, row)
    return solve_points(*check, which_check, g, e, roots, radii, even, UNSTABLE_RTOL,
                        high_precision=high_precision, out=out)


#: Points per sub-block when every point has its own model (bounds the stacked copies).
_EACH_BLOCK = 1 << 15


def _solve_models(mats: tuple[NDArray, ...], which: NDArray, g: NDArray, e: NDArray,
                  high_precision: bool = True):
    """:func:`_solve_block` for a stack of models ``mats`` (S, n, n): point p is model
    ``which[p]`` at contact factors ``g[p]``, ``e[p]``, each point solved on its own."""
    n = mats[0].shape[-1]
    P = g.shape[0]
    M, C, K0, Kn, Kf = mats
    check_contact_factors(Kn, Kf, g, e)
    if n > _KERNEL_MAX_DOF:
        K = K0[which] + g[:, None, None] * Kn[which] + e[:, None, None] * Kf[which]
        roots, radii = lapack_roots(M[which], C[which], K)
        roots, radii, even = np.ascontiguousarray(roots), np.ascontiguousarray(radii), None
    else:
        # points of one model in a run (a scan of each model) form a row: warm starts along
        # it; single points are each solved cold
        L = _run_length(which)
        R = P // L
        roots = np.empty((R, L, 2 * n), dtype=np.complex128)
        radii = np.empty((R, L, 2 * n))
        even = np.empty((R, L), dtype=np.bool_)
        perms, signs = _perms(n)
        quadratic_eigvals_stack(*(np.ascontiguousarray(a[which[::L]]) for a in mats),
                                np.ascontiguousarray(g.reshape(R, L)), np.ascontiguousarray(e.reshape(R, L)),
                                perms, signs, roots, radii, even)
        roots, radii, even = roots.reshape(P, 2 * n), radii.reshape(P, 2 * n), even.reshape(P)
    return solve_points(M, C, K0, Kn, Kf, which, g, e, roots, radii, even, UNSTABLE_RTOL,
                        high_precision=high_precision)


def _run_length(which: NDArray) -> int:
    """L when ``which`` is runs of L equal entries each (L consecutive points per model),
    else 1."""
    P = which.size
    starts = np.flatnonzero(np.concatenate([[True], which[1:] != which[:-1]]))
    L = P // max(1, starts.size)
    if L > 1 and starts.size * L == P and np.array_equal(starts, np.arange(0, P, L)):
        return L
    return 1


def _solve_each(mats: tuple[NDArray, ...], g: NDArray, e: NDArray, high_precision: bool = True):
    """:func:`_solve_block` for a stack of one model per point: each point solved on its own."""
    n = mats[0].shape[-1]
    out = [np.empty((g.shape[0], n), dtype=np.complex128), np.empty((g.shape[0], n)),
           np.empty(g.shape[0], dtype=np.int8), np.empty(g.shape[0])]
    for a in range(0, g.shape[0], _EACH_BLOCK):
        sl = slice(a, min(g.shape[0], a + _EACH_BLOCK))
        sub = tuple(np.ascontiguousarray(x[sl]) for x in mats)
        which = np.arange(sub[0].shape[0], dtype=np.int64)
        res = _solve_models(sub, which, g[sl], e[sl], high_precision)
        for o, r in zip(out, res, strict=True):
            o[sl] = r
    return tuple(out)


def _solve_grid(model, mu, tan_theta, damped, progress=None, friction=None, speed=None, *, high_precision=True):
    """``(lam, err, verdict, thr)`` over ``broadcast(mu, tan_theta)``; see :func:`eigenvalues`."""
    mu_a = validate_array_finite("mu", mu)
    t_a = validate_array_finite("tan_theta", tan_theta)
    mu_b, t_b = np.broadcast_arrays(mu_a, t_a)
    shape = mu_b.shape
    # the results (modes, radii, verdicts) and the kernel's buffers, before allocating them
    check_memory(mu_b.size * (48.0 * model.n_dof + 32.0), f"Eigenvalues at {mu_b.size} points",
                 "Use a coarser grid, or stream a map to zarr (--out FILE.zarr, store=...).")
    mu_v = mu_b if friction is None else friction.mu(mu_b, speed)  # the coefficient while sliding
    g = np.ascontiguousarray((1.0 - mu_v * t_b).ravel())
    e = np.ascontiguousarray((model.sliding_direction * (mu_v + t_b)).ravel())
    n = model.n_dof
    total = g.shape[0]
    lam = np.empty((total, n), dtype=np.complex128)
    err = np.empty((total, n))
    verdict = np.empty(total, dtype=np.int8)
    thr = np.empty(total)
    mats = _matrices(model, damped)
    check_magnitudes(*mats)
    work: dict = {}
    # the last axis is a row: solved on its own, so a row's numbers never depend on the others
    row = max(1, shape[-1]) if shape else 1
    block = max(1, _BLOCK // row) * row
    for start in range(0, total, block):
        stop = min(total, start + block)
        sl = slice(start, stop)
        slope = None
        if friction is not None:
            mats = _matrices(model, damped, friction, speed, mu_b.ravel()[sl], t_b.ravel()[sl])
        elif model.slope_coupled:
            # consistent kinematics: one model, the slope terms per point, warm starts along rows
            slope = (*model.slope_parts(), model.sliding_direction * t_b.ravel()[sl])
        with limit_threads(threads_for(stop - start)):  # small blocks: no parallel start-up
            _solve_block(mats, g[sl], e[sl], row, high_precision, (lam[sl], err[sl], verdict[sl], thr[sl]), work,
                         slope)
        if progress is not None:
            progress(stop, total)
    return (lam.reshape((*shape, n)), err.reshape((*shape, n)), verdict.reshape(shape), thr.reshape(shape))


@honour_thread_limit
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def eigenvalues(
    model: FrictionModel,
    mu: ArrayLike,
    *,
    tan_theta: ArrayLike = 0.0,
    damped: bool = False,
    friction: Stribeck | None = None,
    speed: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> NDArray[np.complex128]:
    """Complex eigenvalues lambda = sigma + j omega [1/s] of the model (paper eqs. 7-8).

    One eigenvalue per mode: of each conjugate pair the one with ``omega >= 0``; of real
    roots (overdamped, divergent or rigid-body modes; real within their error radius, and
    returned with omega = 0) the largest, so a growing real root is never dropped. Modes are
    ordered by frequency, lowest first, at each point (use :func:`stability_map` for tracked
    modes). Roots that rounding leaves undecided are recomputed (see
    :func:`stability_verdict`).

    Parameters
    ----------
    model : FrictionModel
        The system.
    mu, tan_theta : array_like
        Friction coefficient and run-out slope; broadcast against each other.
    damped : bool
        Include the damping matrix C. The paper's sweep (eq. 7) is undamped.
    friction : Stribeck, optional
        Speed-dependent friction (see :mod:`squealkit.models.friction`); ``mu`` is then the
        kinetic coefficient. The system is linearised about steady sliding at ``speed``:
        K uses ``mu(speed)`` and the friction force's slope adds the damping
        ``dmu/dv N0 D`` (negative for falling friction), with or without ``damped``.
    speed : float, optional
        Sliding speed V [m/s] of the disc past the pin; needed with ``friction``.
    progress : callable, optional
        Called as ``progress(done, total)`` with point counts while working.

    Returns
    -------
    ndarray, shape ``broadcast(mu, tan_theta).shape + (n,)``

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> lam = eigenvalues(get_preset("lv2013"), mu=0.0)
    >>> bool(np.all(lam.real == 0.0))   # undamped, no friction: on the imaginary axis
    True

    Friction falling with speed is negative damping along the sliding direction:

    >>> from squealkit.models.friction import Stribeck
    >>> lam = eigenvalues(get_preset("lv2013"), 0.2, damped=True, friction=Stribeck(0.6, 1e-3), speed=1e-3)
    >>> bool(lam.real.max() > 0)
    True
    """
    validate_model(model)
    friction, speed = validate_friction(model, friction, speed)
    return _solve_grid(model, mu, tan_theta, damped, progress, friction, speed)[0]


@honour_thread_limit
@keyword_only("tan_theta", why=_TAN_THETA_WHY)
def stability_verdict(
    model: FrictionModel,
    mu: ArrayLike,
    *,
    tan_theta: ArrayLike = 0.0,
    damped: bool = False,
    friction: Stribeck | None = None,
    speed: float | None = None,
) -> NDArray[np.str_]:
    """The verdict at each point: ``"stable"``, ``"flutter"``, ``"divergence"`` or ``"indeterminate"``.

    A point is unstable when some eigenvalue's real part exceeds
    ``UNSTABLE_RTOL * |lambda|_max`` by more than its a-posteriori error radius: by a
    complex pair (``"flutter"``, mode-coupling squeal) or by a real root (``"divergence"``).
    It is stable when no eigenvalue can reach the threshold. Each computed root carries an
    error radius; where a radius straddles the threshold (near-double roots: disc doublets,
    the lock-in point, rigid-body modes) the point is recomputed by LAPACK on the state
    matrix and then decided exactly, in rational arithmetic (50-digit arithmetic where
    that meets a root exactly on the threshold). ``"indeterminate"`` means even that cannot
    decide: the answer lies within the rounding of the model's own numbers. ``friction`` and
    ``speed`` as for :func:`eigenvalues`.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : array_like
        Friction coefficient; broadcast against ``tan_theta``.
    tan_theta : array_like
        Run-out slope ``tan(theta)`` [1]; broadcast against ``mu``.
    damped : bool
        Include the damping matrix C.
    friction : Stribeck, optional
        Speed-dependent friction, ``mu`` its kinetic coefficient (see :func:`eigenvalues`).
    speed : float, optional
        Sliding speed V [m/s], > 0; needed with ``friction`` (and only with it).

    Returns
    -------
    ndarray of str, shape ``broadcast(mu, tan_theta).shape``
        One of :data:`VERDICTS` per point.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> stability_verdict(get_preset("lv2013"), [0.0, 0.6]).tolist()
    ['stable', 'flutter']
    """
    validate_model(model)
    friction, speed = validate_friction(model, friction, speed)
    return np.asarray(VERDICTS)[_solve_grid(model, mu, tan_theta, damped, None, friction, speed)[2]]


def _stability_map_small(model: FrictionModel, mu: ArrayLike, theta: ArrayLike, *, damped: bool,
                         friction: Stribeck | None, speed: float | None, track: bool, lock_in_rtol: float,
                         progress: Callable[[int, int], None] | None, store: str | Path | None, client: Any,
                         tile_points: int) -> xr.Dataset:
    """:func:`~squealkit.stability.stability_map` of a small (friction) model, ``damped`` resolved
    (:mod:`~squealkit.stability.maps` dispatches here)."""
    friction, speed = validate_friction(model, friction, speed)
    fr = {"friction": friction, "speed": speed}
    mu_a = validate_array_finite("mu", mu)
    th_a = validate_array_finite("theta", theta)
    if mu_a.ndim > 1 or th_a.ndim > 1:
        raise InputError("mu and theta must be 1-D grids (or numbers).")
    mu_a = np.atleast_1d(mu_a)
    th_a = np.atleast_1d(th_a)
    if np.any(np.abs(th_a) >= math.pi / 2):
        raise InputError("Parameter theta must lie strictly between -90 and 90 deg.")
    tan_t = np.tan(th_a)
    n = model.n_dof
    points = float(mu_a.size) * th_a.size
    check_budget(f"A stability map of {mu_a.size} x {th_a.size} points", points=points,
                 seconds=points * _SECONDS_PER_POINT * (n / 3) ** 3 / thread_limit(),
                 hint="Use a coarser grid, or split the range into several runs.")
    if store is None:
        # measured peak about 230-450 bytes per point for 3 DOF (results, tracking, labels)
        check_memory(mu_a.size * th_a.size * (110.0 * n + 64.0), f"A stability map of {mu_a.size} x {th_a.size} points",
                     "Stream it to zarr (--out FILE.zarr, store=...) or use a coarser grid.")
    else:
        # the first theta column is solved and tracked whole before the tiles, and a tile
        # holds at least one whole mu row
        check_memory((mu_a.size + th_a.size) * (110.0 * n + 64.0),
                     f"A streamed map of {mu_a.size} x {th_a.size} points (its first column and one row)",
                     "Use fewer points along each axis.")
    if store is None and client is not None:
        raise InputError("A cluster run streams its result to zarr: pass store='....zarr' with client.")
    if store is None:
        with limit_threads(threads_for(mu_a.size * th_a.size)):  # tracking and labels too
            sol = _solve_grid(model, mu_a[:, None], tan_t[None, :], damped, progress, friction, speed)
            # lowest frequency first; tracking keeps the order of the first grid point
            if track:
                sol = _tracked(sol, track_modes(sol[0]))
            return _dataset(model, mu_a, th_a, sol, damped=damped, tracked=track, lock_in_rtol=lock_in_rtol, **fr)
    if Path(store).suffix.lower() != ".zarr":
        raise InputError(f"Parameter store={str(store)!r} must be a zarr store ending in .zarr.")
    tile_points = validate_int("tile_points", tile_points, 1)
    return _stream_map(model, mu_a, th_a, damped=damped, track=track, lock_in_rtol=lock_in_rtol,
                       progress=progress, store=store, client=client, tile_points=tile_points, **fr)


def _tile(arg: tuple) -> xr.Dataset:
    """One block of whole mu rows of a stability map (a task of a streamed sweep)."""
    model, mu, theta, first, damped, track, lock_in_rtol, fr = arg
    with limit_threads(threads_for(mu.size * theta.size)):
        sol = _solve_grid(model, mu[:, None], np.tan(theta)[None, :], damped, None, fr["friction"], fr["speed"])
        if track:  # rows are tracked independently: in blocks of rows, so a signal is honoured between them
            rows = max(1, _BLOCK // theta.size)
            sol = _tracked(sol, np.concatenate([track_rows(sol[0][a:a + rows], first[a:a + rows])
                                                for a in range(0, mu.size, rows)]))
        return _dataset(model, mu, theta, sol, damped=damped, tracked=track, lock_in_rtol=lock_in_rtol, **fr)


def _tracked(sol, lam_tracked):
    """``sol`` with its modes in the tracked order (error radii carried along)."""
    lam, err, verdict, thr = sol
    return lam_tracked, carry_along(lam, err, lam_tracked), verdict, thr


def _stream_map(model, mu, theta, *, damped, track, lock_in_rtol, progress, store, client, tile_points, **fr):
    from ..scale import lazy_template, stream_to_zarr

    n_th = theta.size
    rows = max(1, min(mu.size, -(-tile_points // n_th)))
    if client is not None:  # enough tiles to keep every worker thread busy
        threads = max(1, sum(client.nthreads().values()))
        rows = max(1, min(rows, -(-mu.size // (4 * threads))))
    # the first column, tracked along mu: each point is the cold first point of its row,
    # so these are the same numbers the tiles compute for their column 0
    first = eigenvalues(model, mu[:, None], tan_theta=np.tan(theta[:1])[None, :], damped=damped, **fr)[:, 0]
    first = track_column(first) if track else first
    sample = _tile((model, mu[:1], theta, first[:1], damped, track, lock_in_rtol, fr))
    template = lazy_template(sample, "mu", mu, rows)
    pieces = [(_tile, (model, mu[a:a + rows], theta, first[a:a + rows], damped, track, lock_in_rtol, fr),
               a, min(mu.size, a + rows)) for a in range(0, mu.size, rows)]
    return stream_to_zarr(store, template, "mu", pieces, client=client, progress=progress,
                          weights=[(b - a) * n_th for *_, a, b in pieces], name="squealkit-stability")


def _dataset(model, mu, theta, sol, *, damped, tracked, lock_in_rtol, friction=None, speed=None) -> xr.Dataset:
    lam, err, verdict, thr = sol
    sigma, omega, zeta, unstable, smax, any_u, locked = derived_variables(lam, err, thr, verdict, lock_in_rtol)
    dims = ("mu", "theta", "mode")
    n = lam.shape[-1]
    tan_t = np.tan(theta)
    ds = xr.Dataset(
        data_vars=eigen_variables(dims, sigma, omega, zeta, err, unstable, verdict, smax, any_u, locked,
                                   lock_in_rtol),
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
            "kind": "stability_map",
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
    if friction is not None:
        mu_v = friction.mu(mu, speed)
        ds = ds.assign_coords(
            mu_sliding=("mu", mu_v, {"units": "1", "long_name": "friction coefficient at the sliding speed"}),
            mu_e=(("mu", "theta"), mu_v[:, None] + tan_t[None, :], ds["mu_e"].attrs))
        ds.attrs.update(friction=friction.describe(), mu_static=friction.mu_static,
                        v_stribeck=friction.v_stribeck, speed=speed, speed_units="m/s")
    return ds


def stability_summary(ds: xr.Dataset) -> dict[str, object]:
    """Headline numbers of a stability map (what ``squealkit stability --json`` prints).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`stability_map`, in memory or streamed (dask-backed: only
        reductions are computed, the map is never loaded whole).

    Returns
    -------
    dict
        ``unstable_fraction`` (share of grid points with an unstable mode), and of it
        ``flutter_fraction`` and ``divergence_fraction``; ``indeterminate_fraction`` (points
        within rounding of the limit, see :func:`stability_verdict`),
        ``max_growth_rate`` [1/s], ``unstable_omega_rad_s`` and ``unstable_frequency_hz``
        ([min, max] over unstable points of the frequency of the most unstable mode, or
        None), ``lock_in_fraction``, and the grid extent.
    """
    validate_dataset(ds, what="stability_map")
    # reductions only, computed in one pass: a streamed (dask-backed) map is never loaded whole
    any_u = ds["any_unstable"]
    w_top = ds["omega"].where(ds["growth_rate"] == ds["max_growth_rate"]).max("mode")
    w_u = w_top.where(any_u)
    verdict = ds["verdict"] if "verdict" in ds else None
    fractions = {} if verdict is None else {
        f"{name}_fraction": (verdict == code).mean() for code, name in enumerate(VERDICTS)}
    r = xr.Dataset({
        **fractions,
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
    for name in VERDICTS[1:]:
        if f"{name}_fraction" in r:
            out[f"{name}_fraction"] = float(r[f"{name}_fraction"])
    if bool(r["any"]):
        lo, hi = float(r["w_min"]), float(r["w_max"])
        out["unstable_omega_rad_s"] = [lo, hi]
        out["unstable_frequency_hz"] = [lo / (2 * math.pi), hi / (2 * math.pi)]
    return out
