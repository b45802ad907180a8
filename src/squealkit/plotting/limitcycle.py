"""Bifurcation diagram of a limit-cycle branch: amplitude and frequency against friction.

Draws a result of :func:`squealkit.nonlinear.limit_cycle_branch` and computes nothing it
does not hold. matplotlib is imported inside the function.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

__all__ = ["limitcycle_plot"]

_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i, j] (inclusive, overlapping by one point) of equal ``mask``."""
    out, start = [], 0
    for k in range(1, mask.size + 1):
        if k == mask.size or mask[k] != mask[start]:
            out.append((start, min(k, mask.size - 1)))
            start = k
    return out


def limitcycle_plot(ds: xr.Dataset, *, fig=None):
    """Bifurcation diagram: amplitude per DOF [um] and frequency [Hz] against mu (or tan(theta)).

    Stable cycles are solid, unstable ones dashed; the quiet state (amplitude 0) is solid
    below the Hopf point and dashed above it; the Hopf point is a black star, folds are
    black crosses.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squealkit.nonlinear.limit_cycle_branch` (or ``limit_cycle_branch_slope``).
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    fig = fig or Figure(figsize=(7.5, 6.5), layout="constrained")
    fig.clf()
    ax_a, ax_f = fig.subplots(2, 1, sharex=True, height_ratios=[2.0, 1.0])
    param = str(ds.attrs.get("param", "mu"))
    mu = ds[param].values
    stable = ds["stable"].values.astype(bool)
    amp = ds["amplitude"].values * 1e6
    freq = ds["frequency_hz"].values
    mu_h = float(ds.attrs["hopf_mu"])
    pad = 0.05 * float(np.ptp(mu)) if mu.size > 1 else 0.0
    lo, hi = (float(v) for v in ds.attrs.get(f"{param}_range", [mu.min() - pad, mu.max() + pad]))
    runs = _runs(stable)
    for j, dof in enumerate(ds["dof"].values):
        c = _COLORS[j % len(_COLORS)]
        for i0, i1 in runs:
            ls = "-" if stable[i0] else "--"
            ax_a.plot(mu[i0:i1 + 1], amp[i0:i1 + 1, j], ls, color=c, lw=1.8)
        ax_a.plot([], [], "-", color=c, label=str(dof))
    for i0, i1 in runs:
        ax_f.plot(mu[i0:i1 + 1], freq[i0:i1 + 1], "-" if stable[i0] else "--", color="k", lw=1.5)
    ax_a.plot([min(lo, mu_h), mu_h], [0, 0], "-", color="0.4", lw=1.5)
    ax_a.plot([mu_h, max(hi, mu_h)], [0, 0], "--", color="0.4", lw=1.5)
    ax_a.plot([mu_h], [0], "k*", ms=12, zorder=5)
    ax_f.plot([mu_h], [float(ds.attrs["hopf_frequency_hz"])], "k*", ms=12, zorder=5)
    for i in np.flatnonzero(ds["fold"].values):
        ax_a.plot(np.full(amp.shape[1], mu[i]), amp[i], "kx", ms=9, mew=2, zorder=5)
        ax_f.plot([mu[i]], [freq[i]], "kx", ms=9, mew=2, zorder=5)
    kind = ds.attrs.get("kind", "")
    ax_a.set_title(f"Limit cycles by harmonic balance (H = {ds.attrs.get('harmonics')}): "
                   f"Hopf at {param} = {mu_h:.4f}, {ds.attrs['hopf_frequency_hz']:.1f} Hz, {kind}", fontsize=10)
    ax_a.set_ylabel("amplitude (half peak-to-peak) [um]")
    ax_f.set_ylabel("frequency [Hz]")
    ax_f.set_xlabel({"mu": "friction coefficient mu", "tan_theta": "run-out slope tan(theta)"}.get(param, param))
    ax_f.set_xlim(lo, hi)
    handles = ax_a.get_legend_handles_labels()[0]
    handles += [Line2D([], [], color="0.3", ls="-", label="stable"),
                Line2D([], [], color="0.3", ls="--", label="unstable"),
                Line2D([], [], color="k", marker="*", ls="", ms=10, label="Hopf point"),
                Line2D([], [], color="k", marker="x", ls="", ms=8, mew=2, label="fold")]
    ax_a.legend(handles=handles, loc="upper left", fontsize=8, ncol=2)
    for ax in (ax_a, ax_f):
        ax.grid(color="0.9")
        ax.set_axisbelow(True)
    return fig
