"""Measured squeal against predicted unstable modes (step 3 of a correlation).

A measured squeal component (the campaign's events of one application, merged where their
frequencies lie within the tolerance of each other) is *matched* when a predicted unstable
mode of that application lies within ``tolerance`` (relative, default 3 %) of its frequency.
Per application:

- ``hit``: squeal measured and at least one component matched;
- ``miss``: squeal measured, no component matched (under-prediction);
- ``over_prediction``: no squeal measured, an unstable mode predicted;
- ``quiet``: neither.

Per mode (index by frequency) and per 1/3-octave band of the predicted frequency: how often
an unstable mode was predicted, the share of those that matched squeal (hit rate) and the
share in quiet applications (over-prediction rate). Noise matrices (SAE J2521 layout):
occurrence [% of applications] per band against temperature and against pressure, measured
(an event in the band) and predicted (an unstable mode in the band).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import xarray as xr

from .._validation import InputError

__all__ = ["OUTCOMES", "PRESSURE_EDGES_BAR", "TEMPERATURE_EDGES_C", "match_modes", "measured_components"]

#: Outcome of an application, in this order (codes 0-3).
OUTCOMES = ("hit", "miss", "over_prediction", "quiet")
#: Bin edges of the noise matrices (the campaign summary's).
TEMPERATURE_EDGES_C = (-math.inf, 50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 400.0, math.inf)
PRESSURE_EDGES_BAR = (-math.inf, 5.0, 10.0, 15.0, 20.0, 30.0, 40.0, math.inf)


def validate_tolerance(tolerance: float) -> float:
    """A relative frequency tolerance in (0, 0.5]: one line naming the value otherwise."""
    try:
        t = float(tolerance)
    except (TypeError, ValueError):
        raise InputError(f"Parameter tolerance={tolerance!r} must be a number (relative, e.g. 0.03).") from None
    if not (math.isfinite(t) and 0.0 < t <= 0.5):
        raise InputError(f"Parameter tolerance={tolerance!r} must be > 0 and <= 0.5 (relative: 0.03 is 3 %).")
    return t


def measured_components(applications: Any, events: Any, tolerance: float = 0.03) -> xr.Dataset:
    """Each application's squeal components: its events merged where within ``tolerance`` of each other.

    Parameters
    ----------
    applications : array_like of str
        Application ids (the order of the result).
    events : pandas.DataFrame
        ``application``, ``frequency_hz`` [Hz], ``peak_dba`` [dB(A)] per event.
    tolerance : float
        Relative frequency tolerance.

    Returns
    -------
    xarray.Dataset
        Over ``(application, component)``: ``measured_hz`` [Hz] (the loudest event's frequency
        of the component; NaN where an application has fewer) and ``measured_dba`` [dB(A)];
        ``kind`` ``"measured_components"``.
    """
    tol = validate_tolerance(tolerance)
    apps = [str(a) for a in np.asarray(applications)]
    by_app: dict[str, list[tuple[float, float]]] = {a: [] for a in apps}
    for a, f, lvl in zip(events["application"], events["frequency_hz"], events["peak_dba"], strict=True):
        if a in by_app and math.isfinite(f):
            by_app[a].append((float(f), float(lvl)))
    comps: dict[str, list[tuple[float, float]]] = {}
    for a, evs in by_app.items():
        evs.sort()
        groups: list[list[tuple[float, float]]] = []
        for f, lvl in evs:
            if groups and f - groups[-1][-1][0] <= tol * f:
                groups[-1].append((f, lvl))
            else:
                groups.append([(f, lvl)])
        comps[a] = [max(g, key=lambda x: x[1]) for g in groups]
    width = max(1, max(len(c) for c in comps.values()))
    hz = np.full((len(apps), width), np.nan)
    dba = np.full((len(apps), width), np.nan)
    for i, a in enumerate(apps):
        for j, (f, lvl) in enumerate(comps[a]):
            hz[i, j], dba[i, j] = f, lvl
    return xr.Dataset({"measured_hz": (("application", "component"), hz, {"units": "Hz"}),
                       "measured_dba": (("application", "component"), dba, {"units": "dB(A)"})},
                      coords={"application": apps, "component": np.arange(width)},
                      attrs={"kind": "measured_components"})


def _bin_labels(edges: tuple[float, ...], unit: str) -> list[str]:
    out = []
    for lo, hi in itertools.pairwise(edges):
        out.append(f"< {hi:g} {unit}" if not math.isfinite(lo) else f">= {lo:g} {unit}" if not math.isfinite(hi)
                   else f"{lo:g}-{hi:g} {unit}")
    return out


def _bin_index(x: np.ndarray, edges: tuple[float, ...]) -> np.ndarray:
    """Bin of each value (-1 for NaN)."""
    idx = np.searchsorted(np.asarray(edges[1:-1]), x, side="right")
    return np.where(np.isfinite(x), idx, -1)


def _outcomes(f_pred: np.ndarray, f_meas: np.ndarray, tol: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The matching itself: per application its outcome code (:data:`OUTCOMES`), which components
    ``(A, C)`` and unstable modes ``(A, M)`` matched, and the frequency misfit of the matched
    components (mean squared error in tolerances: the calibration's tie-breaker).

    ``f_pred``: the unstable modes' frequencies (NaN where stable), ``f_meas``: the components'.
    """
    with np.errstate(invalid="ignore"):
        diff = np.abs(f_meas[:, :, None] - f_pred[:, None, :])  # (A, C, M)
        close = diff <= tol * f_meas[:, :, None]
        err = np.where(close, diff / (tol * f_meas[:, :, None]), np.inf)
    comp_matched = close.any(axis=2)
    squeal = np.isfinite(f_meas).any(axis=1)
    predicted_any = np.isfinite(f_pred).any(axis=1)
    outcome = np.where(squeal, np.where(comp_matched.any(axis=1), 0, 1), np.where(predicted_any, 2, 3))
    best = err.min(axis=2, initial=np.inf)
    misfit = float(np.mean(best[np.isfinite(best)] ** 2)) if np.isfinite(best).any() else 0.0
    return outcome, comp_matched, close.any(axis=1), misfit


