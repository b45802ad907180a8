"""Figure of robust margins: each mode's growth rate under scatter, by both estimators.

Draws a result of :func:`squealkit.design.robust.robust_margins` and returns the matplotlib
Figure; matplotlib is imported inside the functions. Nothing is computed here that the result
does not hold.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .._validation import validate_dataset
from .stability import _axes

__all__ = ["robust_margins_plot"]

_STYLE = {"montecarlo": ("tab:blue", "o", "Monte Carlo"), "perturbation": ("tab:orange", "s", "perturbation")}


def robust_margins_plot(ds: xr.Dataset, ax=None):
    """Mean growth rate of each mode +- two standard deviations against frequency, per estimator.

    The nominal growth rates are black crosses; modes beyond the perturbation estimate's reach
    (``perturbation_status`` 2, indeterminate) are circled in red, those whose Monte Carlo match is
    indeterminate in some samples (``match_indeterminate``) boxed in orange. The legend gives each
    estimator's squeal propensity with its interval and its cost.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`~squealkit.design.robust.robust_margins`.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    validate_dataset(ds, variables=("growth_rate_mean", "propensity"), what="robust_margins")
    fig, ax = _axes(ax, (7.5, 4.5))
    f_khz = ds.frequency_hz.values / 1e3
    span = float(np.ptp(f_khz)) if f_khz.size > 1 else 1.0
    estimators = [str(e) for e in ds.estimator.values]
    for i, name in enumerate(estimators):
        color, marker, label = _STYLE.get(name, ("tab:gray", "d", name))
        one = ds.sel(estimator=name)
        offset = (i - (len(estimators) - 1) / 2) * 0.008 * (span or 1.0)
        lo, hi = one.propensity_ci_lower.item(), one.propensity_ci_upper.item()
        p = one.propensity.item()
        said = (f"propensity {p:.3f} [{lo:.3f}, {hi:.3f}]" if np.isfinite(p)
                else "propensity indeterminate (modes near a coalescence)")
        ax.errorbar(f_khz + offset, one.growth_rate_mean.values, yerr=2 * one.growth_rate_std.values, fmt=marker,
                    color=color, ms=5, capsize=3, lw=1.2, label=f"{label}: {said}, {one.cost_seconds.item():.3g} s")
    ax.plot(f_khz, ds.growth_rate.values, "x", color="k", ms=6, label="nominal")
    if "perturbation_status" in ds:
        bad = ds.perturbation_status.values == 2
        if bad.any():
            ax.plot(f_khz[bad], ds.growth_rate.values[bad], "o", mfc="none", mec="tab:red", ms=14,
                    label="indeterminate (near a coalescence)")
    if "match_indeterminate" in ds:
        mixed = ds.match_indeterminate.values.any(axis=0)
        if mixed.any():
            ax.plot(f_khz[mixed], ds.growth_rate.values[mixed], "s", mfc="none", mec="tab:orange", ms=14,
                    label="Monte Carlo match indeterminate in some samples (near-degenerate pair)")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("frequency [kHz]")
    ax.set_ylabel("growth rate [1/s] (mean +- 2 std)")
    ax.set_title(f"Robust margins at mu = {float(ds.attrs['mu']):g}"
                 + (f", {float(ds.attrs['rpm']):g} rpm" if np.isfinite(float(ds.attrs.get("rpm", np.nan))) else ""))
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=7)
    return fig
