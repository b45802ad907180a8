"""Figures of stability results: the paper's Fig. 2, a stability map, a root locus, two kinematics.

Each function draws a result computed elsewhere and returns the matplotlib Figure; none
computes anything the result does not hold. matplotlib is imported inside the functions.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .._accessor import upgrade_result

__all__ = [
    "coupled_modes",
    "critical_plot",
    "fig2_plot",
    "kinematics_plot",
    "root_locus_plot",
    "stability_map_plot",
    "tolerance_plot",
]


def _figure(**kwargs: Any):
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def _axes(ax, figsize: tuple[float, float]):
    """The given axes and their figure, or a new single-axes figure."""
    if ax is None:
        ax = _figure(figsize=figsize).add_subplot(1, 1, 1)
    return ax.figure, ax


def coupled_modes(ds: xr.Dataset) -> list[int]:
    """Modes that become unstable anywhere on the grid, with the modes they lock in with.

    Falls back to all modes on a grid without instability.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`squealkit.stability.stability_map` (dims ``mu``, ``theta``, ``mode``).

    Returns
    -------
    list of int
        Mode indices, increasing: the unstable ones and the mode nearest in frequency to the
        fastest-growing one at its grid point (its lock-in partner).
    """
    sigma = ds["growth_rate"].values
    omega = ds["omega"].values
    unstable = ds["unstable"].values.any(axis=(0, 1))
    chosen = set(np.flatnonzero(unstable).tolist())
    if not chosen:
        return list(range(ds.sizes["mode"]))
    i, j = np.unravel_index(np.argmax(sigma.max(axis=-1)), sigma.shape[:2])
    k = int(np.argmax(sigma[i, j]))
    dw = np.abs(omega[i, j] - omega[i, j, k])
    dw[k] = np.inf
    chosen.add(int(np.argmin(dw)))
    return sorted(chosen)


def fig2_plot(ds: xr.Dataset, *, modes: list[int] | None = None, fig=None):
    """Paper Fig. 2: real and imaginary parts of the eigenvalues over mu and theta.

    Parameters
    ----------
    ds : xarray.Dataset
        A stability map (:func:`squealkit.stability.stability_map`).
    modes : list of int, optional
        Modes to draw; default the coupled ones (:func:`coupled_modes`).
    fig : matplotlib Figure, optional
        Figure to draw into (cleared); a new one otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = fig or _figure(figsize=(12, 5.2))
    fig.clf()
    modes = coupled_modes(ds) if modes is None else modes
    MU, TH = np.meshgrid(ds.mu.values, ds.theta_deg.values, indexing="ij")
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown"]
    titles = ("(a) real part: growth rate sigma [1/s]", "(b) imaginary part: omega [rad/s]")
    for panel, (var, title) in enumerate(zip(("growth_rate", "omega"), titles, strict=True)):
        ax = fig.add_subplot(1, 2, panel + 1, projection="3d")
        for n, k in enumerate(modes):
            Z = ds[var].isel(mode=k).values
            # unshaded: the surface shows the legend's colour
            ax.plot_surface(MU, TH, Z, color=colors[n % len(colors)], alpha=0.75, linewidth=0, rasterized=True,
                            rstride=max(1, MU.shape[0] // 40), cstride=max(1, MU.shape[1] // 40), shade=False)
            ax.plot([], [], color=colors[n % len(colors)], label=f"mode {k}")
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(4))  # 9 mu labels ran together
        ax.yaxis.set_major_locator(MaxNLocator(5))
        ax.set_xlabel("friction coefficient mu")
        ax.set_ylabel("incline theta [deg]")
        ax.set_zlabel("sigma [1/s]" if var == "growth_rate" else "omega [rad/s]")
        ax.set_title(title, fontsize=10)
        ax.view_init(elev=22, azim=-128)
        ax.legend(loc="upper left", fontsize=8)
    damped = "damped" if ds.attrs.get("damped") else "undamped (eq. 7)"
    fig.suptitle(f"Complex eigenvalues versus friction and SRO incline, {damped}")
    return fig


def stability_map_plot(ds: xr.Dataset, *, critical: xr.Dataset | None = None, ax=None):
    """Largest growth rate over (mu, theta) with the stability boundary.

    Parameters
    ----------
    ds : xarray.Dataset
        A stability map.
    critical : xarray.Dataset, optional
        A critical-friction curve (:func:`squealkit.stability.critical_friction_curve`)
        drawn over the map.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 5))
    sig = ds["max_growth_rate"].values
    # growth rates below rounding of the frequencies (1e-9 of the largest) are zero: a stable rig's
    # +-1e-26 must not fill the map with full red and blue
    floor = 1e-9 * float(np.nanmax(np.abs(ds["omega"].values))) if "omega" in ds else 1e-12
    sig = np.where(np.abs(sig) <= floor, 0.0, sig)
    vmax = max(float(np.nanmax(np.abs(sig))), floor) or 1.0
    mesh = ax.pcolormesh(ds.mu.values, ds.theta_deg.values, sig.T, cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                         shading="auto", rasterized=True)
    fig.colorbar(mesh, ax=ax, label="largest growth rate sigma [1/s]")
    if ds.sizes["mu"] > 1 and ds.sizes["theta"] > 1:
        ax.contour(ds.mu.values, ds.theta_deg.values, ds["any_unstable"].values.T.astype(float), levels=[0.5],
                   colors="k", linewidths=1.2)
    if critical is not None:
        ax.plot(critical["mu_critical"].values, critical["theta_deg"].values, "k--", lw=1.5,
                label="critical friction mu_crit(theta)")
        ax.legend(loc="lower left", fontsize=8)
    ax.set_xlabel("friction coefficient mu")
    ax.set_ylabel("run-out incline theta [deg]")
    ax.set_title("Stability map: unstable where sigma > 0 (red)" if bool(ds["any_unstable"].any()) else
                 "Stability map: stable at every point (rounding-size sigma shown as 0)")
    return fig


def root_locus_plot(ds: xr.Dataset, *, theta_index: int | None = None, modes: list[int] | None = None, ax=None):
    """Eigenvalues in the complex plane as mu_e = mu + tan(theta) grows (one theta column).

    Parameters
    ----------
    ds : xarray.Dataset
        A stability map.
    theta_index : int, optional
        Which theta column to follow; default the one nearest theta = 0.
    modes : list of int, optional
        Modes to draw; default the coupled ones (:func:`coupled_modes`), so a far mode does not
        shrink the coalescence to a few pixels.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 5))
    j = int(np.argmin(np.abs(ds.theta.values))) if theta_index is None else theta_index
    col = upgrade_result(ds).isel(theta=j)  # frequency_hz, also in a file saved as "frequency"
    mu_e = col["mu_e"].values
    sc = None
    for k in coupled_modes(ds) if modes is None else modes:
        sc = ax.scatter(col["growth_rate"].isel(mode=k), col["frequency_hz"].isel(mode=k), c=mu_e, s=8,
                        cmap="viridis", rasterized=True)
    if sc is not None:
        fig.colorbar(sc, ax=ax, label="mu_e = mu + tan(theta)")
    ax.axvline(0.0, color="k", lw=0.8)
    ax.set_xlabel("growth rate sigma [1/s]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_title(f"Root locus over mu_e (theta = {float(col.theta_deg):.2f} deg)")
    return fig


def kinematics_plot(ds: xr.Dataset, *, ax=None):
    """Critical friction over the run-out incline for each contact kinematics, with mu + tan(theta).

    Parameters
    ----------
    ds : xarray.Dataset
        Critical-friction curves (:func:`squealkit.stability.critical_friction_curve`) stacked
        along a ``kinematics`` dimension (``"paper"``, ``"consistent"``).
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 4.5))
    styles = {"paper": ("C0", "o"), "consistent": ("C3", "s")}
    for kin in ds["kinematics"].values.tolist():
        r = ds.sel(kinematics=kin)
        color, marker = styles.get(kin, ("k", "x"))
        ax.plot(r.theta_deg.values, r.mu_critical.values, color=color, marker=marker, ms=4,
                label=f"{kin}: mu_crit")
        ax.plot(r.theta_deg.values, r.mu_e_critical.values, color=color, ls="--", lw=1,
                label=f"{kin}: mu_crit + tan(theta)")
        gone = ~np.isfinite(r.mu_critical.values)
        if gone.any():
            top = float(ds.attrs.get("mu_max", np.nanmax(ds.mu_critical.values)))
            ax.plot(r.theta_deg.values[gone], np.full(gone.sum(), top), color=color, marker="^", ls="none",
                    label=f"{kin}: stable up to mu = {top:g}")
    ax.set_xlabel("run-out incline theta [deg]")
    ax.set_ylabel("critical friction")
    ax.set_title("Onset of squeal: the paper's contact kinematics and the consistent ones")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def critical_plot(ds: xr.Dataset, *, ax=None):
    """Critical friction over the run-out incline with every unstable friction window.

    Each incline's unstable windows along mu are drawn as red bars, mu_crit(theta) and
    mu_crit + tan(theta) (eq. 6) as lines; an incline without onset in the searched range is
    marked at the top of the range ("stable up to mu_max").

    Parameters
    ----------
    ds : xarray.Dataset
        A critical-friction curve (:func:`squealkit.stability.critical_friction_curve`), one
        incline or many.
    ax : matplotlib Axes, optional
        Axes to draw into; a new figure otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 4.5))
    th = ds.theta_deg.values
    mu_max = float(ds.attrs.get("mu_max", 2.0))
    width = 0.6 * (float(np.min(np.diff(th))) if th.size > 1 else 1.0)
    for i, t in enumerate(th):
        for k, (lo, hi) in enumerate(ds.unstable_intervals.values[i]):
            if np.isfinite(lo):
                ax.bar(t, hi - lo, bottom=lo, width=width, color="tab:red", alpha=0.3, lw=0,
                       label="unstable friction window" if i == 0 and k == 0 else None)
    mu_c = ds.mu_critical.values
    style = "o-" if th.size > 1 else "o"
    ax.plot(th, mu_c, style, color="k", ms=4, label="mu_crit")
    ax.plot(th, ds.mu_e_critical.values, style.replace("-", "--"), color="C0", ms=3, lw=1,
            label="mu_crit + tan(theta) (eq. 6)")
    none = ~np.isfinite(mu_c)
    if none.any():
        ax.plot(th[none], np.full(none.sum(), mu_max), "^", color="C2", ls="none",
                label=f"no onset: stable up to mu = {mu_max:g}")
    ax.set_ylim(min(0.0, float(np.nanmin(np.append(mu_c, 0.0)))), 1.05 * mu_max)
    if th.size == 1:
        ax.set_xlim(th[0] - 1.0, th[0] + 1.0)
        if np.isfinite(mu_c[0]):
            ax.annotate(f"mu_crit = {mu_c[0]:.4f}", (th[0], mu_c[0]), xytext=(12, -14), textcoords="offset points")
    ax.set_xlabel("run-out incline theta [deg]")
    ax.set_ylabel("friction coefficient mu")
    damped = "damped" if ds.attrs.get("damped") else "undamped"
    ax.set_title(f"Critical friction and unstable windows ({damped}, mu searched 0 to {mu_max:g})")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    return fig


