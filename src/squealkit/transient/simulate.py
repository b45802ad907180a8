"""Transient time simulation of a friction model sliding over a disc surface profile.

Solves the paper's equations of motion (eqs. 1-4) with time-varying run-out q(t) and slope
tan(theta(t)) = dq/dx at x = x_start + v t (eqs. 9-11) in compiled code, and returns an
:class:`xarray.Dataset` sampled at ``fs``. Two integrators:

- ``"dopri5"`` (default): Dormand-Prince 5(4) with error control (``rtol``, ``atol``), a step
  per run, output by its 4th-order dense interpolant at ``fs``; contact loss and closure are
  located inside a step (bisection on the interpolant) and the step is retaken to end there;
  stick/slip transitions of the regularised friction law are located and recorded.
- ``"rosenbrock"``: Rodas4 (Hairer & Wanner, Solving ODEs II, sec. IV.7, code RODAS), a
  linearly implicit, L-stable Rosenbrock 4(3) pair with the analytic Jacobian of the force law,
  for stiff friction laws (small ``v_reg``): its step is bounded by the error control only (and
  by ``3 / omega_max``), not by the friction law's stability bound. Output by its own 3rd-order
  dense output; contact and stick/slip events as for ``"dopri5"``.
- ``"rk4"``: classical RK4 with a fixed step (the earlier integrator, for order studies).

The explicit ones respect a step bound from the fastest mode and from the friction law's own stiffness:
regularised friction ``mu N tanh(w / v_reg)`` acts like a damper ``mu N / v_reg`` on the sliding
direction (and a Stribeck law adds ``(mu_static - mu) N / v_stribeck``), whose explicit
stability limit ``~2.5 / (c fhat.M^-1.fhat)`` can be far below the modes' (see
:func:`step_bound`). The q and slope samples are interpolated in time by cubic Hermite
polynomials through q and dq/dt = v tan(theta) (4 samples per output sample).

The steps, one private module each, in the order a run takes them: the runs validated
(``_runs``), the step bound (``_step``, public :func:`step_bound`), the set-up of the arrays and
initial states (``_setup``), the driver of the compiled integrators chunk by chunk (``_driver``),
the labelled result (``_result``); the summaries of a record (``_summary``:
:func:`response_envelope`, :func:`transient_summary`). This module holds the entry points.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from .._validation import InputError, validate_fs, validate_model, validate_positive
from ..models import FrictionModel
from ._driver import _chunks, _integrate
from ._result import (
    _STATUS,
    TensileContactWarning,
    _attrs,
    _integrator_attrs,
    _run_dataset,
    _warn_tensile,
    _with_events,
)
from ._runs import METHODS, Progress, _as_runs, _Run, _validate_method  # noqa: F401  (METHODS: see below)
from ._setup import _perturbation_noise, _prepare
from ._step import (  # noqa: F401  (the factors: see below)
    DOPRI_OMEGA_FACTOR,
    STABILITY_FACTOR,
    STEP_FACTOR,
    AliasingWarning,
    _step_size,
    step_bound,
)
from ._summary import SUMMARY_STAGE_SAMPLES, response_envelope, transient_summary  # noqa: F401  (see below)
from .contact import Contact, as_contact
from .profiles import SurfaceProfile

__all__ = ["AliasingWarning", "TensileContactWarning", "response_envelope", "simulate", "simulate_batch",
           "simulate_blocks", "step_bound", "transient_summary"]
# Before issue #28 split this module, METHODS, STEP_FACTOR, STABILITY_FACTOR, DOPRI_OMEGA_FACTOR and
# SUMMARY_STAGE_SAMPLES were defined here: they stay importable from here.


def simulate(
    model: FrictionModel,
    *,
    mu: float,
    profile: SurfaceProfile | None = None,
    speed: float = 0.02,
    duration: float,
    fs: float = 40_000.0,
    contact: Contact | str = "linear",
    x0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    perturbation: float = 0.0,
    rng: np.random.Generator | None = None,
    x_start: float = 0.0,
    dt: float | None = None,
    limit: float = 1.0,
    progress: Progress | None = None,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
) -> xr.Dataset:
    """Time response of a model sliding over a disc surface profile (paper section 4).

    Integrates ``M x'' + C x' + K(mu, tan_theta(t)) x = F(mu, tan_theta(t), q(t))`` (eq. 4)
    with q and tan(theta) from the profile at ``x = x_start + speed * t`` (eqs. 9-11), by
    Dormand-Prince 5(4) with error control (default) or classical RK4 with a fixed step,
    output every ``1/fs`` (see the module notes for the step bound and the events).

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu : float
        Friction coefficient (kinetic value for the Stribeck law).
    profile : SurfaceProfile, optional
        Disc surface; default :class:`~squealkit.transient.profiles.Smooth`.
    speed : float
        Sliding speed v [m/s] (paper: 0.02 m/s).
    duration : float
        Simulated time [s].
    fs : float
        Output sample rate [Hz] (default 40 kHz, the paper's rig).
    contact : Contact or {"linear", "nonlinear"}
        Contact law; ``"linear"`` is the paper's (eqs. 2-3). See :class:`Contact`.
    x0, v0 : array_like, shape (n,), optional
        Initial displacements [m] and velocities [m/s]. Default: at rest in the static
        equilibrium of t = 0, ``K(0) x = F(0)``.
    perturbation : float
        Standard deviation [m] of a random displacement added to the initial state (needs
        ``rng``); a flat disc in exact equilibrium never leaves it.
    rng : numpy.random.Generator, optional
        Source of the perturbation.
    x_start : float
        Position on the profile at t = 0 [m].
    dt : float, optional
        Largest step [s]. RK4: its fixed step (rounded down so that ``1/fs`` is a whole number
        of steps; default ``min(0.25 / omega_max, 2.5 / friction rate)``, and an error if it
        exceeds the friction law's stability bound, :func:`step_bound`). Dormand-Prince: the
        largest step the error control may take (cut to the stability bound).
    limit : float
        A run whose displacement exceeds ``limit`` [m] stops with status ``"diverged"``.
    progress : callable, optional
        Called as ``progress(done, total)``.
    method : {"dopri5", "rosenbrock", "rk4"}
        Integrator: Dormand-Prince 5(4) with error control and event location; Rodas4, a
        linearly implicit Rosenbrock 4(3) pair with the analytic Jacobian, error control, its own
        dense output and the same event location, for stiff friction laws (small ``v_reg``: its
        step is not held at the friction law's stability bound; ``dt`` caps it, default
        ``3 / omega_max``); or fixed-step RK4.
    rtol : float
        Relative tolerance of the error control (Dormand-Prince, Rodas4).
    atol : float, optional
        Absolute displacement tolerance [m]; velocities get ``atol * omega_max``. Default
        ``1e-3 rtol`` times the largest initial displacement (at least 1 nm).

    Returns
    -------
    xarray.Dataset
        Over ``time`` [s] (coordinate ``position`` [m]): each DOF's displacement (``x1``,
        ``y1``, ``y2`` for the paper's model), velocity (``x1_dot``...) and acceleration
        (``x1_ddot``...), ``normal_force`` and ``friction_force`` [N], ``q`` [m],
        ``tan_theta``, ``mu_e`` and the frozen-time ``growth_rate`` sigma(t) [1/s] of the
        damped linear model at (mu, tan_theta(t)) (with a Stribeck contact, linearised about
        sliding at ``speed``: see :func:`~squealkit.stability.eigenvalues`). A run starts at rest
        in the static equilibrium of steady sliding (friction ``mu(speed)`` for a Stribeck
        contact) unless ``x0`` is given. Attribute ``status`` is ``"completed"``,
        ``"diverged"`` or ``"failed"`` (the error control could not meet ``rtol`` above the
        smallest step); such a run is cut at its last sample (``t_stop``). Dormand-Prince and Rodas4 runs
        carry ``steps``, ``rejected_steps``, ``rhs_calls``, ``min_step`` and the located events
        (``event_time``, ``event_kind`` over ``event``: contact_opens / contact_closes / stick /
        slip). A linear contact whose normal force pulls has ``tensile_fraction`` > 0 and
        ``min_normal_force`` < 0 and warns (:class:`TensileContactWarning`).

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> from squealkit.transient import SineRunOut, simulate
    >>> ds = simulate(get_preset("lv2013"), mu=0.4, profile=SineRunOut(0.08e-3, 1e-3),
    ...               speed=0.02, duration=0.01, fs=40_000)
    >>> ds.attrs["status"], ds.sizes["time"]
    ('completed', 401)
    """
    validate_model(model)
    runs = _as_runs([model], [mu], [profile], [speed])
    raw = _integrate(
        runs, duration=duration, fs=fs, contact=as_contact(contact), x0=x0, v0=v0, perturbation=perturbation,
        rng=rng, x_start=x_start, dt=dt, limit=limit, progress=progress, method=method, rtol=rtol, atol=atol,
        memory_hint="Stream it to a file block by block: simulate_blocks and io.save_blocks (CLI: --out FILE.nc).",
    )
    n_keep = max(1, int(raw["n_valid"][0]))
    status = _STATUS[int(raw["status"][0])]
    ds = _run_dataset(runs[0], raw, 0, n_keep)
    ds.attrs.update(_attrs(runs[0], raw, status, float(raw["time"][n_keep - 1]), validate_fs(fs)))
    ds = _with_events(ds, raw, 0)
    _warn_tensile(ds)
    return ds


#: Samples per block of :func:`simulate_blocks` by default (about 10 MB for the paper's model).
BLOCK_SAMPLES = 1 << 16


def simulate_blocks(
    model: FrictionModel,
    *,
    mu: float,
    profile: SurfaceProfile | None = None,
    speed: float = 0.02,
    duration: float,
    fs: float = 40_000.0,
    contact: Contact | str = "linear",
    x0: ArrayLike | None = None,
    v0: ArrayLike | None = None,
    perturbation: float = 0.0,
    rng: np.random.Generator | None = None,
    x_start: float = 0.0,
    dt: float | None = None,
    limit: float = 1.0,
    progress: Progress | None = None,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
    block_samples: int = BLOCK_SAMPLES,
) -> Iterator[xr.Dataset]:
    """The run of :func:`simulate`, block by block along ``time``: memory bounded for any duration.

    The integrator runs in the same chunks as :func:`simulate` and carries its state from one to
    the next, so the blocks put together (``xarray.concat(blocks, "time")``) equal
    :func:`simulate`'s result bit for bit. Write them with :func:`squealkit.io.save_blocks`.
    The inputs are checked when this is called, before the first block.

    Parameters
    ----------
    model : FrictionModel
        The system, e.g. ``get_preset("lv2013")``.
    mu, profile, speed, duration, fs, contact, x0, v0, perturbation, rng, x_start, dt, limit : object
        As for :func:`simulate`.
    progress, method, rtol, atol : object
        As for :func:`simulate`.
    block_samples : int
        Samples per block (the last one holds what is left, at least one sample).

    Yields
    ------
    xarray.Dataset
        The variables of :func:`simulate` over consecutive pieces of ``time``. Only the last
        block carries the attributes (status, steps, ``tensile_fraction`` over the whole
        run...) and the located events (``event_time``, ``event_kind``); the others have none.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> blocks = simulate_blocks(get_preset("lv2013"), mu=0.4, duration=0.01, block_samples=100)
    >>> [b.sizes["time"] for b in blocks]
    [100, 100, 100, 100, 1]
    """
    validate_model(model)
    if isinstance(block_samples, bool) or not isinstance(block_samples, int | np.integer) or block_samples < 1:
        raise InputError(f"Parameter block_samples={block_samples!r} must be an integer >= 1.")
    runs = _as_runs([model], [mu], [profile], [speed])
    setup = _prepare(
        runs, duration=duration, fs=fs, contact=as_contact(contact), x0=x0, v0=v0, perturbation=perturbation,
        rng=rng, x_start=x_start, dt=dt, limit=limit, method=method, rtol=rtol, atol=atol,
    )
    return _stream(runs[0], setup, progress, int(block_samples))


def _stream(run: _Run, setup: dict[str, Any], progress: Progress | None, block: int) -> Iterator[xr.Dataset]:
    fs = setup["fs"]
    pending: list[xr.Dataset] = []
    n_pending = n_kept = n_tensile = 0
    min_force, any_force = math.inf, False

    def take(k: int) -> xr.Dataset:
        nonlocal pending, n_pending
        whole = pending[0] if len(pending) == 1 else xr.concat(pending, "time", combine_attrs="override")
        out, rest = whole.isel(time=slice(0, k)), whole.isel(time=slice(k, None))
        pending, n_pending = ([rest] if rest.sizes["time"] else []), n_pending - k
        return out

    for first, (x, v, a, nc, me) in _chunks(setup, progress):
        valid = min(int(setup["n_valid"][0]), first + x.shape[1]) - first
        if first == 0:
            valid = max(valid, 1)  # as simulate: a run that fails at once keeps its first sample
        if valid <= 0:
            break
        raw = {"time": np.arange(first, first + valid) / fs, "x": x, "v": v, "a": a, "nc": nc, "me": me,
               "x_start": setup["x_start"], "contact": setup["contact"]}
        part = _run_dataset(run, raw, 0, valid)
        part.attrs = {}
        normal = part["normal_force"].values
        if setup["contact"].is_linear and np.isfinite(normal).any():
            any_force = True
            n_tensile += int(np.sum(normal < 0.0))
            min_force = min(min_force, float(np.nanmin(normal)))
        n_kept += valid
        pending.append(part)
        n_pending += valid
        while n_pending > block:  # keep at least one sample back: the last block carries the attributes
            yield take(block)
    last = take(n_pending)
    attrs: dict[str, Any] = {}
    if any_force:
        attrs = {"tensile_fraction": float(n_tensile / n_kept), "min_normal_force": min_force}
    attrs.update(_attrs(run, setup, _STATUS[int(setup["status"][0])], float((n_kept - 1) / fs), fs))
    last.attrs = attrs
    last = _with_events(last, setup, 0)
    _warn_tensile(last)
    yield last


def simulate_batch(
    models: FrictionModel | Sequence[FrictionModel],
    *,
    mu: float | ArrayLike,
    profiles: SurfaceProfile | Sequence[SurfaceProfile | None] | None = None,
    speed: float | ArrayLike = 0.02,
    duration: float,
    fs: float = 40_000.0,
    contact: Contact | str = "linear",
    x0: ArrayLike | None = None,
    perturbation: float = 0.0,
    rng: np.random.Generator | None = None,
    x_start: float = 0.0,
    dt: float | None = None,
    limit: float = 1.0,
    progress: Progress | None = None,
    store: str | Path | None = None,
    client: Any = None,
    runs_per_task: int = 16,
    method: str = "dopri5",
    rtol: float = 1e-8,
    atol: float | None = None,
) -> xr.Dataset:
    """Many runs at once, in parallel over runs (numba ``prange``, all cores).

    Each of ``models``, ``mu``, ``profiles`` and ``speed`` is one value for all runs or one
    per run; the runs are their broadcast. All models need the same DOFs. RK4's step ``dt``
    is the smallest any run needs; Dormand-Prince steps each run on its own (``method``,
    ``rtol``, ``atol`` as for :func:`simulate`), so a run's numbers do not depend on the
    batch. Returns the variables of :func:`simulate` with a leading ``run`` dimension and
    per-run ``status`` (``"completed"``/``"diverged"``/``"failed"``), ``mu``, ``speed``,
    ``tensile_fraction`` and ``min_normal_force`` (linear contact), and with Dormand-Prince
    ``steps`` and ``events``; samples after a divergence are NaN.

    With ``store`` (a ``.zarr`` path) the runs are computed ``runs_per_task`` at a time and
    written piece by piece into the store, which is returned opened lazily; with
    ``client`` (a ``distributed.Client``) the pieces run on that Dask cluster. The step
    and the perturbations are fixed for the whole batch up front, so the numbers are
    identical to the in-memory run.

    Parameters
    ----------
    models : FrictionModel or sequence of FrictionModel
        One model for all runs, or one per run (same DOFs).
    mu : float or array_like
        Friction coefficient(s), one or one per run.
    profiles : SurfaceProfile or sequence of SurfaceProfile or None, optional
        Disc surface(s), one or one per run (None: :class:`~squealkit.transient.profiles.Smooth`).
    speed : float or array_like, default 0.02
        Sliding speed(s) [m/s], one or one per run.
    duration : float
        Simulated time [s].
    fs : float, default 40000.0
        Output sample rate [Hz].
    contact : Contact or {"linear", "nonlinear"}, default "linear"
        Contact law, the same for all runs.
    x0 : array_like, shape (n,), optional
        Initial displacements [m] of every run (default: the static equilibrium of each).
    perturbation : float, default 0.0
        Standard deviation [m] of a random initial displacement, drawn per run (needs ``rng``).
    rng : numpy.random.Generator, optional
        Source of the perturbations.
    x_start : float, default 0.0
        Position on the profile at t = 0 [m].
    dt : float, optional
        Step [s] as for :func:`simulate`.
    limit : float, default 1.0
        A run whose displacement exceeds ``limit`` [m] stops with status ``"diverged"``.
    progress : callable, optional
        Called as ``progress(done, total)``.
    store : str or Path, optional
        A ``.zarr`` path to stream the runs into (returned opened lazily).
    client : distributed.Client, optional
        Run the pieces on this Dask cluster (needs ``store``).
    runs_per_task : int, default 16
        Runs per piece written to ``store`` (and per Dask task).
    method : {"dopri5", "rosenbrock", "rk4"}, default "dopri5"
        Integrator (see :func:`simulate`).
    rtol : float, default 1e-8
        Relative tolerance of the error control.
    atol : float, optional
        Absolute displacement tolerance [m] (see :func:`simulate`).

    Returns
    -------
    xarray.Dataset
        The variables of :func:`simulate` with a leading ``run`` dimension, and per run
        ``status``, ``mu``, ``speed`` and the contact and step statistics described above.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = simulate_batch(get_preset("lv2013"), mu=[0.2, 0.4], duration=0.002)
    >>> ds.sizes["run"], ds.status.values.tolist()
    (2, ['completed', 'completed'])
    """
    models_l = list(models) if isinstance(models, Sequence) else [models]
    mus = np.atleast_1d(np.asarray(mu, dtype=float)).tolist()
    profs = list(profiles) if isinstance(profiles, Sequence) else [profiles]
    speeds = np.atleast_1d(np.asarray(speed, dtype=float)).tolist()
    runs = _as_runs(models_l, mus, profs, speeds)
    kw = dict(duration=duration, fs=fs, contact=as_contact(contact), x0=x0, perturbation=perturbation, x_start=x_start,
              dt=dt, limit=limit, method=method, rtol=rtol, atol=atol)
    if store is None and client is not None:
        raise InputError("A cluster run streams its result to zarr: pass store='....zarr' with client.")
    if store is None:
        ds = _batch_dataset(runs, rng=rng, progress=progress, **kw)
        tensile = ds["tensile_fraction"].values
        if np.any(tensile > 0):
            warnings.warn(
                f"The normal force of the linear contact was tensile in {int(np.sum(tensile > 0))} of {tensile.size} "
                f"runs (up to {100 * float(tensile.max()):.1f} % of the time; see tensile_fraction): a real contact "
                "opens there. Run with contact='nonlinear' (CLI: --contact nonlinear).",
                TensileContactWarning, stacklevel=2)
        return ds
    if Path(store).suffix.lower() != ".zarr":
        raise InputError(f"Parameter store={str(store)!r} must be a zarr store ending in .zarr.")
    if isinstance(runs_per_task, bool) or not isinstance(runs_per_task, int) or runs_per_task < 1:
        raise InputError(f"Parameter runs_per_task={runs_per_task!r} must be an integer >= 1.")
    n = runs[0].model.n_dof
    if any(r.model.n_dof != n for r in runs):
        raise InputError("All models of a batch must have the same number of degrees of freedom.")
    # one step and one set of perturbations for the whole batch, whatever the pieces
    if _validate_method(method) == "rk4":  # RK4's step is the batch's; Dormand-Prince steps each run alone
        kw["dt"] = _step_size(runs, validate_fs(fs), dt, kw["contact"], "rk4")[0]
    noise = _perturbation_noise(validate_positive("perturbation", perturbation, allow_zero=True), rng, len(runs), n)
    from ..scale import lazy_template, stream_to_zarr

    R = len(runs)
    sample = _batch_piece((runs[:1], 0, noise[:1], kw))
    pieces = [(_batch_piece, (runs[a:a + runs_per_task], a, noise[a:a + runs_per_task], kw), a,
               min(R, a + runs_per_task)) for a in range(0, R, runs_per_task)]
    template = lazy_template(sample, "run", np.arange(R), runs_per_task)
    return stream_to_zarr(store, template, "run", pieces, client=client, progress=progress,
                          name="squealkit-transient")


def _batch_piece(arg: tuple) -> xr.Dataset:
    """Runs ``first, first + 1, ...`` of a streamed batch (a task)."""
    runs, first, noise, kw = arg
    ds = _batch_dataset(runs, rng=noise, progress=None, **kw)
    return ds.assign_coords(run=np.arange(first, first + len(runs)))


def _batch_dataset(runs: Sequence[_Run], *, duration, fs, contact, x0, perturbation, rng, x_start, dt, limit,
                   progress, method="dopri5", rtol=1e-8, atol=None) -> xr.Dataset:
    raw = _integrate(
        runs, duration=duration, fs=fs, contact=contact, x0=x0, v0=None, perturbation=perturbation,
        rng=rng, x_start=x_start, dt=dt, limit=limit, progress=progress, method=method, rtol=rtol, atol=atol,
        memory_hint="Stream the batch run by run: store='....zarr' (CLI: --out FILE.zarr).",
    )
    n_out = raw["time"].size
    parts = [_run_dataset(run, raw, i, n_out) for i, run in enumerate(runs)]
    tensile = [p.attrs.get("tensile_fraction", 0.0) for p in parts]
    min_force = [p.attrs.get("min_normal_force", math.nan) for p in parts]
    ds = xr.concat(parts, dim="run", coords="different", compat="equals", join="exact", combine_attrs="drop")
    ds = ds.assign_coords(run=np.arange(len(runs)))
    ds["status"] = ("run", np.array([_STATUS[int(s)] for s in raw["status"]]))
    ds["mu"] = ("run", np.array([r.mu for r in runs]), {"units": "1"})
    ds["speed"] = ("run", np.array([r.speed for r in runs]), {"units": "m/s"})
    ds["tensile_fraction"] = ("run", np.array(tensile), {"units": "1", "long_name": "share of time the linear "
                                                          "contact pulled (normal force < 0)"})
    ds["min_normal_force"] = ("run", np.array(min_force), {"units": "N"})
    if "counts" in raw:
        ds["steps"] = ("run", raw["counts"][:, 0].astype(np.int64), {"long_name": "accepted steps"})
        ds["events"] = ("run", raw["n_ev"].astype(np.int64), {"long_name": "located contact and stick/slip events"})
        ds["max_step"] = ("run", raw["h_max"], {"units": "s", "long_name": "largest step (the run's stability bound)"})
    # batch attributes may not depend on which runs a piece holds (streamed batches must equal
    # the in-memory one): the per-run steps and bounds are variables, RK4's dt is fixed up front
    integ = _integrator_attrs(raw, 0)
    for k in ("steps", "rejected_steps", "rhs_calls", "min_step", "atol", "dt", "step_bound_modes",
              "step_bound_friction"):
        integ.pop(k, None)
    if raw["method"] == "rk4":
        integ["dt"] = float(raw["dt"])
    ds.attrs.update(
        {"kind": "simulation_batch", "title": "squealkit transient simulation (batch)", "fs": float(fs), **integ,
         "integrator": integ["integrator"].replace("(numba)", "(numba, parallel over runs)"),
         "contact": raw["contact"].describe()}
    )
    return ds
