"""Every unstable mode at each application's conditions (step 2 of a correlation).

Applications with identical operating points (friction, disc speed and parameter scales)
are solved once. Small models (3-DOF, Hoffmann, matrix models) go through the batch
eigenvalue kernels of :mod:`squealkit.stability.eigen` (one call for every distinct point);
FE models reuse one reduced basis (:mod:`squealkit.solvers.reduction`, POD or modal) for
the whole campaign, every eigenpair checked by its backward error in the full model
(``trusted``; an untrusted pair never counts as an unstable mode). With a Dask ``client``
the distinct points are solved in chunks on the cluster.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from .. import __version__
from .._validation import InputError
from ..models import FEModel, FrictionModel

__all__ = ["apply_quantities", "predict_modes"]

#: Distinct operating points per task on a Dask cluster (small models / FE models).
_CHUNK_SMALL = 1 << 14
_CHUNK_FE = 64
#: Quantities a correlation handles itself (the others are model parameters).
CONDITION_QUANTITIES = ("mu_offset", "mu_scale")


def apply_quantities(model: Any, values: Mapping[str, float]) -> Any:
    """The model with named quantities applied: ``NAME = value`` sets a parameter, ``NAME_scale``
    scales it, ``damping_scale`` scales the damping (every ``N s/m`` parameter; ``D1`` and ``D4``
    of an FE model). ``mu_offset``/``mu_scale`` belong to the conditions and are skipped here.

    Parameters
    ----------
    model : FrictionModel or FEModel
        The model.
    values : mapping of str to float
        Quantity name -> value.

    Returns
    -------
    FrictionModel or FEModel
        A new model (the given one is unchanged).

    Raises
    ------
    InputError
        For a name that is no parameter of the model (the message lists the known ones).

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> apply_quantities(get_preset("lv2013"), {"k1_scale": 2.0}).k1
    17090000.0
    """
    changes: dict[str, Any] = {}
    for name, v in values.items():
        if name in CONDITION_QUANTITIES:
            continue
        if isinstance(model, FEModel):
            mats = ("D1", "D4") if name == "damping_scale" else (name.removesuffix("_scale"),)
            if name.endswith("_scale"):
                for m in mats:
                    if m not in model.present:
                        if name == "damping_scale":
                            continue
                        raise InputError(f"{name}: the FE model has no matrix {m!r} (it has "
                                         f"{', '.join(model.present)}).")
                    changes[m] = float(v) * changes.get(m, getattr(model, m))
            elif name in ("omega_ref", "mu_ref", "f_ref"):
                changes[name] = float(v)
            else:
                raise InputError(f"{name!r} is no quantity of an FE model; known: omega_ref, mu_ref, f_ref, "
                                 f"damping_scale, and NAME_scale of its matrices ({', '.join(model.present)}).")
            continue
        info = model.parameter_info()
        if name == "damping_scale":
            for k, meta in info.items():
                if meta["unit"].startswith("N s/m"):
                    changes[k] = float(v) * np.asarray(changes.get(k, getattr(model, k)))
            if not any(meta["unit"].startswith("N s/m") for meta in info.values()):
                raise InputError(f"damping_scale: the {model.kind!r} model has no damping parameter.")
        elif name.endswith("_scale") and name.removesuffix("_scale") in info:
            k = name.removesuffix("_scale")
            changes[k] = float(v) * np.asarray(changes.get(k, getattr(model, k)))
        elif name in info:
            changes[name] = float(v)
        else:
            known = ", ".join([*CONDITION_QUANTITIES, "damping_scale", *sorted(info), "NAME_scale"])
            raise InputError(f"{name!r} is no quantity of the {model.kind!r} model; known: {known}.")
    changes = {k: (float(x) if np.ndim(x) == 0 else x) for k, x in changes.items()}
    return model.replace(**changes) if changes else model


def _distinct(points: xr.Dataset, scale_names: list[str], *, speed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Distinct operating points: ``(keys (D, 2 + L), inverse (A,))``.

    Columns of a key: mu, disc speed (``speed``: the model depends on it; else 0), then one
    scale per parameter law.
    """
    w = np.nan_to_num(points["disc_speed"].values, nan=-1.0) if speed else np.zeros(points.sizes["application"])
    cols = [points["mu"].values, w]
    cols += [points[f"scale_{n}"].values for n in scale_names]
    keys, inverse = np.unique(np.column_stack(cols), axis=0, return_inverse=True)
    return keys, inverse.ravel()


