"""Figures of the unstable modes of an FE brake: on the mesh, the friction work, and the tracked branches.

- :func:`friction_work_plot`: the friction work per cycle of one mode on each contact surface
  (matplotlib), from :func:`~squealkit.fe.energy.mode_energy`;
- :func:`mode_tracking_plot`: frequency and growth rate of the MAC-tracked modes over friction
  or disc speed (matplotlib), from :func:`~squealkit.stability.fe_stability_map`;
- :func:`mode_view`: one complex mode animated over its phase on the mesh's surface, a 3D
  view the reader can turn (plotly), from :func:`~squealkit.fe.surface.mode_surface`, with the
  friction work per contact point drawn on it.

Each draws its result; nothing is recomputed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from .stability import _figure

__all__ = ["friction_work_plot", "mode_tracking_plot", "mode_view"]


def _check(ds: xr.Dataset, kind: str, what: str) -> None:
    from .._validation import InputError

    if ds.attrs.get("kind") != kind:
        raise InputError(f"{what} draws a result of kind {kind!r}, got {ds.attrs.get('kind')!r}.")


def _mode_title(ds: xr.Dataset, mode: int) -> str:
    r = ds.sel(mode=mode)
    return (f"mode {mode}: {float(r.frequency_hz):.6g} Hz, sigma {float(r.growth_rate):+.4g} 1/s"
            f" ({ds.attrs.get('rpm', float('nan')):g} rpm, mu {ds.attrs.get('mu', float('nan')):g})")


def friction_work_plot(energy: xr.Dataset, mode: int, *, fig=None):
    """The friction work per cycle of one mode on each contact surface, seen face-on.

    Each contact point (a disc node and the pad node on it) is coloured by the energy friction
    feeds into the mode there per cycle (red: fed in, blue: taken out); one panel per surface
    (pad), seen along the global axis nearest to its normal.

    Parameters
    ----------
    energy : xarray.Dataset
        A result of :func:`~squealkit.fe.energy.mode_energy` of a model with a mesh.
    mode : int
        The mode (a value of the ``mode`` coordinate).
    fig : matplotlib Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check(energy, "fe_mode_energy", "friction_work_plot")
    from .._validation import InputError

    if "friction_work_contact" not in energy:
        raise InputError("The energy result has no contact points (the model has no mesh).")
    e = energy.sel(mode=mode)
    surfaces = [s for s in np.unique(e.contact_body.values) if s]
    fig = fig or _figure(figsize=(3.0 * max(1, len(surfaces)) + 1.6, 4.4), layout="constrained")
    axes = fig.subplots(1, max(1, len(surfaces)), squeeze=False)[0]
    work = e.friction_work_contact.values
    vmax = float(np.nanmax(np.abs(work))) or 1.0
    art = None
    for ax, s in zip(axes, surfaces, strict=False):
        on = e.contact_body.values == s
        xyz = np.column_stack([e.contact_x.values[on], e.contact_y.values[on], e.contact_z.values[on]])
        # face-on: drop the global axis closest to the surface's normal (the least-spread direction)
        normal = np.linalg.svd(xyz - xyz.mean(axis=0), full_matrices=False)[2][-1]
        keep = [a for a in range(3) if a != int(np.argmax(np.abs(normal)))]
        uv = 1e3 * xyz[:, keep]
        w = work[on]
        if on.sum() >= 3 and np.linalg.matrix_rank(uv - uv.mean(axis=0)) == 2:
            art = ax.tripcolor(uv[:, 0], uv[:, 1], w, shading="gouraud", cmap="RdBu_r", vmin=-vmax, vmax=vmax)
        art = ax.scatter(uv[:, 0], uv[:, 1], c=w, cmap="RdBu_r", vmin=-vmax, vmax=vmax, s=14, edgecolors="k",
                         linewidths=0.3)
        ax.set_aspect("equal")
        ax.set_xlabel(f"{'xyz'[keep[0]]} [mm]")
        ax.set_ylabel(f"{'xyz'[keep[1]]} [mm]")
        ax.set_title(f"{s}: {on.sum()} contact points, {np.nansum(w):.3g} J", fontsize=9)
    if art is not None:
        fig.colorbar(art, ax=list(axes), label="friction work per cycle [J]", format="%.2g")
    total, drawn = float(e.friction_work), float(e.friction_work_drawn)
    shown = "" if abs(drawn - total) <= 1e-6 * abs(total) else f"; {drawn:.3g} J on the mesh's nodes"
    fig.suptitle(f"Friction work, {_mode_title(energy, mode)}\ntotal {total:.3g} J per cycle at 1 m largest "
                 f"amplitude{shown}\nred: fed into the mode, blue: taken out", fontsize=9)
    return fig