def _counts(outcome: np.ndarray) -> dict[str, int]:
    return {"hits": int((outcome == 0).sum()), "misses": int((outcome == 1).sum()),
            "over_predictions": int((outcome == 2).sum()), "quiet": int((outcome == 3).sum())}


def _match_counts(predicted: xr.Dataset, measured: xr.Dataset, *, tolerance: float = 0.03) -> dict[str, float]:
    """The counts of :func:`match_modes` alone (what a calibration weighs, thousands of times).

    Parameters
    ----------
    predicted, measured, tolerance
        As for :func:`match_modes`; ``measured`` over the same applications in the same order.

    Returns
    -------
    dict
        ``hits``, ``misses``, ``over_predictions``, ``quiet`` and ``frequency_misfit``: the
        attributes of :func:`match_modes` of the same arguments.
    """
    tol = validate_tolerance(tolerance)
    f_meas = measured["measured_hz"].values
    if not np.array_equal(measured["application"].values, predicted["application"].values):
        f_meas = measured.reindex(application=predicted["application"].values)["measured_hz"].values
    f_pred = np.where(predicted["unstable"].values, predicted["frequency_hz"].values, np.nan)
    outcome, _, _, misfit = _outcomes(f_pred, f_meas, tol)
    return {**_counts(outcome), "frequency_misfit": misfit}