def _small_task(item: tuple) -> tuple[np.ndarray, ...]:
    """Eigenvalues of distinct points of small models (a Dask task): per point
    ``(lam, err, verdict, thr)`` from :func:`squealkit.stability.eigen._solve_models`."""
    from .._threads import limit_threads, threads_for
    from ..stability.eigen import _solve_grid, _solve_models, check_magnitudes

    models, which, mu, t, damped = item
    if len(models) == 1:
        with limit_threads(threads_for(mu.size)):
            lam, err, verdict, thr = _solve_grid(models[0], mu, t, damped)
        return lam, err, verdict, thr
    n = models[0].n_dof
    mats = [np.empty((len(models), n, n)) for _ in range(5)]
    for s, m in enumerate(models):
        mats[0][s] = m.mass_matrix()
        mats[1][s] = m.damping_matrix() if damped else 0.0
        mats[2][s], mats[3][s], mats[4][s] = m.stiffness_parts()
    check_magnitudes(*mats)
    s = models[0].sliding_direction
    g = np.ascontiguousarray(1.0 - mu * t)
    e = np.ascontiguousarray(s * (mu + t))
    with limit_threads(threads_for(mu.size)):
        return _solve_models(tuple(mats), which.astype(np.int64), g, e)


def _predict_small(model: FrictionModel, points: xr.Dataset, scale_names: list[str], *, damped: bool,
                   theta: float, client: Any) -> dict[str, Any]:
    from .._threads import limit_threads, threads_for
    from ..scale import map_tasks
    from ..stability._schema import UNSTABLE_RTOL
    from ..stability._verdicts import derived_quantities

    keys, inverse = _distinct(points, scale_names, speed=False)  # (no speed in a small model without a law)
    # one model per distinct set of parameter scales
    mkeys, which = np.unique(keys[:, 2:], axis=0, return_inverse=True) if scale_names else \
        (np.empty((1, 0)), np.zeros(keys.shape[0], dtype=np.int64))
    which = which.ravel()
    models = [model if not scale_names else apply_quantities(
        model, {f"{n}_scale" if n != "damping" else "damping_scale": float(v) for n, v in zip(scale_names, mk,
                                                                                           strict=True)})
        for mk in mkeys]
    # points of a model together, by increasing mu (warm starts along the row)
    order = np.lexsort((keys[:, 0], which))
    t = math.tan(theta)
    D = keys.shape[0]
    n = model.n_dof
    lam = np.empty((D, n), dtype=complex)
    err = np.empty((D, n))
    verdict = np.empty(D, dtype=np.int8)
    thr = np.empty(D)
    chunks = [order[a:a + _CHUNK_SMALL] for a in range(0, D, _CHUNK_SMALL)]
    items = []
    for idx in chunks:
        used, local = np.unique(which[idx], return_inverse=True)
        items.append(([models[u] for u in used], local.ravel(), np.ascontiguousarray(keys[idx, 0]), t, damped))
    for i, res in map_tasks(_small_task, items, client=client, name="squealkit-correlate"):
        idx = chunks[i]
        lam[idx], err[idx], verdict[idx], thr[idx] = res
    with limit_threads(threads_for(D)):  # a few points: no parallel start-up (7.7 ms of 7.7 ms for 25 points)
        sigma, omega, zeta, unstable, _smax, _any, _locked = derived_quantities(
            np.ascontiguousarray(lam), np.ascontiguousarray(err), thr, verdict, 1e-3)
    return {"keys": keys, "inverse": inverse, "sigma": sigma, "omega": omega, "zeta": zeta, "unstable": unstable,
            "verdict": verdict, "residual": np.full(sigma.shape, np.nan), "n_models": len(models),
            "unstable_rtol": UNSTABLE_RTOL}