def mode_tracking_plot(ds: xr.Dataset, *, over: str = "mu", at: int | None = None, fig=None):
    """Frequency and growth rate of each MAC-tracked mode over friction (or disc speed).

    Branches that are unstable somewhere on the line are coloured and labelled by their
    number in the map and their median frequency, the others grey; unstable points are marked.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`~squealkit.stability.fe_stability_map` with ``track=True``.
    over : {"mu", "rpm"}
        The axis along which the modes are drawn.
    at : int, optional
        Index along the other axis (default: its middle).
    fig : matplotlib Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    _check(ds, "fe_stability_map", "mode_tracking_plot")
    from .._validation import InputError

    if over not in ("mu", "rpm"):
        raise InputError(f"Parameter over={over!r}; known: mu, rpm.")
    other = "rpm" if over == "mu" else "mu"
    at = ds.sizes[other] // 2 if at is None else int(at)
    line = ds.isel({other: at})
    x = line[over].values
    f = line["frequency_hz"].transpose(over, "mode").values
    s = line["growth_rate"].transpose(over, "mode").values
    u = line["unstable"].transpose(over, "mode").values
    fig = fig or _figure(figsize=(9.0, 6.0), layout="constrained")
    ax_f, ax_s = fig.subplots(2, 1, sharex=True)
    import matplotlib

    colours = matplotlib.colormaps["tab10"]
    grown = np.flatnonzero(u.any(axis=0))
    for k in range(f.shape[1]):
        if k in grown:
            continue
        ax_f.plot(x, f[:, k], color="0.75", lw=0.8)
        ax_s.plot(x, s[:, k], color="0.75", lw=0.8)
    for n, k in enumerate(grown):
        c = colours(n % 10)
        # the map's branch numbers are its own: the frequency says which mode of a table it is
        label = f"branch {int(line['mode'].values[k])}, {np.nanmedian(f[:, k]):.5g} Hz"
        ax_f.plot(x, f[:, k], color=c, lw=1.6, label=label)
        ax_s.plot(x, s[:, k], color=c, lw=1.6)
        ax_f.plot(x[u[:, k]], f[u[:, k], k], "o", color=c, ms=4)
        ax_s.plot(x[u[:, k]], s[u[:, k], k], "o", color=c, ms=4)
    ax_s.axhline(0.0, color="k", lw=0.8)
    ax_f.set_ylabel("frequency [Hz]")
    ax_s.set_ylabel("growth rate sigma [1/s]")
    ax_s.set_xlabel("friction coefficient mu" if over == "mu" else "disc speed [rpm]")
    where = f"{float(line[other]):g} rpm" if other == "rpm" else f"mu = {float(line[other]):g}"
    ax_f.set_title(f"Modes tracked by MAC over {'friction' if over == 'mu' else 'disc speed'} at {where} "
                   f"({len(grown)} become unstable: coloured; dots: unstable)", fontsize=9)
    if len(grown):
        ax_f.legend(fontsize=7, ncol=1 if len(grown) <= 12 else 2, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig


def mode_view(surface: xr.Dataset, mode: int, *, energy: xr.Dataset | None = None, n_frames: int = 16,
              amplification: float | None = None):
    """One complex mode animated over its phase on the mesh: a 3D plotly figure the reader can turn.

    Frame k shows ``Re(phi e^{j 2 pi k / n_frames})`` added to the mesh, coloured by the
    amplitude of the motion at each point; play/pause buttons and a phase slider step through
    the cycle. With ``energy``, the friction work per contact point is drawn as coloured
    markers (red: fed into the mode). Coordinates are sent as float32.

    Parameters
    ----------
    surface : xarray.Dataset
        A result of :func:`~squealkit.fe.surface.mode_surface`.
    mode : int
        The mode (a value of the ``mode`` coordinate).
    energy : xarray.Dataset, optional
        The :func:`~squealkit.fe.energy.mode_energy` of the same modes.
    n_frames : int, default 16
        Frames over one cycle.
    amplification : float, optional
        Displacement scale [m per unit shape]; default: the largest displacement drawn is 5 %
        of the mesh's size.

    Returns
    -------
    plotly.graph_objects.Figure
    """
    import plotly.graph_objects as go

    _check(surface, "fe_mode_surface", "mode_view")
    s = surface.sel(mode=mode)
    xyz = np.column_stack([surface.x.values, surface.y.values, surface.z.values])
    shape = (s.shape_real.values + 1j * s.shape_imag.values)  # (p, 3)
    size = float(np.ptp(xyz, axis=0).max()) or 1.0
    peak = float(np.abs(shape).max()) or 1.0
    amp = 0.05 * size / peak if amplification is None else float(amplification)
    tri = surface.triangles.values
    f32 = np.float32

    def frame(phase: float) -> dict[str, Any]:
        pos = (xyz + (shape * np.exp(1j * phase)).real * amp).astype(f32)
        return {"x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2]}

    phases = 2 * math.pi * np.arange(n_frames) / n_frames
    # coloured by the amplitude of the motion at each point (the envelope over the cycle): where the mode lives
    envelope = np.linalg.norm(np.abs(shape), axis=1)
    envelope = (envelope / (envelope.max() or 1.0)).astype(f32)
    mesh = go.Mesh3d(**frame(0.0), i=tri[:, 0].astype(np.int32), j=tri[:, 1].astype(np.int32),
                     k=tri[:, 2].astype(np.int32), intensity=envelope, colorscale="Viridis", cmin=0.0, cmax=1.0,
                     colorbar={"title": {"text": "amplitude / max", "side": "right"}, "x": 1.0, "len": 0.6},
                     flatshading=True, lighting={"ambient": 0.55, "diffuse": 0.7}, name="mode shape",
                     hoverinfo="skip")
    data = [mesh]
    if energy is not None and "friction_work_contact" in energy:
        e = energy.sel(mode=mode)
        w = e.friction_work_contact.values
        vmax = float(np.nanmax(np.abs(w))) or 1.0
        data.append(go.Scatter3d(
            x=e.contact_x.values.astype(f32), y=e.contact_y.values.astype(f32), z=e.contact_z.values.astype(f32),
            mode="markers", name="friction work per cycle [J]", visible="legendonly",
            marker={"size": 4, "color": w.astype(f32), "colorscale": "RdBu_r", "cmin": -vmax, "cmax": vmax,
                    "colorbar": {"title": {"text": "friction work [J]", "side": "right"}, "x": 1.12, "len": 0.6}},
            hovertemplate="%{marker.color:.3g} J<extra></extra>"))
    frames = [go.Frame(data=[go.Mesh3d(**frame(p))], traces=[0], name=f"{math.degrees(p):.0f}") for p in phases]
    play = {"args": [None, {"frame": {"duration": 90, "redraw": True}, "fromcurrent": True,
                            "transition": {"duration": 0}, "mode": "immediate"}], "label": "play", "method": "animate"}
    pause = {"args": [[None], {"frame": {"duration": 0, "redraw": False}, "mode": "immediate"}],
             "label": "pause", "method": "animate"}
    steps = [{"args": [[fr.name], {"frame": {"duration": 0, "redraw": True}, "mode": "immediate"}],
              "label": fr.name, "method": "animate"} for fr in frames]
    fig = go.Figure(data=data, frames=frames)
    fig.update_layout(
        title={"text": _mode_title(surface, mode) + f"<br><sup>displacement x {amp:.3g} (shape largest "
                                                    "amplitude 1); drag to turn, scroll to zoom</sup>",
               "font": {"size": 13}},
        scene={"aspectmode": "data", "xaxis": {"visible": False}, "yaxis": {"visible": False},
               "zaxis": {"visible": False}, "camera": {"eye": {"x": 0.9, "y": -1.3, "z": 0.9}}},
        margin={"l": 0, "r": 0, "t": 60, "b": 0}, height=520, showlegend=len(data) > 1,
        legend={"x": 0.0, "y": 0.98},
        updatemenus=[{"type": "buttons", "buttons": [play, pause], "x": 0.0, "y": 0.0, "xanchor": "left",
                      "yanchor": "top", "direction": "left", "pad": {"t": 10}}],
        sliders=[{"steps": steps, "currentvalue": {"prefix": "phase [deg]: "}, "x": 0.15, "len": 0.8, "y": 0.0,
                  "pad": {"t": 10}}],
    )
    return fig
