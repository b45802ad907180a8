"""The correlation report: a section whose prose is generated from the correlation's numbers."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .document import FigureRef, Section, Table

__all__ = ["write_correlation_report"]


def _pct(k: int, n: int) -> str:
    return f"{100.0 * k / n:.0f} %" if n else "n/a"


def correlation_section(ds: Any, figures: tuple[FigureRef, ...] = ()) -> Section:
    """The report section of a correlation: what agreed, what did not, and the calibration.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`squealkit.correlate.correlate`'s result.
    figures : tuple of FigureRef
        The figures written for it.

    Returns
    -------
    Section
    """
    a = ds.attrs
    n, hits, miss, over, quiet = (int(a[k]) for k in ("applications", "hits", "misses", "over_predictions", "quiet"))
    squeal = hits + miss
    pred = int(np.sum(ds["n_unstable"].values > 0))
    agree = hits + quiet
    paras = [
        f"{n} applications of the campaign were compared with the {a.get('model_kind', 'model')!r} model; a measured "
        f"squeal component counts as predicted when an unstable mode lies within {a['tolerance_percent']:g} % of its "
        f"frequency. The model agrees with the test on {agree} of {n} applications ({_pct(agree, n)}): "
        f"{hits} hits and {quiet} quiet.",
        f"Of the {squeal} applications that squealed, the model predicted {hits} ({_pct(hits, squeal)}); "
        f"it missed {miss} (under-prediction). It predicted an unstable mode in {pred} applications, of which "
        f"{over} were quiet on the dynamometer (over-prediction: {_pct(over, pred)} of its predictions)"
        + (", the usual weakness of complex eigenvalue analysis." if pred and over / pred > 0.3 else "."),
        f"{a.get('distinct_points', n)} distinct operating points were solved for the {n} applications"
        + (f" with one reduced basis of {a['basis_size']} vectors ({a.get('method')})" if a.get("basis_size") else "")
        + f"; friction from {a.get('mu_source', 'the matrix')}"
        + (f" ({a['friction_law']})" if a.get("friction_law") else "") + ".",
    ]
    rates = [(int(m), int(ds["mode_predicted"].values[i]), ds["mode_hit_rate"].values[i],
              ds["mode_over_prediction_rate"].values[i], float(np.nanmedian(ds["frequency_hz"].values[:, i])))
             for i, m in enumerate(ds["mode"].values) if ds["mode_predicted"].values[i] > 0]
    if rates:
        worst = max(rates, key=lambda r: (np.nan_to_num(r[3]), r[1]))
        paras.append(f"Mode {worst[0]} (about {worst[4]:.0f} Hz) is predicted unstable in {worst[1]} applications "
                     f"with an over-prediction rate of {worst[3]:.0f} %.")
    tables = [Table("Outcomes", ("outcome", "applications", "share [%]"),
                    tuple((k, v, 100.0 * v / n if n else math.nan)
                          for k, v in (("hit", hits), ("miss", miss), ("over-prediction", over), ("quiet", quiet)))),
              Table("Per mode", ("mode", "median frequency [Hz]", "predicted unstable", "hit rate [%]",
                                 "over-prediction rate [%]"), tuple((r[0], r[4], r[1], r[2], r[3]) for r in rates)),
              Table("Per 1/3-octave band", ("band [Hz]", "predicted", "hit rate [%]", "over-prediction rate [%]",
                                            "measured", "detection rate [%]"),
                    tuple((f"{lo:.0f}-{hi:.0f}", int(p), h, o, int(m), d) for lo, hi, p, h, o, m, d in zip(
                        ds["band_lo_hz"].values, ds["band_hi_hz"].values, ds["band_predicted"].values,
                        ds["band_hit_rate"].values, ds["band_over_prediction_rate"].values,
                        ds["band_measured"].values, ds["band_detection_rate"].values, strict=True)
                        if p or m))]
    if "calibration" in a:
        cal = json.loads(a["calibration"])
        b, f = cal["before"], cal["after"]
        paras.append(f"Calibration ({cal['objective']}): the wrong applications went from "
                     f"{b['misses'] + b['over_predictions']} to {f['misses'] + f['over_predictions']} "
                     f"(hits {b['hits']} -> {f['hits']}).")
        for name, q in cal["quantities"].items():
            lo, hi = q["interval"]
            if not q["identifiable"]:
                paras.append(f"{name} is not identifiable from this campaign: every value in its bounds "
                             f"[{q['bounds'][0]:g}, {q['bounds'][1]:g}] fits as well.")
            else:
                edge = " (the interval reaches a bound: widen it)" if lo <= q["bounds"][0] or hi >= q["bounds"][1] \
                    else ""
                paras.append(f"{name} = {q['value']:.4g}; the data allow {lo:.4g} to {hi:.4g}{edge}.")
        tables.append(Table("Calibration", ("quantity", "start", "fit", "interval", "identifiable"),
                            tuple((k, q["start"], q["value"], f"{q['interval'][0]:.4g} to {q['interval'][1]:.4g}",
                                   "yes" if q["identifiable"] else "no") for k, q in cal["quantities"].items())))
    numbers = {"applications": n, "hits": hits, "misses": miss, "over_predictions": over, "quiet": quiet}
    return Section("correlation", "Test against model", tuple(paras), (), tuple(tables), tuple(figures),
                   numbers=numbers)


def write_correlation_report(ds: Any, out: Path, *, synthetic: bool = False) -> Path:
    """Write ``out/report.html`` (figures embedded) and ``out/figures/*.png`` of a correlation.

    Parameters
    ----------
    ds : xarray.Dataset
        :func:`squealkit.correlate.correlate`'s result.
    out : Path
        The (staging) output folder.
    synthetic : bool, default False
        Mark the figures and the report as made from SYNTHETIC recordings.

    Returns
    -------
    Path
        The report.
    """
    from ..plotting import correlate as cp
    from .html import save_figures, write_report

    tol = ds.attrs["tolerance_percent"]
    figs = {
        "noise_matrices_temperature": (cp.noise_matrices_plot(ds, by="temperature", synthetic=synthetic),
                                       "Noise matrices by temperature: measured occurrence (left) and predicted "
                                       "(right), per 1/3-octave band [% of the applications in each column]."),
        "noise_matrices_pressure": (cp.noise_matrices_plot(ds, by="pressure", synthetic=synthetic),
                                    "Noise matrices by pressure: measured (left) and predicted (right)."),
        "noise_map_temperature": (cp.noise_map_plot(ds, by="temperature_c", synthetic=synthetic),
                                  "Noise map: measured squeal components (dots, colour: level) over the predicted "
                                  f"unstable modes (circles); a dot inside a circle is a hit (within {tol:g} %)."),
        "noise_map_pressure": (cp.noise_map_plot(ds, by="pressure_bar", synthetic=synthetic),
                               "Noise map against pressure."),
        "outcomes": (cp.outcome_plot(ds, synthetic=synthetic), "Outcome of each application against its model "
                                                               "friction and temperature."),
    }
    if "calibration" in ds.attrs:
        for name in json.loads(ds.attrs["calibration"])["quantities"]:
            figs[f"profile_{name}"] = (cp.calibration_profile_plot(ds, name),
                                       f"Profile of {name}: applications wrong at each value (others re-fitted); "
                                       "shaded: the interval the data allow.")
    section = correlation_section(ds, save_figures(figs, out / "figures"))
    if synthetic:
        section = Section(section.key, section.title, ("SYNTHETIC DATA: the campaign's recordings were made by "
                                                       "squealkit with known truth; not a measurement.",
                                                       *section.paragraphs),
                          section.comparisons, section.tables, section.figures, numbers=section.numbers)
    return write_report([section], out, title="squealkit test-versus-model correlation",
                        subtitle=f"campaign {ds.attrs.get('campaign', '')}; frequency tolerance {tol:g} %")