def tolerance_plot(ds: xr.Dataset, *, ax=None):
    """Run-out tolerance against friction: the largest stable slope and, with a wavelength, amplitude.

    Parameters
    ----------
    ds : xarray.Dataset
        Over ``mu``: ``tan_theta_max`` (inf where every slope searched is stable),
        ``limiting_side`` and optionally ``q0_max`` [m] (as written by ``squealkit tolerance
        --out``).
    ax : matplotlib Axes, optional
        Axes to draw into; a new figure otherwise.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, (7, 4.5))
    mu = ds.mu.values
    s = ds.tan_theta_max.values
    finite = np.isfinite(s)
    ax.plot(mu[finite], s[finite], "o-", color="k", ms=4, label="largest stable slope tan(theta)")
    top = float(np.nanmax(s[finite])) if finite.any() else 1.0
    if (~finite).any():
        ax.plot(mu[~finite], np.full((~finite).sum(), 1.05 * top), "^", color="C2", ls="none",
                label=f"stable at every slope searched (up to {ds.attrs.get('slope_max_deg', 80):g} deg)")
    flat = ds.limiting_side.values == "flat"
    if flat.any():
        ax.plot(mu[flat], s[flat], "x", color="tab:red", ms=8, ls="none", label="unstable on a flat disc")
    ax.set_xlabel("friction coefficient mu")
    ax.set_ylabel("tan(theta) max")
    ax.grid(alpha=0.3)
    if "q0_max" in ds and np.isfinite(ds.q0_max.values).any():
        lam = float(ds.attrs["wavelength"])
        sec = ax.secondary_yaxis("right", functions=(lambda t: t * lam / (2 * np.pi) * 1e6,
                                                      lambda q: q * 2 * np.pi / lam / 1e6))
        sec.set_ylabel(f"q0 max [um] at lambda = {lam * 1e3:g} mm (eq. 11)")
    damped = "damped" if ds.attrs.get("damped") else "undamped"
    ax.set_title(f"Run-out tolerance ({damped})")
    ax.legend(fontsize=8, loc="center right")
    return fig
