"""Figures of the design study (:mod:`squealkit.design`): they draw what the results hold, nothing more."""

from __future__ import annotations

import numpy as np

from .campaign import _fig

__all__ = ["countermeasures_plot", "pareto_plot"]


def pareto_plot(ds, *, ax=None):
    """Largest growth rate against the size of the change, every DOE point and the Pareto front.

    Parameters
    ----------
    ds : xarray.Dataset
        A :func:`~squealkit.design.doe_sweep` result (``change_size``, ``max_growth_rate``,
        ``pareto``, ``all_trusted``).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(7, 4.5))
    size, sig = ds["change_size"].values, ds["max_growth_rate"].values
    trusted, front = ds["all_trusted"].values, ds["pareto"].values
    ax.scatter(size[trusted], sig[trusted], s=10, color="0.6", label="design points")
    if (~trusted).any():
        ax.scatter(size[~trusted], sig[~trusted], s=14, marker="x", color="tab:orange",
                   label="residual above eta_max (not trusted)")
    order = np.argsort(size[front])
    ax.plot(size[front][order], sig[front][order], "o-", color="tab:red", ms=4, label="Pareto front")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("size of the change [declared steps]")
    ax.set_ylabel("largest growth rate [1/s]")
    names = ", ".join(map(str, ds["parameter"].values))
    ax.set_title(f"DOE of {names} at {ds.attrs.get('rpm', float('nan')):g} rpm, mu = {ds.attrs['mu']:g} "
                 f"({ds.attrs['method']} basis of {ds.attrs['basis_size']})", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def countermeasures_plot(ds, *, ax=None):
    """Effect of each design parameter on each unstable mode's growth rate (per declared step).

    Parameters
    ----------
    ds : xarray.Dataset
        A :func:`~squealkit.design.countermeasures` result (``effect`` over mode x parameter).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(7, 4.5))
    effect = ds["effect"].values
    n_mode, n_par = effect.shape
    width = 0.8 / max(n_par, 1)
    for j, name in enumerate(ds["parameter"].values):
        ax.bar(np.arange(n_mode) + (j - (n_par - 1) / 2) * width, effect[:, j], width, label=str(name))
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xticks(range(n_mode), [f"{f:.0f} Hz" if f >= 100 else f"{f:.4g} Hz" for f in ds["frequency_hz"].values])
    ax.set_xlabel("unstable mode")
    ax.set_ylabel("change of growth rate per step [1/s]")
    ax.set_title("Countermeasures: effect of one declared step on each unstable mode", fontsize=10)
    ax.legend(fontsize=8)
    return fig