def _fe_task(item: tuple) -> list[tuple[np.ndarray, np.ndarray]]:
    """Eigenvalues and full-model residuals of distinct FE points (a Dask task)."""
    from threadpoolctl import threadpool_limits

    solvers, which, omega, mu, t = item
    out = []
    with threadpool_limits(1, user_api="blas"):
        for s, w, m in zip(which, omega, mu, strict=True):
            sol = solvers[s].solve(float(w), float(m), t, vectors=False)
            out.append((sol.eigenvalues, sol.residuals))
    return out


def _predict_fe(model: FEModel, points: xr.Dataset, scale_names: list[str], *, theta: float, client: Any,
                method: str, band: tuple[float, float] | None, n_modes: int | None) -> dict[str, Any]:
    from ..scale import map_tasks
    from ..solvers import reduction
    from ..stability.fe_sweep import FESolver, _point_arrays

    w = points["disc_speed"].values
    if not np.all(np.isfinite(w) & (w > 0)):
        raise InputError("An FE model needs every application's disc speed (> 0): an rpm in the campaign, or "
                         "[correlate] disc_speed = \"vehicle\" with rolling_radius.")
    keys, inverse = _distinct(points, scale_names, speed=True)
    t = math.tan(theta)
    mkeys, which = np.unique(keys[:, 2:], axis=0, return_inverse=True) if scale_names else \
        (np.empty((1, 0)), np.zeros(keys.shape[0], dtype=np.int64))
    which = which.ravel()
    samples = None
    if method == "pod":  # the campaign's corners and centre of (disc speed, mu)
        wl, wh = float(keys[:, 1].min()), float(keys[:, 1].max())
        ml, mh = float(keys[:, 0].min()) + t, float(keys[:, 0].max()) + t
        ws = np.array([wl, wh, wl, wh, (wl + wh) / 2])
        ms = np.array([ml, ml, mh, mh, (ml + mh) / 2])
        pairs = np.unique(np.column_stack([ws, ms]), axis=0)  # (a campaign at one speed: fewer snapshots)
        samples = (pairs[:, 0], pairs[:, 1])
    base = FESolver(model, method, band, n_modes, samples)
    solvers = []
    for mk in mkeys:
        if not scale_names:
            solvers.append(base)
            continue
        variant = apply_quantities(model, {f"{n}_scale" if n != "damping" else "damping_scale": float(v)
                                           for n, v in zip(scale_names, mk, strict=True)})
        s = copy.copy(base)
        s.model = variant
        if base.reduced is not None:  # the same basis, the variant's matrices projected on it
            s.reduced = reduction.reduce(variant, base.reduced.V)
        solvers.append(s)
    D = keys.shape[0]
    chunks = [np.arange(a, min(D, a + _CHUNK_FE)) for a in range(0, D, _CHUNK_FE)]
    results: list[Any] = [None] * D
    items = [(solvers, which[c], keys[c, 1], keys[c, 0], t) for c in chunks]
    for i, res in map_tasks(_fe_task, items, client=client, name="squealkit-correlate-fe"):
        for j, r in zip(chunks[i], res, strict=True):
            results[j] = r
    width = max(1, max(r[0].size for r in results))
    lam = np.full((D, width), np.nan + 1j * np.nan)
    res = np.full((D, width), np.nan)
    for j, (ev, rr) in enumerate(results):
        lam[j, :ev.size], res[j, :ev.size] = ev, rr
    valid = np.isfinite(lam)
    _err, unstable, verdict, _thr = _point_arrays(np.where(valid, lam, 0.0), np.where(np.isfinite(res), res, 0.0),
                                                  valid)
    mag = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(mag > 0, -lam.real / mag, 0.0)
    from ..stability._schema import UNSTABLE_RTOL

    return {"keys": keys, "inverse": inverse, "sigma": lam.real, "omega": lam.imag, "zeta": zeta,
            "unstable": unstable & valid, "verdict": verdict, "residual": res, "n_models": len(solvers),
            "method": base.method, "basis_size": 0 if base.reduced is None else base.reduced.n_reduced,
            "band_hz": list(base.band) if base.band is not None else "all", "unstable_rtol": UNSTABLE_RTOL}