def match_modes(predicted: xr.Dataset, measured: xr.Dataset, conditions: xr.Dataset | None = None, *,
                tolerance: float = 0.03, band: tuple[float, float] = (2000.0, 16000.0)) -> xr.Dataset:
    """Match measured squeal components to predicted unstable modes, application by application.

    Parameters
    ----------
    predicted : xarray.Dataset
        :func:`~squealkit.correlate.predict.predict_modes` (``frequency_hz``, ``unstable`` over
        ``(application, mode)``).
    measured : xarray.Dataset
        :func:`measured_components` (``measured_hz`` over ``(application, component)``).
    conditions : xarray.Dataset, optional
        ``temperature_c`` [degC] and ``pressure_bar`` [bar] per application, for the noise matrices.
    tolerance : float, default 0.03
        Relative frequency tolerance of a match (0.03: 3 %).
    band : (float, float), default (2000, 16000)
        Squeal band [Hz] split into the 1/3-octave bands of the rates and matrices.

    Returns
    -------
    xarray.Dataset
        Over ``application``: ``outcome`` (one of :data:`OUTCOMES`), ``predicted_hz`` and
        ``component_matched`` / ``mode_matched`` flags; rates over ``mode`` and ``band`` (the
        1/3-octave bands: ``band_center_hz``, ``band_lo_hz``, ``band_hi_hz`` [Hz]); noise matrices
        ``measured_by_temperature``, ``predicted_by_temperature``, ``measured_by_pressure``,
        ``predicted_by_pressure`` [% of applications] over
        ``(band, temperature_bin)`` and ``(band, pressure_bin)``. Attributes: the counts
        ``hits``, ``misses``, ``over_predictions``, ``quiet``, ``applications`` and ``tolerance``;
        ``kind`` ``"mode_match"``.
    """
    from ..campaign.summary import third_octave_bands

    tol = validate_tolerance(tolerance)
    apps = predicted["application"].values
    meas = measured.reindex(application=apps)
    f_pred = np.where(predicted["unstable"].values, predicted["frequency_hz"].values, np.nan)  # (A, M)
    f_meas = meas["measured_hz"].values  # (A, C)
    outcome, comp_matched, mode_matched, misfit = _outcomes(f_pred, f_meas, tol)
    squeal = np.isfinite(f_meas).any(axis=1)

    bands = third_octave_bands(band)
    centres = np.array([c for c, _, _ in bands])
    lo_edges = np.array([lo for _, lo, _ in bands])
    hi_edges = np.array([hi for _, _, hi in bands])

    def band_of(f: np.ndarray) -> np.ndarray:
        idx = np.searchsorted(hi_edges, f, side="right")
        ok = np.isfinite(f) & (idx < len(bands))
        ok &= f >= lo_edges[np.minimum(idx, len(bands) - 1)]
        return np.where(ok, idx, -1)

    pb, mb = band_of(f_pred), band_of(f_meas)
    quiet_app = ~squeal
    # per mode: predicted unstable, matched, in quiet applications
    n_pred_mode = np.isfinite(f_pred).sum(axis=0)
    hit_mode = (mode_matched & np.isfinite(f_pred)).sum(axis=0)
    over_mode = (np.isfinite(f_pred) & quiet_app[:, None]).sum(axis=0)
    nb = len(bands)
    n_pred_band, hit_band, over_band, n_meas_band, det_band = (np.zeros(nb, int) for _ in range(5))
    for b in range(nb):
        inb = pb == b
        n_pred_band[b] = inb.any(axis=1).sum()
        hit_band[b] = (inb & mode_matched).any(axis=1).sum()
        over_band[b] = (inb.any(axis=1) & quiet_app).sum()
        inm = mb == b
        n_meas_band[b] = inm.any(axis=1).sum()
        det_band[b] = (inm & comp_matched).any(axis=1).sum()

    def rate(k: np.ndarray, n: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(n > 0, 100.0 * k / np.maximum(n, 1), np.nan)

    A = apps.size
    ds = xr.Dataset(
        {
            "outcome": ("application", np.asarray(OUTCOMES)[outcome], {"long_name": "hit, miss, over_prediction or "
                                                                        "quiet", "tolerance": tol}),
            "outcome_code": ("application", outcome.astype(np.int8),
                             {"flag_values": np.arange(4, dtype=np.int8), "flag_meanings": " ".join(OUTCOMES)}),
            "predicted_hz": (("application", "mode"), f_pred, {"units": "Hz",
                                                              "long_name": "frequency of each unstable mode"}),
            "measured_hz": (("application", "component"), f_meas, {"units": "Hz"}),
            "measured_dba": (("application", "component"), meas["measured_dba"].values, {"units": "dB(A)"}),
            "component_matched": (("application", "component"), comp_matched,
                                  {"long_name": f"measured component within {100 * tol:g} % of an unstable mode"}),
            "mode_matched": (("application", "mode"), mode_matched,
                             {"long_name": f"unstable mode within {100 * tol:g} % of a measured component"}),
            "mode_predicted": ("mode", n_pred_mode, {"long_name": "applications where the mode is unstable"}),
            "mode_hit_rate": ("mode", rate(hit_mode, n_pred_mode),
                              {"units": "%", "long_name": "of those, matched to measured squeal"}),
            "mode_over_prediction_rate": ("mode", rate(over_mode, n_pred_mode),
                                          {"units": "%", "long_name": "of those, in quiet applications"}),
            "band_predicted": ("band", n_pred_band, {"long_name": "applications with an unstable mode in the band"}),
            "band_hit_rate": ("band", rate(hit_band, n_pred_band), {"units": "%"}),
            "band_over_prediction_rate": ("band", rate(over_band, n_pred_band), {"units": "%"}),
            "band_measured": ("band", n_meas_band, {"long_name": "applications with squeal in the band"}),
            "band_detection_rate": ("band", rate(det_band, n_meas_band),
                                    {"units": "%", "long_name": "of those, matched to an unstable mode"}),
        },
        coords={"application": apps, "mode": predicted["mode"].values,
                "component": meas["component"].values,
                # the campaign's names (its store's events): frequencies in Hz end in _hz
                "band_center_hz": ("band", centres, {"units": "Hz", "long_name": "1/3-octave band centre"}),
                "band_lo_hz": ("band", lo_edges, {"units": "Hz", "long_name": "1/3-octave band lower edge"}),
                "band_hi_hz": ("band", hi_edges, {"units": "Hz", "long_name": "1/3-octave band upper edge"})},
        attrs={"kind": "mode_match", "tolerance": tol, "tolerance_percent": 100 * tol, "applications": int(A),
               **_counts(outcome), "frequency_misfit": misfit,
               "matching": f"a measured squeal component matches an unstable mode within {100 * tol:g} % "
                           "of its frequency"},
    )
    if conditions is not None:
        cond = conditions.reindex(application=apps)
        for name, var, edges, unit in (("temperature", "temperature_c", TEMPERATURE_EDGES_C, "C"),
                                       ("pressure", "pressure_bar", PRESSURE_EDGES_BAR, "bar")):
            bins = _bin_index(cond[var].values, edges)
            nbins = len(edges) - 1
            meas_m = np.full((nb, nbins), np.nan)
            pred_m = np.full((nb, nbins), np.nan)
            for k in range(nbins):
                sel = bins == k
                n = int(sel.sum())
                if not n:
                    continue
                for b in range(nb):
                    meas_m[b, k] = 100.0 * (mb[sel] == b).any(axis=1).sum() / n
                    pred_m[b, k] = 100.0 * (pb[sel] == b).any(axis=1).sum() / n
            labels = _bin_labels(edges, unit)
            ds = ds.assign_coords({f"{name}_bin": (f"{name}_bin", labels)})
            ds[f"{name}_bin_count"] = (f"{name}_bin", np.bincount(bins[bins >= 0], minlength=nbins))
            ds[f"measured_by_{name}"] = (("band", f"{name}_bin"), meas_m,
                                         {"units": "%", "long_name": f"measured occurrence by band and {name}"})
            ds[f"predicted_by_{name}"] = (("band", f"{name}_bin"), pred_m,
                                          {"units": "%", "long_name": f"predicted occurrence by band and {name}"})
    return ds
