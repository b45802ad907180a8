"""Figures of complex modes: amplitude and phase of each mode shape per degree of freedom.

Draws a result of :func:`squealkit.stability.modes` (or ``onset_modes``) and computes
nothing the result does not hold beyond the amplitude and phase of its stored shapes.
matplotlib is imported inside the functions.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

__all__ = ["modes_plot"]

_STABLE = "tab:blue"
_UNSTABLE = "tab:red"
_ONSET = "tab:orange"
#: Largest number of modes per row of panels.
_PER_ROW = 4


def _role(ds: xr.Dataset, k: int) -> str:
    if bool(ds["unstable"].values[k]):
        return "unstable"
    if "loses_stability" in ds and bool(ds["loses_stability"].values[k]):
        return "onset"
    return "stable"


def modes_plot(ds: xr.Dataset, *, modes: list[int] | None = None, fig=None):
    """Mode shapes: amplitude bars and phase per DOF, one column per mode.

    The upper panel of each column shows the amplitude ``|phi_i|`` of each DOF (largest 1),
    the lower one its phase [deg] (DOFs of amplitude below 1e-6 have no meaningful phase
    and are left out). Unstable modes are red; with an :func:`~squealkit.stability.onset_modes`
    result the mode that loses stability is orange.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squealkit.stability.modes`.
    modes : list of int, optional
        Mode indices to draw; default all.
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    chosen = list(range(ds.sizes["mode"])) if modes is None else list(modes)
    if not chosen:
        raise ValueError("Parameter modes=[] selects no mode to draw.")
    ncol = min(_PER_ROW, len(chosen))
    nrow = math.ceil(len(chosen) / ncol)
    n_dof = ds.sizes["dof"]
    width = max(2.6, 0.55 * n_dof + 1.2)
    fig = fig or Figure(figsize=(width * ncol + 0.6, 4.4 * nrow + 1.0), layout="constrained")
    fig.clf()
    outer = fig.add_gridspec(nrow, ncol)
    phi = ds["shape_real"].values + 1j * ds["shape_imag"].values
    labels = [str(d) for d in ds["dof"].values]
    descriptions = [str(d) for d in ds["dof_description"].values] if "dof_description" in ds.coords else labels
    ticks = [lab if desc == lab else f"{lab}\n{desc.replace(', ', chr(10))}" for lab, desc in
             zip(labels, descriptions, strict=True)]
    x = np.arange(n_dof)
    colors = {"stable": _STABLE, "unstable": _UNSTABLE, "onset": _ONSET}
    roles = set()
    for i, k in enumerate(chosen):
        r, c = divmod(i, ncol)
        role = _role(ds, k)
        roles.add(role)
        color = colors[role]
        amp = np.abs(phi[k])
        phase = np.degrees(np.angle(phi[k]))
        phase[phase <= -180.0 + 1e-6] = 180.0  # -180 and +180 are one phase; show (-180, 180]
        cell = outer[r, c].subgridspec(2, 1, height_ratios=[1.4, 1.0])
        ax_a = fig.add_subplot(cell[0])
        ax_p = fig.add_subplot(cell[1], sharex=ax_a)
        ax_a.bar(x, amp, color=color, width=0.6)
        for xi, a_i in zip(x, amp, strict=True):
            ax_a.annotate(f"{a_i:.2g}", (xi, a_i), xytext=(0, 2), textcoords="offset points", ha="center",
                          va="bottom", fontsize=7)
        ax_a.set_ylim(0.0, 1.18)
        ax_a.tick_params(labelbottom=False)
        f = float(ds["frequency_hz"].values[k])
        sigma = float(ds["growth_rate"].values[k])
        thr = float(ds.attrs.get("unstable_threshold", 0.0))
        # a sigma within the stability engine's round-off bound has no sign to show
        sig = f"|sigma| < {thr:.1g} (round-off)" if abs(sigma) <= thr else f"sigma = {sigma:+.4g} 1/s"
        ax_a.set_title(f"mode {k}: {f:.1f} Hz\n{sig}", fontsize=9, color=color)
        show = amp > 1e-6
        ax_p.axhline(0.0, color="0.7", lw=0.8)
        ax_p.vlines(x[show], 0.0, phase[show], color=color, lw=2)
        ax_p.plot(x[show], phase[show], "o", color=color, ms=5)
        ax_p.set_ylim(-200, 200)
        ax_p.set_yticks([-180, -90, 0, 90, 180])
        ax_p.set_xticks(x, ticks, fontsize=8)
        ax_p.set_xlim(-0.6, n_dof - 0.4)
        if c == 0:
            ax_a.set_ylabel("amplitude |phi| [1]")
            ax_p.set_ylabel("phase [deg]")
        for ax in (ax_a, ax_p):
            ax.grid(axis="y", color="0.9")
            ax.set_axisbelow(True)
    pair = ds.attrs.get("onset_kind") == "coalescence"
    names = {"stable": "stable mode", "unstable": "unstable mode (sigma > 0)",
             "onset": "coalescing pair that loses stability at mu_crit (one double root)" if pair else
             "mode that loses stability at mu_crit"}
    handles = [Patch(color=colors[k], label=names[k]) for k in ("unstable", "onset", "stable") if k in roles]
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=9, frameon=False)
    a = ds.attrs
    where = (f"mu_crit = {a['mu_critical']:.5f}" if "mu_critical" in a else f"mu = {a.get('mu', math.nan):g}")
    damped = "damped" if a.get("damped") else "undamped"
    fig.suptitle(f"Mode shapes at {where}, theta = {a.get('theta_deg', math.nan):g} deg ({damped}); "
                 "largest amplitude 1", fontsize=11)
    return fig