def predict_modes(model: Any, points: xr.Dataset, *, damped: bool = True, client: Any = None,
                  method: str = "pod", band: tuple[float, float] | None = None,
                  n_modes: int | None = None) -> xr.Dataset:
    """Every mode, and which are unstable, at each application's operating point.

    Parameters
    ----------
    model : FrictionModel or FEModel
        The model (3-DOF, Hoffmann, matrix or FE).
    points : xarray.Dataset
        :func:`~squealkit.correlate.conditions.operating_points`: ``mu`` and ``disc_speed``
        [rad/s] per application, ``scale_NAME`` per parameter law; attribute ``theta`` [rad].
    damped : bool, default True
        Include the damping of a small model (an FE model's damping is always included).
    client : distributed.Client, optional
        Solve the distinct points on this Dask cluster.
    method : {"pod", "modal", "dense", "sparse"}, default "pod"
        FE models: the solver; ``pod`` and ``modal`` build one reduced basis for the campaign.
    band : (float, float), optional
        FE models: frequency band [Hz] of the modes (default 1-16 kHz for reduced solvers).
    n_modes : int, optional
        FE models: reduced basis size.

    Returns
    -------
    xarray.Dataset
        Over ``(application, mode)``: ``frequency_hz`` [Hz], ``growth_rate`` [1/s],
        ``damping_ratio`` [1], ``unstable`` (bool), ``residual`` (FE: backward error in the
        full model); over ``application``: ``mu``, ``disc_speed`` [rad/s], ``n_unstable``,
        ``verdict`` (``stable``, ``flutter``, ``divergence``, ``indeterminate``). Modes are
        ordered by frequency at each point. Attributes: ``distinct_points`` (solved), ``model``,
        ``kind`` ``"predicted_modes"``.

    Raises
    ------
    InputError
        For an unknown model kind or a quantity the model lacks.
    """
    from ..stability._solve import VERDICTS

    theta = float(points.attrs.get("theta", 0.0))
    scale_names = [str(v).removeprefix("scale_") for v in points.data_vars if str(v).startswith("scale_")]
    if isinstance(model, FEModel):
        r = _predict_fe(model, points, scale_names, theta=theta, client=client, method=method, band=band,
                        n_modes=n_modes)
    elif isinstance(model, FrictionModel):
        if method not in ("pod",) or band is not None or n_modes is not None:
            raise InputError("method, band and n_modes apply to FE models only.")
        r = _predict_small(model, points, scale_names, damped=damped, theta=theta, client=client)
    else:
        raise InputError(f"model must be a squealkit model (a preset, a model file's), not {type(model).__name__}.")
    inv = r["inverse"]
    freq = r["omega"][inv] / (2 * math.pi)
    unstable = r["unstable"][inv]
    attrs = {"kind": "predicted_modes", "model": model.to_json(), "model_kind": model.kind,
             "damped": int(damped or isinstance(model, FEModel)),
             "distinct_points": int(r["keys"].shape[0]), "distinct_models": int(r["n_models"]),
             "unstable_rtol": r["unstable_rtol"], "theta": theta, "squealkit_version": __version__}
    for k in ("method", "basis_size", "band_hz"):
        if k in r:
            attrs[k] = r[k]
    return xr.Dataset(
        {
            "frequency_hz": (("application", "mode"), freq, {"units": "Hz", "long_name": "frequency"}),
            "growth_rate": (("application", "mode"), r["sigma"][inv], {"units": "1/s", "long_name": "growth rate"}),
            "damping_ratio": (("application", "mode"), r["zeta"][inv],
                              {"units": "1", "long_name": "damping ratio -sigma/|lambda|"}),
            "unstable": (("application", "mode"), unstable, {"long_name": "mode unstable"}),
            "residual": (("application", "mode"), r["residual"][inv],
                         {"units": "1", "long_name": "backward error in the full model (FE)"}),
            "mu": ("application", points["mu"].values, {"units": "1", "long_name": "the model's friction"}),
            "disc_speed": ("application", points["disc_speed"].values, {"units": "rad/s"}),
            "n_unstable": ("application", unstable.sum(axis=1), {"long_name": "unstable modes"}),
            "verdict": ("application", np.asarray(VERDICTS)[r["verdict"][inv]]),
        },
        coords={"application": points["application"].values, "mode": np.arange(freq.shape[1])},
        attrs=attrs,
    )
