"""The design report: which change removes which unstable mode, in sentences made from the numbers."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from .document import FigureRef, Section, Table

__all__ = ["write_design_report"]


def _g(x: float) -> str:
    return f"{x:+.3g}" if math.isfinite(x) else "n/a"


def countermeasure_table(ds: Any) -> list[dict[str, Any]]:
    """The countermeasure study as rows (one per unstable mode and parameter), best rank first.

    Parameters
    ----------
    ds : xarray.Dataset
        A :func:`squealkit.design.countermeasures` result.

    Returns
    -------
    list of dict
        ``frequency_hz``, ``growth_rate``, ``parameter``, ``unit``, ``nominal``, ``rank``,
        ``effect`` [1/s per step], ``dgrowth_rate_dp``, ``predicted_change``, ``confirmed_change``,
        ``prediction_error``, ``confirmed_growth_rate``, ``solves``, ``status`` (NaN as None
        is left to the JSON writer).
    """
    rows = []
    for i in range(ds.sizes["mode"]):
        for j in np.argsort(ds["rank"].values[i]):
            rows.append({
                "frequency_hz": float(ds["frequency_hz"].values[i]),
                "growth_rate": float(ds["growth_rate"].values[i]),
                "parameter": str(ds["parameter"].values[j]),
                "unit": str(ds["parameter_unit"].values[j]),
                "nominal": float(ds["parameter_nominal"].values[j]),
                "rank": int(ds["rank"].values[i, j]),
                "effect": float(ds["effect"].values[i, j]),
                "dgrowth_rate_dp": float(ds["dgrowth_rate_dp"].values[i, j]),
                "predicted_change": float(ds["predicted_change"].values[i, j]),
                "confirmed_change": float(ds["confirmed_change"].values[i, j]),
                "prediction_error": float(ds["prediction_error"].values[i, j]),
                "confirmed_growth_rate": float(ds["confirmed_growth_rate"].values[i, j]),
                "solves": int(ds["solves"].values[i, j]),
                "status": str(ds["status"].values[i, j]),
            })
    return rows


def _change(ds, k: int, change: float) -> str:
    """``NAME by +0.2 (to 1.2 x nominal)`` for a scale, ``NAME by +0.05 kg`` for a quantity with a unit."""
    name, unit = str(ds["parameter"].values[k]), str(ds["parameter_unit"].values[k])
    nominal = float(ds["parameter_nominal"].values[k]) if "parameter_nominal" in ds.coords else math.nan
    if unit == "1" and nominal == 1.0:
        return f"{name} by {_g(change)}, to {nominal + change:.3g} x nominal,"
    return f"{name} by {_g(change)}" + ("" if unit == "1" else f" {unit}")


def design_sentences(ds: Any) -> list[str]:
    """Sentences, one per unstable mode and one overall, made from a countermeasure study's numbers.

    Parameters
    ----------
    ds : xarray.Dataset
        A :func:`squealkit.design.countermeasures` result.

    Returns
    -------
    list of str
    """
    a = ds.attrs
    where = f"at {a['rpm']:g} rpm and mu = {a['mu']:g}" if "rpm" in a else f"at mu = {a['mu']:g}"
    n = ds.sizes["mode"]
    names = [str(p) for p in ds["parameter"].values]
    if n == 0:
        return [f"The brake has no unstable mode {where} in the band considered: there is nothing to remove."]
    out = [f"{n} mode{'s are' if n > 1 else ' is'} unstable {where}; {len(names)} declared change"
           f"{'s were' if len(names) > 1 else ' was'} studied ({', '.join(names)}), each step counted in the unit "
           "the [design] table gives it."]
    step = ds["parameter_step"].values
    unit = ds["parameter_unit"].values
    for i in range(n):
        f, s = float(ds["frequency_hz"].values[i]), float(ds["growth_rate"].values[i])
        conf = ds["confirmed_change"].values[i]
        steps = np.abs(conf) / step
        head = f"The mode at {f:.0f} Hz" if f >= 100 else f"The mode at {f:.4g} Hz"
        head += f" (growth rate {s:.3g} 1/s)"
        if np.isfinite(steps).any():
            j = int(np.nanargmin(steps))
            pred = float(ds["predicted_change"].values[i, j])
            u = "" if unit[j] == "1" else f" {unit[j]}"
            n_solves = int(ds["solves"].values[i, j])
            text = (f"{head} is removed at the smallest cost by changing {_change(ds, j, float(conf[j])).rstrip(',')} "
                    f"({steps[j]:.2g} declared steps), confirmed by {n_solves} solve{'s' if n_solves != 1 else ''}; "
                    f"first order predicted {_g(pred)}{u} "
                    f"({100 * float(ds['prediction_error'].values[i, j]):.2g} % off).")
            others = [_change(ds, k, float(conf[k])) for k in np.argsort(steps) if k != j and np.isfinite(steps[k])]
            if others:
                text += f" It is also removed by changing {'; '.join(o.rstrip(',') for o in others)}."
        else:
            text = f"{head} is not removed by any single declared change within its range."
        beyond = [names[k] for k in range(len(names)) if ds["status"].values[i, k] == "beyond_range"]
        if beyond:
            text += f" {', '.join(beyond)} cannot remove it (the change would take a scale or a mass below zero)."
        best = int(np.argmin(ds["rank"].values[i]))
        text += (f" Per step, {names[best]} acts most on it ({float(ds['effect'].values[i, best]):+.3g} 1/s per "
                 "step).")
        out.append(text)
    return out


def design_section(ds: Any, doe: Any = None, figures: tuple[FigureRef, ...] = ()) -> Section:
    """The report section of a countermeasure study (and of a DOE sweep, when given).

    Parameters
    ----------
    ds : xarray.Dataset
        A :func:`squealkit.design.countermeasures` result.
    doe : xarray.Dataset, optional
        A :func:`squealkit.design.doe_sweep` result.
    figures : tuple of FigureRef
        The figures written for it.

    Returns
    -------
    Section
    """
    paras = design_sentences(ds)
    if doe is not None:
        ok = doe["all_trusted"].values
        front = doe["pareto"].values & (doe["max_growth_rate"].values <= 0)
        text = (f"A design of experiments of {doe.sizes['point']} points on the reduced model ({doe.attrs['method']} "
                f"basis of {doe.attrs['basis_size']} vectors) has {int(ok.sum())} points whose every eigenpair's "
                "backward error in the full model is within tolerance.")
        if front.any():
            k = int(np.flatnonzero(front)[np.argmin(doe["change_size"].values[front])])
            vals = ", ".join(f"{p} = {v:.3g}" for p, v in zip(doe["parameter"].values, doe["value"].values[k],
                                                             strict=True))
            text += (f" The smallest change on the Pareto front that leaves no unstable mode is {vals} "
                     f"({doe['change_size'].values[k]:.2g} steps).")
        else:
            text += " No point of it is stable."
        paras.append(text)
    rows = countermeasure_table(ds)
    table = Table("Countermeasures", ("mode [Hz]", "parameter", "rank", "effect [1/s per step]", "predicted change",
                                      "confirmed change", "status"),
                  tuple((r["frequency_hz"], r["parameter"], r["rank"], r["effect"], r["predicted_change"],
                         r["confirmed_change"], r["status"]) for r in rows))
    numbers = {"unstable_modes": float(ds.sizes["mode"])}
    return Section("design", "Designing the squeal out", tuple(paras), (), (table,), tuple(figures), numbers=numbers)


def write_design_report(ds: Any, out: Path, *, doe: Any = None) -> Path:
    """Write ``out/report.html`` (figures embedded) and ``out/figures/*.png`` of a design study.

    Parameters
    ----------
    ds : xarray.Dataset
        A :func:`squealkit.design.countermeasures` result.
    out : Path
        The (staging) output folder.
    doe : xarray.Dataset, optional
        A :func:`squealkit.design.doe_sweep` result (its Pareto figure is added).

    Returns
    -------
    Path
        The report.
    """
    from ..plotting import design as dp
    from .html import save_figures, write_report

    figs = {}
    if ds.sizes["mode"]:
        figs["countermeasures"] = (dp.countermeasures_plot(ds), "Change of each unstable mode's growth rate per "
                                                                "declared step of each parameter.")
    if doe is not None:
        figs["pareto"] = (dp.pareto_plot(doe), "Largest growth rate against the size of the change (declared steps) "
                                               "over the DOE; red: the Pareto front.")
    section = design_section(ds, doe, save_figures(figs, out / "figures"))
    return write_report([section], out, title="squealkit design study",
                        subtitle=f"{ds.attrs.get('model_kind', 'model')} model, method {ds.attrs.get('method')}")
