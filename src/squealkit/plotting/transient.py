"""Figures of transient runs: paper Figs. 3 and 4 and the response envelope against sigma(t).

Each function takes a dataset from :func:`squealkit.transient.simulate` and returns a
:class:`matplotlib.figure.Figure` (no pyplot state); pass ``ax`` to draw into existing axes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from .._deprecation import renamed_kwargs

__all__ = ["envelope_plot", "fig3_plot", "fig4_plot", "floquet_plot"]


def _axes(ax: Any, n: int, figsize: tuple[float, float]):
    if ax is not None:
        axes = list(ax) if isinstance(ax, Sequence) else [ax]
        if len(axes) != n:
            raise ValueError(f"Parameter ax needs {n} axes; got {len(axes)}.")
        return axes[0].figure, axes
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    axes = [fig.add_subplot(n, 1, i + 1) for i in range(n)]
    for a in axes[1:]:
        a.sharex(axes[0])
    return fig, axes


def _accel_names(ds: xr.Dataset) -> list[str]:
    names = [str(v) for v in ds.data_vars if str(v).endswith("_ddot")]
    # The paper shows the pin's horizontal and the disc's vertical acceleration (x1'', y2'').
    if "x1_ddot" in names and "y2_ddot" in names:
        return ["x1_ddot", "y2_ddot"]
    return names[:2]


def _title(ds: xr.Dataset) -> str:
    profile = str(ds.attrs.get("profile"))
    profile = "smooth disc" if profile in ("none", "None") else profile  # a reader does not know "none"
    return f"mu = {ds.attrs.get('mu')}, v = {ds.attrs.get('speed')} m/s, {profile}"


def fig3_plot(ds: xr.Dataset, ax: Any = None):
    """Accelerations against time on a smooth disc (paper Fig. 3).

    Parameters
    ----------
    ds : xarray.Dataset
        Result of :func:`~squealkit.transient.simulate`.
    ax : sequence of 2 matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = _accel_names(ds)
    fig, axes = _axes(ax, len(names), (7.0, 5.0))
    t = ds.time.values
    for a, name in zip(axes, names, strict=True):
        a.plot(t, ds[name].values, lw=0.6)
        a.set_ylabel(f"{name} [m/s²]")
        a.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(_title(ds), fontsize=9)
    return fig


def fig4_plot(ds: xr.Dataset, ax: Any = None, *, smooth: xr.Dataset | None = None):
    """Accelerations with the surface run-out q drawn alongside (paper Fig. 4).

    Parameters
    ----------
    ds : xarray.Dataset
        Run with run-out.
    ax : sequence of 2 matplotlib Axes, optional
        Where to draw.
    smooth : xarray.Dataset, optional
        The same run on a smooth disc, drawn in grey behind for comparison.

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = _accel_names(ds)
    fig, axes = _axes(ax, len(names), (7.0, 5.0))
    t = ds.time.values
    for a, name in zip(axes, names, strict=True):
        if smooth is not None and name in smooth:
            a.plot(smooth.time.values, smooth[name].values, lw=0.5, color="0.6", label="smooth disc")
        a.plot(t, ds[name].values, lw=0.6, color="C0", label="with SRO")
        # the scale follows the response after the start-up (first 5 %), not a start-up spike
        x = np.asarray(ds[name].values)[t >= t[0] + 0.05 * (t[-1] - t[0])]
        peak = float(np.nanmax(np.abs(x))) if x.size else 0.0
        if peak > 0 and float(np.nanmax(np.abs(ds[name].values))) > 1.5 * peak:
            a.set_ylim(-1.3 * peak, 1.3 * peak)
            a.text(0.01, 0.02, "start-up spike clipped", transform=a.transAxes, fontsize=7, color="0.4")
        a.set_ylabel(f"{name} [m/s²]")
        a.grid(True, alpha=0.3)
        tw = a.twinx()
        tw.plot(t, ds.q.values * 1e3, color="C3", lw=1.0, label="SRO q")
        tw.set_ylabel("q [mm]", color="C3")
    axes[0].legend(loc="upper left", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    axes[0].set_title(_title(ds), fontsize=9)
    return fig


@renamed_kwargs(freq_lower="highpass_freq")
def envelope_plot(ds: xr.Dataset, ax: Any = None, *, var: str = "x1_ddot", highpass_freq: float = 1000.0):
    """Vibration envelope (log scale) against the frozen-time growth rate sigma(t).

    Where sigma > 0 the envelope should rise with slope sigma on the log scale, where sigma < 0
    it should fall (paper section 4).

    Parameters
    ----------
    ds : xarray.Dataset
        Result of :func:`~squealkit.transient.simulate`.
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.
    var : str, default "x1_ddot"
        The variable whose envelope is drawn.
    highpass_freq : float, default 1000.0
        High-pass corner [Hz] of :func:`~squealkit.transient.response_envelope` (formerly
        ``freq_lower``, still accepted with a DeprecationWarning).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    from ..transient.simulate import response_envelope

    env = response_envelope(ds, var, highpass_freq=highpass_freq)
    fig, axes = _axes(ax, 1, (7.0, 3.5))
    a = axes[0]
    t = ds.time.values
    a.semilogy(t, np.maximum(env.values, 1e-300), lw=0.8, color="C0")
    a.set_ylabel(f"envelope of {var} [{env.attrs.get('units', '')}]", color="C0")
    a.set_xlabel("time [s]")
    a.grid(True, alpha=0.3)
    tw = a.twinx()
    tw.plot(t, ds.growth_rate.values, color="C1", lw=1.0)
    tw.axhline(0.0, color="C1", lw=0.5, ls="--")
    tw.set_ylabel("sigma(t) [1/s]", color="C1")
    a.set_title(_title(ds), fontsize=9)
    return fig


def floquet_plot(ds: xr.Dataset, ax: Any = None):
    """Floquet exponent over friction and run-out amplitude (a :func:`~squealkit.transient.floquet.floquet_map`).

    Colour: the exponent [1/s] (red grows); black line: exponent 0; dashed: where the period
    average of the frozen-time sigma is 0.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`~squealkit.transient.floquet.floquet_map` (dims ``mu``, ``amplitude``).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    fig, axes = _axes(ax, 1, (7, 5))
    a = axes[0]
    rho = ds["floquet_exponent"].values
    vmax = float(np.nanmax(np.abs(rho))) or 1.0
    q_um = ds["amplitude"].values * 1e6
    mesh = a.pcolormesh(ds["mu"].values, q_um, rho.T, cmap="RdBu_r", vmin=-vmax, vmax=vmax, shading="auto")
    fig.colorbar(mesh, ax=a, label="Floquet exponent [1/s]")
    if ds.sizes["mu"] > 1 and ds.sizes["amplitude"] > 1:
        a.contour(ds["mu"].values, q_um, rho.T, levels=[0.0], colors="k", linewidths=1.2)
        a.contour(ds["mu"].values, q_um, ds["frozen_mean"].values.T, levels=[0.0], colors="k", linestyles="--",
                  linewidths=1.0)
    a.set_xlabel("friction coefficient mu")
    a.set_ylabel("run-out amplitude q0 [um]")
    a.set_title(f"Floquet exponent, lambda = {ds.attrs['wavelength'] * 1e3:g} mm, v = {ds.attrs['speed']:g} m/s "
                "(solid: 0; dashed: frozen-time mean 0)", fontsize=9)
    return fig
