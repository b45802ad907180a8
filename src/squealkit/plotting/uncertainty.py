"""Figures of Monte Carlo results: the squeal-propensity curve and the Sobol' indices.

Each function draws a result of :func:`squealkit.uncertainty.squeal_propensity` and returns
the matplotlib Figure; matplotlib is imported inside the functions.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .._validation import InputError
from .stability import _axes, _figure

__all__ = ["propensity_plot", "sensitivity_plot", "uncertainty_plot"]


def propensity_plot(ds: xr.Dataset, ax=None):
    """Probability of instability against friction, with its confidence band.

    The nominal model's critical friction is marked by a dashed line (when it lies inside
    the range).

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`~squealkit.uncertainty.squeal_propensity`.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 4.5))
    mu = ds.mu.values
    conf = float(ds.attrs.get("confidence", 0.95))
    ax.fill_between(mu, ds.ci_lower.values, ds.ci_upper.values, color="tab:blue", alpha=0.25, lw=0,
                    label=f"{conf:.0%} confidence band (Clopper-Pearson)")
    ax.plot(mu, ds.probability_unstable.values, color="tab:blue", lw=1.8, marker="." if mu.size <= 41 else None,
            label=f"P(unstable), {int(ds.attrs['samples'])} samples")
    if int(ds.attrs.get("nominal_onset_status", -1)) == 0:
        ax.axvline(float(ds.attrs["nominal_mu_critical"]), color="k", ls="--", lw=1.0,
                   label=f"nominal mu_crit = {float(ds.attrs['nominal_mu_critical']):.4f}")
    ax.set_ylim(-0.02, 1.02)
    if mu.size > 1:
        ax.set_xlim(mu[0], mu[-1])
    ax.set_xlabel("friction coefficient mu")
    ax.set_ylabel("probability of instability")
    theta = float(ds.attrs.get("theta_deg", 0.0))
    ax.set_title(f"Squeal propensity (theta = {theta:g} deg, {'damped' if ds.attrs.get('damped') else 'undamped'})")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    return fig


def sensitivity_plot(ds: xr.Dataset, ax=None):
    """Sobol' first-order and total indices of the critical friction, per parameter.

    Error bars are the bootstrap intervals stored in ``ds``.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`~squealkit.uncertainty.squeal_propensity` with sensitivity.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    if "sobol_total" not in ds:
        raise InputError("The dataset has no Sobol' indices (run squeal_propensity with sensitivity=True).")
    fig, ax = _axes(ax, (7, 4.5))
    names = [str(p) for p in ds.parameter.values]
    x = np.arange(len(names))
    w = 0.38
    for off, key, label, color in ((-w / 2, "sobol_first_order", "first order", "tab:blue"),
                                   (w / 2, "sobol_total", "total", "tab:orange")):
        v = ds[key].values
        err = np.abs(np.vstack([v - ds[f"{key}_ci_lower"].values, ds[f"{key}_ci_upper"].values - v]))
        ax.bar(x + off, v, w, color=color, label=label, yerr=np.nan_to_num(err), capsize=3)
    ax.set_xticks(x, names)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_ylabel("Sobol' index of mu_crit")
    ax.set_title(f"Which parameters drive the critical friction ({int(ds.attrs['sobol_base_samples'])} base samples)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def uncertainty_plot(ds: xr.Dataset, fig=None):
    """Both panels side by side: :func:`propensity_plot` and (if computed) :func:`sensitivity_plot`.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squealkit.uncertainty.squeal_propensity`.
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = fig or _figure(figsize=(13, 4.8) if "sobol_total" in ds else (7, 4.8))
    fig.clf()
    if "sobol_total" in ds:
        propensity_plot(ds, ax=fig.add_subplot(1, 2, 1))
        sensitivity_plot(ds, ax=fig.add_subplot(1, 2, 2))
    else:
        propensity_plot(ds, ax=fig.add_subplot(1, 1, 1))
    fig.tight_layout()
    return fig
