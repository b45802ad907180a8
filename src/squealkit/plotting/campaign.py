"""Figures of a brake noise campaign, as NVH engineers show them (SAE J2521 / VDA 303 style).

Each function draws what the campaign store and summary already hold; none recomputes results.
"""

from __future__ import annotations

import numpy as np

__all__ = ["level_vs_application_plot", "noise_matrix_plot", "occurrence_by_band_plot", "runout_phase_plot"]

_SYN = " [SYNTHETIC]"


def _fig(ax, **kw):
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(**kw)
        return fig, ax
    return ax.figure, ax


def occurrence_by_band_plot(summary: dict, *, synthetic: bool = False, ax=None):
    """Noise occurrence [% of applications] per 1/3-octave band.

    Parameters
    ----------
    summary : dict
        A campaign summary (:func:`squealkit.campaign.campaign_summary`, ``summary.json``).
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]`` (the campaign's recordings are synthetic).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(8, 4))
    bands = summary["by_band"]
    labels = [f"{b['center_hz'] / 1000:.3g}" for b in bands]
    occ = [np.nan if b["occurrence_percent"] is None else b["occurrence_percent"] for b in bands]
    ax.bar(range(len(bands)), occ, color="tab:red")
    ax.set_xticks(range(len(bands)), labels)
    ax.set_xlabel("1/3-octave band centre [kHz]")
    ax.set_ylabel("occurrence [% of applications]")
    total = summary["occurrence_percent"]
    head = "unknown: no application analysed" if total is None else (
        f"{total:.1f} % of {summary['applications']} applications")
    if total is None:  # no bars: a 0-100 % axis that says why
        ax.set_ylim(0.0, 100.0)
        ax.text(0.5, 0.5, "no application could be analysed", transform=ax.transAxes, ha="center", va="center")
    ax.set_title("Squeal occurrence by band: " + head + (_SYN if synthetic else ""), fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def noise_matrix_plot(events, *, by: str = "temperature_c", label: str = "brake temperature [C]",
                      threshold_dba: float = 70.0, synthetic: bool = False, ax=None):
    """The noise matrix: each event's frequency against a condition, coloured by its peak level.

    Parameters
    ----------
    events : pandas.DataFrame
        The campaign's squeal events with their conditions (the store's ``squeal`` view):
        columns ``frequency_hz``, ``peak_dba`` and ``by``.
    by : str, default "temperature_c"
        The condition column on the x axis (e.g. ``"pressure_bar"``).
    label : str, default "brake temperature [C]"
        Its axis label.
    threshold_dba : float, default 70.0
        Lower end of the colour scale [dB(A)] (the squeal threshold).
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]`` (the campaign's recordings are synthetic).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(8, 4.5))
    if len(events):
        sc = ax.scatter(events[by], events["frequency_hz"] / 1000, c=events["peak_dba"], cmap="inferno_r",
                        vmin=threshold_dba, vmax=max(threshold_dba + 10, float(events["peak_dba"].max())), s=22,
                        edgecolors="k", linewidths=0.3)
        fig.colorbar(sc, ax=ax, label="peak level [dB(A)]")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter

    for axis in (ax.yaxis,):
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}" if v in (1.25, 2.5, 5, 8, 12.5) else ""))
    ax.set_xlabel(label)
    ax.set_ylabel("squeal frequency [kHz]")
    ax.set_title("Noise matrix" + _SYN * synthetic, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    return fig


def level_vs_application_plot(apps, *, threshold_dba: float = 70.0, synthetic: bool = False, ax=None):
    """Each application's peak level (Fast, A-weighted, in the criteria band) in matrix order.

    Parameters
    ----------
    apps : pandas.DataFrame
        The store's ``applications`` table: columns ``squeal`` and ``peak_dba``.
    threshold_dba : float, default 70.0
        The squeal threshold [dB(A)], drawn as a line.
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]`` (the campaign's recordings are synthetic).
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _fig(ax, figsize=(8, 4))
    x = np.arange(1, len(apps) + 1)
    sq = apps["squeal"].to_numpy(bool)
    ax.scatter(x[~sq], apps["peak_dba"][~sq], s=10, color="tab:gray", label="no squeal")
    ax.scatter(x[sq], apps["peak_dba"][sq], s=12, color="tab:red", label="squeal")
    ax.axhline(threshold_dba, color="k", ls="--", lw=0.8, label=f"{threshold_dba:g} dB(A)")
    ax.set_xlabel("application number")
    ax.set_ylabel("peak level [dB(A)]")
    ax.set_title("Peak level per brake application" + _SYN * synthetic, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def runout_phase_plot(apps, *, synthetic: bool = False, ax=None):
    """Where on the disc the squeal sounds, relative to the run-out crest, per squealing application.

    Parameters
    ----------
    apps : pandas.DataFrame
        Applications with a ``runout_phase_deg`` column [deg] (NaN rows are left out).
    synthetic : bool, default False
        Mark the title ``[SYNTHETIC]`` (the campaign's recordings are synthetic).
    ax : matplotlib Axes, optional
        Polar axes to draw into; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=(5, 5))
        ax = fig.add_subplot(projection="polar")
    fig = ax.figure
    ph = apps["runout_phase_deg"].dropna().to_numpy(float)
    bins = np.linspace(-np.pi, np.pi, 37)
    counts, _ = np.histogram(np.radians(ph), bins)
    ax.bar(bins[:-1] + np.diff(bins) / 2, counts, width=np.diff(bins), color="tab:red", alpha=0.7,
           edgecolor="k", linewidth=0.3)
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)  # clockwise: the disc's sense of rotation, the crest at the top
    ticks = np.arange(-135, 181, 45)
    ax.set_xticks(np.radians(ticks), [f"{t:+d}" if t not in (0, 180) else f"{t}" for t in ticks])
    ax.set_title("Squeal angle relative to the run-out crest (0 deg)\nnegative: before the crest, rising run-out"
                 + _SYN * synthetic, fontsize=9)
    fig.tight_layout()
    return fig
