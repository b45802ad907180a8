"""One entry point for stability maps of every model kind: :func:`stability_map`.

It sits above the two engines it dispatches to, which do not import each other (their shared
schema is :mod:`~squealkit.stability._schema`): the small (friction) models' compiled map in
:mod:`~squealkit.stability.eigen` and the FE sweep in :mod:`~squealkit.stability.fe_sweep`.
Options are checked against the model's kind before any work: one that cannot apply is an
:class:`~squealkit._validation.InputError` naming it and the kind, never silently ignored.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .._threads import honour_thread_limit
from .._validation import InputError, validate_model
from ..fe.model import FEModel
from ..models import FrictionModel
from ..models._base import resolve_damped
from ..models.friction import Stribeck
from .eigen import _TILE_POINTS, _stability_map_small
from .fe_sweep import fe_stability_map

__all__ = ["stability_map"]

#: Options of :func:`stability_map` for FE models only.
FE_ONLY_OPTIONS = ("rpm", "method", "band", "n_modes")
#: Options of :func:`stability_map` for small (friction) models only (``damped=True`` is what FE models do).
SMALL_ONLY_OPTIONS = ("damped", "friction", "speed", "store", "tile_points")


class _NotGiven:
    """The default of an option whose default must be told apart from the same value given."""

    def __repr__(self) -> str:
        return "<not given>"


NOT_GIVEN: Any = _NotGiven()


def _refuse(names: list[str], model: Any, why: str) -> None:
    if names:
        opts = f"Option {names[0]}" if len(names) == 1 else f"Options {', '.join(names)}"
        verb = "does" if len(names) == 1 else "do"
        raise InputError(f"{opts} {verb} not apply to a{'n' if model.kind[0] in 'aeiouf' else ''} {model.kind} "
                         f"model {why}.")


@honour_thread_limit
def stability_map(
    model: FrictionModel | FEModel,
    mu: ArrayLike,
    theta: ArrayLike = 0.0,
    *,
    damped: bool | None = None,
    friction: Stribeck | None = None,
    speed: float | None = None,
    track: bool = True,
    lock_in_rtol: float = 1e-3,
    progress: Callable[[int, int], None] | None = None,
    store: str | Path | None = None,
    client: Any = None,
    tile_points: int = NOT_GIVEN,
    rpm: ArrayLike | None = None,
    method: str = NOT_GIVEN,
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
) -> xr.Dataset:
    """Eigenvalues over a grid of friction ``mu`` and run-out incline ``theta`` (paper Fig. 2).

    For an :class:`~squealkit.fe.FEModel` the grid is disc speed ``rpm`` x friction ``mu``
    at one ``theta`` (see :func:`~squealkit.stability.fe_sweep.fe_stability_map`, which takes
    ``rpm``, ``method``, ``band`` and ``n_modes``); its damping is always included.

    An option that does not apply to the model's kind is an :class:`InputError` naming the
    option and the kind, never ignored: ``rpm``, ``method``, ``band`` and ``n_modes`` are for
    FE models; ``friction``, ``speed``, ``store``, ``tile_points`` and ``damped=False`` for
    small (friction) models; ``tile_points`` needs ``store``.

    Parameters
    ----------
    model : FrictionModel or FEModel
        The system, e.g. ``get_preset("lv2013")`` or ``load_fe_model(...)``.
    mu : array_like, 1-D
        Friction coefficients.
    theta : array_like, 1-D
        Incline angles of the disc surface run-out [rad]; ``tan(theta)`` enters the model.
    damped : bool, optional
        Include the damping matrix C. Not given: left out (paper eq. 7 is undamped), with a
        warning when the model has damping. FE models always include theirs (``damped=False``
        is refused).
    friction : Stribeck, optional
        Speed-dependent friction, ``mu`` its kinetic coefficient (see :func:`eigenvalues`).
    speed : float, optional
        Sliding speed V [m/s]; needed with ``friction``.
    track : bool
        Follow each mode across the grid (see :func:`~squealkit.stability.track_modes`; FE
        models: by MAC); otherwise modes are ordered by frequency at each point.
    lock_in_rtol : float
        Relative frequency tolerance for the ``lock_in`` flag.
    progress : callable, optional
        ``progress(done, total)`` during the eigenvalue computation.
    store : path, optional
        Stream the result into this zarr store (``.zarr``) tile by tile (blocks of whole
        ``mu`` rows, about ``tile_points`` points each) instead of building it in memory;
        the store is opened lazily (dask-backed) and returned. For grids larger than memory.
    client : distributed.Client, optional
        Compute the tiles on this Dask cluster (small models: needs ``store``, on a file system
        the workers share; FE models: one task per rpm row). Numbers are identical to the local
        run: each row is solved and tracked on its own, from a first column tracked up front.
    tile_points : int, optional
        Grid points per tile when streaming (default 2**20; only with ``store``).
    rpm : array_like, 1-D, optional
        FE models only: disc speeds [rev/min] (see
        :func:`~squealkit.stability.fe_sweep.fe_stability_map`).
    method : {"auto", "dense", "sparse", "modal", "pod"}, optional
        FE models only: the eigenvalue solver (default ``"auto"``).
    band : (float, float), optional
        FE models only: frequency band [Hz] of the modes reported.
    n_modes : int, optional
        FE models only: reduced basis size for ``modal``/``pod``.

    Returns
    -------
    xarray.Dataset
        Dims ``(mu, theta, mode)`` (FE models: ``(rpm, mu, mode)``, see
        :func:`~squealkit.stability.fe_sweep.fe_stability_map`). Variables: ``growth_rate`` sigma [1/s], ``omega``
        [rad/s], ``frequency`` [Hz], ``damping_ratio`` [1], ``unstable`` (bool), and per
        grid point ``max_growth_rate`` [1/s], ``any_unstable`` and ``lock_in``.
        Coordinates: ``mu``, ``theta`` [rad], ``theta_deg``, ``tan_theta``, ``mu_e``
        (= mu + tan theta, eq. 6). Units in ``attrs``; the model as JSON in ``attrs``.
        With ``friction``: coordinate ``mu_sliding`` (mu at ``speed``, which ``mu_e`` then
        uses) and attributes ``friction`` and ``speed`` [m/s].

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = stability_map(get_preset("lv2013"), np.linspace(0, 0.8, 9),
    ...                    np.radians(np.linspace(-8, 8, 5)))
    >>> sorted(ds.sizes.items())
    [('mode', 3), ('mu', 9), ('theta', 5)]
    >>> try:
    ...     stability_map(get_preset("lv2013"), [0.3], rpm=[600.0])
    ... except InputError as e:
    ...     print(str(e)[:50])
    Option rpm does not apply to a pin_on_disc model (
    """
    validate_model(model)
    given = {"damped": damped is not None, "friction": friction is not None, "speed": speed is not None,
             "store": store is not None, "tile_points": tile_points is not NOT_GIVEN, "rpm": rpm is not None,
             "method": method is not NOT_GIVEN, "band": band is not None, "n_modes": n_modes is not None}
    if isinstance(model, FEModel):
        if damped is not None and not damped:
            raise InputError("Option damped=False does not apply to an fe model: its damping matrices are always "
                             "included (leave damped out, or give True).")
        _refuse([k for k in SMALL_ONLY_OPTIONS if given[k] and k != "damped"], model,
                "(a sparse FE model): it is for small (friction) models only")
        if rpm is None:
            raise InputError("A map of an FE model needs the disc speeds: rpm=[...].")
        if np.size(theta) != 1:
            raise InputError("A map of an FE model takes one run-out incline theta (mu_e = mu + tan theta).")
        return fe_stability_map(model, rpm, mu, float(np.ravel(theta)[0]),
                                method="auto" if method is NOT_GIVEN else method, band=band, n_modes=n_modes,
                                track=track, lock_in_rtol=lock_in_rtol, client=client, progress=progress)
    _refuse([k for k in FE_ONLY_OPTIONS if given[k]], model, "(a small model): it is for FE models only"
            if sum(given[k] for k in FE_ONLY_OPTIONS) == 1 else "(a small model): they are for FE models only")
    if given["tile_points"] and store is None:
        raise InputError(f"Option tile_points={tile_points!r} applies to streamed maps only: give store='....zarr' "
                         "with it.")
    damped = resolve_damped(model, damped)
    return _stability_map_small(model, mu, theta, damped=damped, friction=friction, speed=speed, track=track,
                                lock_in_rtol=lock_in_rtol, progress=progress, store=store, client=client,
                                tile_points=_TILE_POINTS if tile_points is NOT_GIVEN else tile_points)
