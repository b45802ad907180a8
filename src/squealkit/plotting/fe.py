"""Figures of FE brake stability maps: what industry reads from a complex eigenvalue analysis.

- :func:`fe_growth_plot`: growth rate against frequency of every mode in the band, one
  panel per disc speed (a few), all friction values, unstable modes marked;
- :func:`fe_map_plot`: the disc speed x friction map of the largest growth rate with the
  stability boundary.

Each draws a result of :func:`~squealkit.stability.fe_stability_map`; nothing is recomputed.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .._accessor import upgrade_result
from .stability import _axes, _figure

__all__ = ["fe_growth_plot", "fe_map_plot"]


def fe_growth_plot(ds: xr.Dataset, *, max_panels: int = 4, fig=None):
    """Growth rate sigma against frequency for every mode, per disc speed (unstable ones marked).

    Parameters
    ----------
    ds : xarray.Dataset
        An FE stability map (dims ``rpm, mu, mode``).
    max_panels : int
        Panels at most; speeds are picked evenly over the grid.
    fig : matplotlib Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    ds = upgrade_result(ds)  # frequency_hz, also in a file saved as "frequency"
    n_r = ds.sizes["rpm"]
    picks = np.unique(np.linspace(0, n_r - 1, min(n_r, max_panels)).round().astype(int))
    fig = fig or _figure(figsize=(7.5, 2.4 * len(picks) + 0.6), layout="constrained")
    axes = fig.subplots(len(picks), 1, sharex=True, squeeze=False)[:, 0]
    mus = ds.mu.values
    norm_mu = (mus - mus.min()) / (np.ptp(mus) or 1.0)
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    friction = f"mu {mus[0]:g}" if mus.size == 1 else f"colour: mu {mus.min():g} to {mus.max():g}"
    for ax, i in zip(axes, picks, strict=True):
        for j in range(ds.sizes["mu"]):
            f = ds["frequency_hz"].values[i, j]
            s = ds["growth_rate"].values[i, j]
            u = ds["unstable"].values[i, j]
            ax.scatter(f[~u], s[~u], s=9, color=cmap(norm_mu[j]), alpha=0.7, lw=0)
            ax.scatter(f[u], s[u], s=40, facecolor="none", edgecolor="red", lw=1.2,
                       label="unstable" if j == 0 or not ax.get_legend_handles_labels()[0] else None)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_ylabel("growth rate sigma [1/s]")
        ax.set_title(f"{ds.rpm.values[i]:g} rpm  ({friction})", fontsize=9)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("frequency [Hz]")
    band = ds.attrs.get("band_hz")
    fig.suptitle(f"Complex eigenvalues, {ds.attrs.get('method', '')} solve"
                 + ("" if band in (None, "all") else f", band {band[0]:g}-{band[1]:g} Hz"), fontsize=10)
    return fig


def fe_map_plot(ds: xr.Dataset, *, ax=None):
    """Largest growth rate over disc speed x friction, with the stability boundary.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squealkit.stability.fe_stability_map` (dims ``rpm``, ``mu``).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 5))
    sig = ds["max_growth_rate"].values
    vmax = float(np.nanmax(np.abs(sig))) or 1.0
    mesh = ax.pcolormesh(ds.mu.values, ds.rpm.values, sig, cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                         shading="auto", rasterized=True)
    fig.colorbar(mesh, ax=ax, label="largest growth rate sigma [1/s]")
    if ds.sizes["mu"] > 1 and ds.sizes["rpm"] > 1:
        ax.contour(ds.mu.values, ds.rpm.values, ds["any_unstable"].values.astype(float), levels=[0.5],
                   colors="k", linewidths=1.2)
    ax.set_xlabel("friction coefficient mu" + (f" (+ tan theta = {float(ds.tan_theta):.3g})"
                                              if float(ds.tan_theta) else ""))
    ax.set_ylabel("disc speed [rpm]")
    ax.set_title("Speed x friction map: unstable where sigma > 0 (red), boundary in black")
    return fig
