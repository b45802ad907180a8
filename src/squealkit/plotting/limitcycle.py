"""Bifurcation diagram of a limit-cycle branch: amplitude and frequency against friction.

Draws a result of :func:`squealkit.nonlinear.limit_cycle_branch` and computes nothing it
does not hold. matplotlib is imported inside the function.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

__all__ = ["how_loud_level_plot", "how_loud_plot", "limitcycle_plot", "limitcycle_signal_plot"]

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
    black crosses. A branch with ``level_db`` (:func:`squealkit.nonlinear.sound_level`)
    shows the level on a secondary axis (black dash-dot).

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
    if param == "tan_theta" and "theta_deg" in ds.coords:  # over the incline: drawn in degrees
        mu = ds["theta_deg"].values
    stable = ds["stable"].values.astype(bool)
    amp = ds["amplitude"].values * 1e6
    freq = ds["frequency_hz"].values
    mu_h = float(ds.attrs["hopf_mu"])
    pad = 0.05 * float(np.ptp(mu)) if mu.size > 1 else 0.0
    lo, hi = (float(v) for v in ds.attrs.get(f"{param}_range", [mu.min() - pad, mu.max() + pad]))
    in_deg = param == "tan_theta" and "theta_deg" in ds.coords
    if in_deg:
        mu_h, lo, hi = (float(np.degrees(np.arctan(v))) for v in (mu_h, lo, hi))
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
    if "level_db" in ds:  # the sound level on a secondary axis (it is not a function of one amplitude alone)
        ax_l = ax_a.twinx()
        lev = ds["level_db"].values
        for i0, i1 in runs:
            ax_l.plot(mu[i0:i1 + 1], lev[i0:i1 + 1], ls=":" if not stable[i0] else "-.", color="k", lw=1.2)
        ax_l.set_ylabel(f"level [dB SPL re 20 uPa], from {ds.attrs.get('level_dof', '')}")
        finite = lev[np.isfinite(lev)]
        if finite.size:
            ax_l.set_ylim(max(finite.min(), finite.max() - 60) - 2, finite.max() + 3)
    kind = ds.attrs.get("hopf_kind", ds.attrs.get("kind", ""))  # "kind" in a branch saved before the rename
    ax_a.set_title(f"Limit cycles by harmonic balance (H = {ds.attrs.get('harmonics')}): "
                   f"Hopf at {'theta' if in_deg else param} = {mu_h:.4f}{' deg' if in_deg else ''}, "
                   f"{ds.attrs['hopf_frequency_hz']:.1f} Hz, {kind}", fontsize=10)
    ax_a.set_ylabel("amplitude (half peak-to-peak) [um]")
    ax_f.set_ylabel("frequency [Hz]")
    ax_f.set_xlabel("run-out incline theta [deg] (at mu = " + f"{ds.attrs.get('mu', float('nan')):g})" if in_deg else
                    {"mu": "friction coefficient mu", "tan_theta": "run-out slope tan(theta)"}.get(param, param))
    ax_f.set_xlim(lo, hi)
    handles = ax_a.get_legend_handles_labels()[0]
    handles += [Line2D([], [], color="0.3", ls="-", label="stable"),
                Line2D([], [], color="0.3", ls="--", label="unstable"),
                Line2D([], [], color="k", marker="*", ls="", ms=10, label="Hopf point"),
                Line2D([], [], color="k", marker="x", ls="", ms=8, mew=2, label="fold")]
    if "level_db" in ds:
        handles.append(Line2D([], [], color="k", ls="-.", lw=1.2, label="level (right axis)"))
    ax_a.legend(handles=handles, loc="upper left", fontsize=8, ncol=2)
    for ax in (ax_a, ax_f):
        ax.grid(color="0.9")
        ax.set_axisbelow(True)
    return fig


def limitcycle_signal_plot(ds: xr.Dataset, point: int = -1, *, n_samples: int = 512, fig=None):
    """One period of a cycle of the branch: each DOF's vibration about its mean [um] against time [ms].

    The signal is the Fourier series the result stores (``coefficients``), summed at
    ``n_samples`` instants.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squealkit.nonlinear.limit_cycle_branch`.
    point : int
        Which point of the branch (default the last).
    n_samples : int
        Instants per period.
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    c = ds["coefficients"].isel(point=point).values
    omega = float(ds["omega_rad_s"].isel(point=point))
    H = (c.shape[0] - 1) // 2
    tau = 2 * np.pi * np.arange(n_samples + 1) / n_samples
    k = np.arange(1, H + 1)
    x = np.cos(np.outer(tau, k)) @ c[1:H + 1] + np.sin(np.outer(tau, k)) @ c[H + 1:]
    t_ms = tau / omega * 1e3
    fig = fig or Figure(figsize=(7.0, 3.8), layout="constrained")
    fig.clf()
    ax = fig.add_subplot()
    for j, dof in enumerate(ds["dof"].values):
        ax.plot(t_ms, x[:, j] * 1e6, color=_COLORS[j % len(_COLORS)], label=str(dof))
    param = str(ds.attrs.get("param", "mu"))
    p = float(ds[param].isel(point=point))
    stable = "stable" if bool(ds["stable"].isel(point=point)) else "unstable"
    ax.set_title(f"One period at {param} = {p:.4f}: {omega / (2 * np.pi):.2f} Hz, {stable}", fontsize=10)
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("displacement about the mean [um]")
    ax.legend(fontsize=8)
    ax.grid(color="0.9")
    return fig


def how_loud_plot(branch: xr.Dataset, slope_branch: xr.Dataset | None, envelope: xr.DataArray, cycle: xr.DataArray, *,
                  dof: str = "x1", fig=None):
    """The report's "How loud" figure: limit-cycle amplitude over mu_e, and a run-out transient beside it.

    Top: the amplitude of ``dof`` [um] over the effective friction ``mu_e = mu + tan(theta)``,
    from a branch over friction on a flat disc and from a branch over the run-out slope at
    one friction (stable solid, unstable dashed). Bottom: a transient's vibration envelope
    [um] against time [ms] beside the limit-cycle amplitude at each instant's slope.

    Parameters
    ----------
    branch : xarray.Dataset
        :func:`squealkit.nonlinear.limit_cycle_branch` at theta = 0.
    slope_branch : xarray.Dataset or None
        :func:`squealkit.nonlinear.limit_cycle_branch_slope` (its ``mu`` attribute is the friction);
        None where the run-out starts no squeal.
    envelope : xarray.DataArray
        The transient's envelope of ``dof`` [m] over ``time`` [s].
    cycle : xarray.DataArray
        The limit-cycle amplitude of ``dof`` [m] at each instant's slope, over ``time`` [s]
        (0 where the quiet state is stable).
    dof : str
        The DOF drawn.
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = fig or Figure(figsize=(7.5, 6.5), layout="constrained")
    fig.clf()
    ax_b, ax_t = fig.subplots(2, 1, height_ratios=[1.2, 1.0])
    curves = [(branch, branch["mu"].values, "tab:blue", "flat disc, over mu")]
    if slope_branch is not None:
        mu_fixed = float(slope_branch.attrs["mu"])
        curves.append((slope_branch, mu_fixed + slope_branch["tan_theta"].values, "tab:red",
                       f"run-out at mu = {mu_fixed:g}, over mu + tan(theta)"))
    for ds, x, color, label in curves:
        st = ds["stable"].values.astype(bool)
        a = ds["amplitude"].sel(dof=dof).values * 1e6
        for i0, i1 in _runs(st):
            ax_b.plot(x[i0:i1 + 1], a[i0:i1 + 1], "-" if st[i0] else "--", color=color, lw=1.8)
        ax_b.plot([], [], "-", color=color, label=label)
    ax_b.plot([branch.attrs["hopf_mu"]], [0], "k*", ms=11, label="onset (Hopf point)")
    ax_b.set_xlabel("effective friction mu_e = mu + tan(theta)")
    ax_b.set_ylabel(f"{dof} amplitude [um]")
    ax_b.legend(fontsize=8, loc="lower right")  # the branches rise from the onset at the left
    t_ms = envelope["time"].values * 1e3
    ax_t.plot(t_ms, envelope.values * 1e6, color="tab:gray", lw=1.0, label=f"transient: {dof} envelope (> 1 kHz)")
    ax_t.plot(cycle["time"].values * 1e3, cycle.values * 1e6, "--", color="tab:red", lw=1.6,
              label="limit cycle at the instant's slope")
    ax_t.set_xlabel("time [ms]")
    ax_t.set_ylabel(f"{dof} amplitude [um]")
    ax_t.legend(fontsize=8, loc="upper right")
    for ax in (ax_b, ax_t):
        ax.grid(color="0.9")
        ax.set_axisbelow(True)
    return fig


def how_loud_level_plot(branch: xr.Dataset, slope_branch: xr.Dataset | None = None, *, dof: str = "x1", fig=None):
    """The report's dB figure: the limit cycles' vibration velocity level over mu_e = mu + tan(theta).

    Draws the ``velocity_level_db`` each branch holds [dB re 1 nm/s] (the report adds it from the
    cycles' Fourier coefficients), stable solid and unstable dashed, the flat-disc branch over mu
    and the run-out branch over its friction plus tan(theta).

    Parameters
    ----------
    branch : xarray.Dataset
        A flat-disc branch with ``velocity_level_db`` over ``point``.
    slope_branch : xarray.Dataset or None
        A run-out branch (its ``mu`` attribute is the friction) with ``velocity_level_db``.
    dof : str
        The DOF the level belongs to (for the label).
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = fig or Figure(figsize=(7.5, 3.6), layout="constrained")
    fig.clf()
    ax = fig.subplots()
    curves = [(branch, branch["mu"].values, "tab:blue", "flat disc, over mu")]
    if slope_branch is not None:
        mu_fixed = float(slope_branch.attrs["mu"])
        curves.append((slope_branch, mu_fixed + slope_branch["tan_theta"].values, "tab:red",
                       f"run-out at mu = {mu_fixed:g}, over mu + tan(theta)"))
    for ds, x, color, label in curves:
        st = ds["stable"].values.astype(bool)
        level = ds["velocity_level_db"].values
        for i0, i1 in _runs(st):
            ax.plot(x[i0:i1 + 1], level[i0:i1 + 1], "-" if st[i0] else "--", color=color, lw=1.8)
        ax.plot([], [], "-", color=color, label=label)
    ax.set_xlabel("effective friction mu_e = mu + tan(theta)")
    ax.set_ylabel(f"{dof} velocity level [dB re 1 nm/s]")
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(color="0.9")
    ax.set_axisbelow(True)
    return fig
