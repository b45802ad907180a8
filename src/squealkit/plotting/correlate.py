"""Figures of a test-versus-model correlation (:func:`squealkit.correlate.correlate`).

Each function draws what the correlation result already holds; none recomputes it.
"""

from __future__ import annotations

import numpy as np

from .campaign import _SYN, _fig

__all__ = ["calibration_profile_plot", "noise_map_plot", "noise_matrices_plot", "outcome_plot"]

_COLOURS = {"hit": "tab:green", "miss": "tab:red", "over_prediction": "tab:orange", "quiet": "0.7"}


def noise_matrices_plot(ds, *, by: str = "temperature", synthetic: bool = False, axes=None):
    """Measured and predicted noise matrices side by side: occurrence [%] per band and condition bin.

    Parameters
    ----------
    ds : xarray.Dataset
        A correlation (``measured_by_<by>``, ``predicted_by_<by>``).
    by : {"temperature", "pressure"}
        The condition of the columns.
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]``.
    axes : sequence of two matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    else:
        fig = axes[0].figure
    bins = ds[f"{by}_bin"].values
    counts = ds[f"{by}_bin_count"].values
    keep = counts > 0
    im = None
    for ax, which in zip(axes, ("measured", "predicted"), strict=True):
        m = ds[f"{which}_by_{by}"].values[:, keep]
        im = ax.imshow(m, origin="lower", aspect="auto", cmap="Reds", vmin=0, vmax=100)
        for (i, j), v in np.ndenumerate(m):
            if np.isfinite(v) and v > 0:
                ax.text(j, i, f"{v:.0f}", ha="center", va="center", fontsize=7,
                        color="white" if v > 60 else "black")
        labels = [f"{b}\n(n={c})" for b, c in zip(bins[keep], counts[keep], strict=True)]
        ax.set_xticks(range(int(keep.sum())), labels, fontsize=7, rotation=35, ha="right")
        ax.set_title(f"{which} occurrence [%]", fontsize=10)
        ax.set_xlabel(f"brake {by}")
    axes[0].set_yticks(range(ds.sizes["band"]), [f"{c / 1000:.3g}" for c in ds["band_center_hz"].values])
    axes[0].set_ylabel("1/3-octave band centre [kHz]")
    fig.colorbar(im, ax=list(axes), label="% of applications in the bin", shrink=0.9)
    fig.suptitle(f"Noise matrix by {by}: measured vs predicted (tolerance {ds.attrs['tolerance_percent']:g} %)"
                 + (_SYN if synthetic else ""), fontsize=11)
    return fig


def noise_map_plot(ds, *, by: str = "temperature_c", synthetic: bool = False, ax=None):
    """Measured squeal components (frequency against a condition, colour: level) over the predicted
    unstable frequencies (open markers).

    Parameters
    ----------
    ds : xarray.Dataset
        A correlation.
    by : {"temperature_c", "pressure_bar", "mu"}
        The condition on the x axis.
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]``.
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(9, 5))
    x = ds[by].values
    f_p = ds["predicted_hz"].values
    xp = np.broadcast_to(x[:, None], f_p.shape)
    okp = np.isfinite(f_p)
    ax.scatter(xp[okp], f_p[okp], s=70, facecolors="none", edgecolors="tab:blue", linewidths=1.2,
               label="predicted unstable mode")
    f_m = ds["measured_hz"].values
    lvl = ds["measured_dba"].values
    xm = np.broadcast_to(x[:, None], f_m.shape)
    okm = np.isfinite(f_m)
    if okm.any():
        sc = ax.scatter(xm[okm], f_m[okm], c=lvl[okm], cmap="magma_r", s=24, edgecolors="k", linewidths=0.4,
                        label="measured squeal", zorder=3)
        fig.colorbar(sc, ax=ax, label="peak level [dB(A)]")
    units = {"temperature_c": "brake temperature [C]", "pressure_bar": "brake pressure [bar]",
             "mu": "model friction coefficient [1]"}
    ax.set_xlabel(units.get(by, by))
    ax.set_ylabel("frequency [Hz]")
    ax.set_yscale("log")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3, which="both")
    ax.set_title("Noise map: measured squeal over predicted unstable modes" + (_SYN if synthetic else ""),
                 fontsize=10)
    fig.tight_layout()
    return fig


def outcome_plot(ds, *, synthetic: bool = False, ax=None):
    """Each application's outcome against its model friction and temperature.

    Parameters
    ----------
    ds : xarray.Dataset
        A correlation.
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]``.
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(8, 4.5))
    out = ds["outcome"].values
    for k, c in _COLOURS.items():
        sel = out == k
        ax.scatter(ds["mu"].values[sel], ds["temperature_c"].values[sel], c=c, s=25,
                   label=f"{k.replace('_', '-')} ({int(sel.sum())})")
    ax.set_xlabel("model friction coefficient mu [1]")
    ax.set_ylabel("brake temperature [C]")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    ax.set_title(f"Outcome per application (tolerance {ds.attrs['tolerance_percent']:g} %)"
                 + (_SYN if synthetic else ""), fontsize=10)
    fig.tight_layout()
    return fig


def calibration_profile_plot(ds, name: str, *, ax=None):
    """Applications the model gets wrong against a fitted quantity (its profile), with the interval.

    Parameters
    ----------
    ds : xarray.Dataset
        A correlation with a calibration (``value_NAME``, ``wrong_NAME``; attribute ``calibration``).
    name : str
        The quantity.
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import json

    fig, ax = _fig(ax, figsize=(7, 3.5))
    q = json.loads(ds.attrs["calibration"])["quantities"][name]
    ax.step(ds[f"value_{name}"].values, ds[f"wrong_{name}"].values, where="mid", color="tab:blue")
    lo, hi = q["interval"]
    ax.axvspan(lo, hi, color="tab:green", alpha=0.2, label=f"interval [{lo:.4g}, {hi:.4g}]")
    ax.axvline(q["value"], color="tab:green", label=f"fit {q['value']:.4g}")
    ax.axvline(q["start"], color="0.5", ls="--", label=f"start {q['start']:.4g}")
    ax.set_xlabel(name)
    ax.set_ylabel("applications wrong")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title(f"Calibration profile of {name}", fontsize=10)
    fig.tight_layout()
    return fig
