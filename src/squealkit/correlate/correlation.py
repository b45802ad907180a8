"""One entry point: a campaign folder and a model in, the correlation (and a calibration) out."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._validation import InputError
from .calibrate import Calibration, calibrate, parse_fit
from .conditions import (
    ConditionMap,
    FrictionLaw,
    campaign_conditions,
    condition_values,
    fit_friction_law,
    operating_points,
)
from .match import _match_counts, match_modes, measured_components, validate_tolerance
from .predict import CONDITION_QUANTITIES, apply_quantities, predict_modes

__all__ = ["correlate", "load_correlation_model"]


def load_correlation_model(path: str | Path, overrides: Mapping[str, Any] | None = None) -> tuple[Any, ConditionMap]:
    """The model of a model file and its ``[correlate]`` table (defaults without one).

    Parameters
    ----------
    path : str or Path
        The model file (TOML; see :mod:`squealkit.models.config` and
        :mod:`squealkit.correlate.conditions`).
    overrides : mapping, optional
        Parameter values applied after the file's ``[parameters]``.

    Returns
    -------
    model : FrictionModel or FEModel
    conditions : ConditionMap
    """
    from ..models.config import _read_toml, model_from_dict

    p = Path(path)
    doc = _read_toml(p)
    try:
        model = model_from_dict(doc, base_dir=p.parent, overrides=overrides)
        cmap = ConditionMap.from_dict(doc.get("correlate"))
    except InputError as e:
        raise InputError(f"{p.name}: {e}") from e
    return model, cmap


def _campaign_band(campaign_dir: Path) -> tuple[float, float]:
    """The squeal band of the campaign (its summary's 1/3-octave bands), default 2-16 kHz."""
    try:
        bands = json.loads((campaign_dir / "summary.json").read_text())["by_band"]
        return (float(min(b["center_hz"] for b in bands)) * 1.001, float(max(b["center_hz"] for b in bands)) * 1.001)
    except (OSError, ValueError, KeyError, TypeError):
        return (2000.0, 16000.0)


def correlate(
    campaign_dir: str | Path,
    model: Any,
    conditions: ConditionMap | None = None,
    *,
    damped: bool = True,
    tolerance: float = 0.03,
    fit: Mapping[str, tuple[float, float]] | Any = None,
    client: Any = None,
    method: str = "pod",
    band: tuple[float, float] | None = None,
    n_modes: int | None = None,
    rng: np.random.Generator | None = None,
) -> xr.Dataset:
    """Correlate a campaign with a model: predicted unstable modes against measured squeal.

    Parameters
    ----------
    campaign_dir : path
        What ``squealkit campaign --out-dir`` wrote (holds ``campaign.duckdb``).
    model : FrictionModel or FEModel
        The model (any kind).
    conditions : ConditionMap, optional
        How conditions map onto the model (default: the matrix's measured mu, no laws).
    damped : bool, default True
        Include a small model's damping.
    tolerance : float, default 0.03
        Relative frequency tolerance of a match (3 %).
    fit : mapping of str to (float, float), or list of "NAME=LO:HI", optional
        Quantities to calibrate within bounds (``mu_offset``, ``mu_scale``, ``damping_scale``,
        any model parameter, ``NAME_scale``); the result is then the fitted model's.
    client : distributed.Client, optional
        Solve the distinct operating points on this Dask cluster.
    method, band, n_modes
        FE models: solver (``pod``/``modal``: one reduced basis), band [Hz], basis size
        (see :func:`~squealkit.correlate.predict.predict_modes`).
    rng : numpy.random.Generator, optional
        Seeds the calibration's optimiser.

    Returns
    -------
    xarray.Dataset
        Dims ``application``, ``mode``, ``component``, ``band``, ``temperature_bin``,
        ``pressure_bin``: the conditions, the model's ``mu``, the predicted modes
        (``frequency_hz``, ``growth_rate``, ``damping_ratio``, ``unstable``), the measured
        components, the ``outcome`` per application, rates and noise matrices (see
        :func:`~squealkit.correlate.match.match_modes`). Attributes: the counts, ``tolerance``,
        ``friction_law``, ``calibration`` (JSON, with ``fit``) and the model.

    Examples
    --------
    >>> from squealkit.models import get_preset
    >>> ds = correlate("camp/out", get_preset("lv2013"))          # doctest: +SKIP
    >>> ds.attrs["hits"], ds.attrs["tolerance_percent"]           # doctest: +SKIP
    (12, 3.0)
    """
    tol = validate_tolerance(tolerance)
    cmap = ConditionMap() if conditions is None else conditions
    if not isinstance(cmap, ConditionMap):
        raise InputError(f"conditions must be a ConditionMap, not {type(cmap).__name__}.")
    d = Path(campaign_dir)
    apps, events = campaign_conditions(d)
    squeal_band = _campaign_band(d)
    measured = measured_components(apps["application"].values, events, tol)
    law: FrictionLaw | None = None
    if cmap.mu == "law" and cmap.mu_law is None:  # fitted once, to the measured mu, before any calibration
        law = fit_friction_law(condition_values(apps, cmap), apps["mu_measured"].values, cmap.mu_law_terms)
    pred_kw = dict(damped=damped, client=client, method=method, band=band, n_modes=n_modes)

    def predict(values: Mapping[str, float]) -> tuple[xr.Dataset, xr.Dataset]:
        cm = cmap.with_quantities(**{k: v for k, v in values.items() if k in CONDITION_QUANTITIES})
        points = operating_points(apps, cm, mu_law=law)
        m = apply_quantities(model, {k: v for k, v in values.items() if k not in CONDITION_QUANTITIES})
        return points, predict_modes(m, points, **pred_kw)

    def counts(values: Mapping[str, float]) -> xr.Dataset:
        # the calibration weighs thousands of candidates by their counts alone: no labelled matching per candidate
        return xr.Dataset(attrs=_match_counts(predict(values)[1], measured, tolerance=tol))

    cal: Calibration | None = None
    values: dict[str, float] = {}
    if fit is not None:
        bounds = parse_fit(fit)
        start = {n: _current(model, cmap, n) for n in bounds}
        predict(start)  # a bad quantity name is refused before the search
        cal = calibrate(counts, bounds, start, rng=rng)
        values = cal.values
    points, pred = predict(values)
    match = match_modes(pred, measured, points, tolerance=tol, band=squeal_band)
    ds = xr.merge([points.drop_vars([v for v in ("mu",) if v in points]), pred, match], compat="override",
                  combine_attrs="override")
    ds.attrs = {}
    ds.attrs.update({k: match.attrs[k] for k in ("tolerance", "tolerance_percent", "applications", "hits", "misses",
                                                 "over_predictions", "quiet", "frequency_misfit", "matching")})
    ds.attrs.update({k: v for k, v in pred.attrs.items()})
    ds.attrs.update({k: v for k, v in points.attrs.items() if isinstance(v, str | int | float)})
    ds.attrs.update(campaign=str(d), criteria=apps.attrs.get("criteria", ""), synthetic=apps.attrs["synthetic"],
                    squeal_band_hz=list(squeal_band), kind="correlation",
                    title="Predicted unstable modes against measured squeal")
    if law is not None:
        ds.attrs["friction_law"] = law.describe()
    if cal is not None:
        ds.attrs["calibration"] = json.dumps(cal.to_dict(), allow_nan=False)
        ds = ds.merge(cal.profiles)
    return ds


def _current(model: Any, cmap: ConditionMap, name: str) -> float:
    """A quantity's value now: the map's mu_offset/mu_scale, 1 for a scale, else the model's parameter."""
    if name in CONDITION_QUANTITIES:
        return float(getattr(cmap, name))
    if name.endswith("_scale"):
        return 1.0
    v = getattr(model, name, None)
    if v is None or np.ndim(v) != 0:
        return math.nan  # apply_quantities names the problem
    return float(v)
