"""Figures of a rig measurement: paper Figs. 6-13 equivalents and the polar plot.

Every function returns a :class:`matplotlib.figure.Figure` (no pyplot state) and imports
matplotlib only when called. Synthetic recordings say so in the title.

They draw what they are given, a :class:`~squealkit.measurement.MeasurementResult` and the signals
of :func:`~squealkit.measurement.figure_signals` (``result.signals``), and import nothing of
:mod:`squealkit.measurement`: the result's :meth:`~squealkit.measurement.MeasurementResult.plot`
calls them, never the other way round.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .._validation import InputError

__all__ = [
    "band_vs_pressure_plot",
    "event_phase_plot",
    "level_plot",
    "measurement_figures",
    "polar_plot",
    "runout_plot",
    "spectrogram_plot",
    "time_history_plot",
]


def _figure(**kw: Any):
    from matplotlib.figure import Figure

    return Figure(layout="constrained", **kw)


def _tag(rec_or_res: Any) -> str:
    attrs = getattr(rec_or_res, "attrs", {})
    return " [SYNTHETIC]" if attrs.get("synthetic") else ""


def _window(rec: xr.Dataset, t_range: tuple[float, float] | None) -> xr.Dataset:
    return rec if t_range is None else rec.sel(time=slice(*t_range))


def _is_signals(ds: Any) -> bool:
    return isinstance(ds, xr.Dataset) and ds.attrs.get("kind") == "measurement_signals"


def _signals(func: str, ds: Any) -> xr.Dataset:
    """``ds`` if it holds the signals a figure draws; a recording is refused with the call that replaces
    it (plotting draws, never filters: :func:`squealkit.measurement.figure_signals` computes the signals)."""
    if not _is_signals(ds):
        kind = ds.attrs.get("kind") if isinstance(ds, xr.Dataset) else type(ds).__name__
        raise InputError(f"{func}() draws the signals of a recording (kind 'measurement_signals'), not {kind!r}: "
                         "pass figure_signals(recording, ...) or the result's signals "
                         "(analyze_recording(..., keep_signals=True)).")
    return ds


def _t_sel(t: np.ndarray, t_range: tuple[float, float] | None) -> Any:
    return slice(None) if t_range is None else (t >= t_range[0]) & (t <= t_range[1])


def time_history_plot(rec: xr.Dataset, *, mic: str = "mic", displacement: str = "displacement",
                      t_range: tuple[float, float] | None = None):
    """Sound pressure and disc displacement against time (paper Figs. 6-7; zoom: Figs. 10-11).

    Parameters
    ----------
    rec : xarray.Dataset
        The signals of :func:`squealkit.measurement.figure_signals` (or ``result.signals``), or
        the recording itself (:func:`squealkit.measurement.read_recording`): both channels are drawn
        as recorded.
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels in a recording (the signals
        name them ``mic`` and ``displacement``).
    t_range : (float, float), optional
        Time window [s] drawn (default: all).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if _is_signals(rec):
        mic, displacement = "mic", "displacement"
    r = _window(rec, t_range)
    fig = _figure(figsize=(8, 5))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(r["time"], r[mic], lw=0.5)
    ax1.set_ylabel(f"sound pressure [{r[mic].attrs.get('units', '')}]")
    ax2.plot(r["time"], r[displacement] * 1e6, lw=0.5, color="C1")
    ax2.set_ylabel("disc displacement [um]")
    ax2.set_xlabel("time [s]")
    ax1.set_title("Time histories" + (f" {t_range[0]:g}-{t_range[1]:g} s" if t_range else "") + _tag(rec))
    return fig


def spectrogram_plot(signals: xr.Dataset, result: Any = None):
    """Spectrograms of both channels in dB (paper Figs. 8-9), with the squeal ridge if given.

    Parameters
    ----------
    signals : xarray.Dataset
        From :func:`squealkit.measurement.figure_signals` or ``result.signals``: its
        ``mic_level`` and ``displacement_level`` [dB] are drawn.
    result : MeasurementResult, optional
        Its analysis: the ridge of the frames above the threshold is drawn on the sound.

    Returns
    -------
    matplotlib.figure.Figure
    """
    signals = _signals("spectrogram_plot", signals)
    fig = _figure(figsize=(8, 6))
    axes = fig.subplots(2, 1, sharex=True)
    names = (signals.attrs.get("mic_channel", "mic"), signals.attrs.get("displacement_channel", "displacement"))
    for ax, var, name in ((axes[0], "mic_level", names[0]), (axes[1], "displacement_level", names[1])):
        db = signals[var].values
        # rasterized: a vector mesh of every time-frequency cell made a 15-30 MB SVG
        m = ax.pcolormesh(signals["frame_time"], signals["freq"], db, shading="auto", vmin=np.percentile(db, 5),
                          rasterized=True)
        fig.colorbar(m, ax=ax, label=signals[var].attrs["units"])
        ax.set_ylabel(f"{name}\nfrequency [Hz]")
    if result is not None and result.squeal:
        fr = result.frames
        loud = fr["level_dba"] >= result.settings.threshold_dba
        axes[0].plot(fr["time"][loud], fr["ridge_freq"][loud], ".", ms=1.5, color="w", label="ridge")
    t = signals["time"].values
    axes[1].set_xlim(float(t[0]), float(t[-1]))  # the recording, not the ridge's frames beyond it (a blank strip)
    axes[1].set_xlabel("time [s]")
    axes[0].set_title("Spectrograms" + _tag(signals))
    return fig


def runout_plot(signals: xr.Dataset, *, t_range: tuple[float, float] | None = None):
    """Low-passed displacement with its macro and micro run-out (paper Fig. 12).

    Parameters
    ----------
    signals : xarray.Dataset
        From :func:`squealkit.measurement.figure_signals` or ``result.signals``: its
        ``runout_lowpass``, ``runout_macro`` and ``runout_micro`` [m] are drawn.
    t_range : (float, float), optional
        Time window [s] drawn (default: all).

    Returns
    -------
    matplotlib.figure.Figure
    """
    signals = _signals("runout_plot", signals)
    a = signals.attrs
    t = signals["time"].values
    sel = _t_sel(t, t_range)
    fig = _figure(figsize=(8, 4))
    ax = fig.subplots()
    ax.plot(t[sel], signals["runout_lowpass"].values[sel] * 1e6, lw=0.8, label=f"low-pass {a['lowpass_freq']:g} Hz")
    ax.plot(t[sel], signals["runout_macro"].values[sel] * 1e6, lw=1.2,
            label=f"macro (orders <= {a['macro_orders']})")
    ax.plot(t[sel], signals["runout_micro"].values[sel] * 1e6, lw=0.8, label="micro")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("run-out [um]")
    ax.legend(loc="upper right")
    ax.set_title("Disc surface run-out" + _tag(signals))
    return fig


def band_vs_pressure_plot(signals: xr.Dataset, *, t_range: tuple[float, float] | None = None):
    """Band-passed displacement against the sound pressure (paper Fig. 13: 1000-2500 Hz).

    Parameters
    ----------
    signals : xarray.Dataset
        From :func:`squealkit.measurement.figure_signals` or ``result.signals``: its ``mic`` [Pa]
        and ``displacement_band`` [m] are drawn.
    t_range : (float, float), optional
        Time window [s] drawn (default: all).

    Returns
    -------
    matplotlib.figure.Figure
    """
    signals = _signals("band_vs_pressure_plot", signals)
    band = (signals.attrs["freq_lower"], signals.attrs["freq_upper"])
    t = signals["time"].values
    sel = _t_sel(t, t_range)
    fig = _figure(figsize=(8, 5))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(t[sel], signals["mic"].values[sel], lw=0.5)
    ax1.set_ylabel("sound pressure [Pa]")
    ax2.plot(t[sel], signals["displacement_band"].values[sel] * 1e6, lw=0.5, color="C1",
             label=f"band-passed {band[0]:.0f}-{band[1]:.0f} Hz")
    # the band goes in the legend: in the axis label it made a label longer than the panel (issue 27)
    ax2.set_ylabel("displacement [um]")
    ax2.legend(loc="upper right", fontsize=8)
    ax2.set_xlabel("time [s]")
    ax1.set_title("Vibration band against sound pressure" + _tag(signals))
    fig.align_ylabels([ax1, ax2])
    return fig


def level_plot(result: Any, ax: Any = None):
    """A-weighted level against time with the threshold and the events.

    Parameters
    ----------
    result : MeasurementResult
        A result of :func:`squealkit.measurement.analyze_recording`.
    ax : matplotlib Axes, optional
        Where to draw; a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig = _figure(figsize=(8, 3.5))
        ax = fig.subplots()
    else:
        fig = ax.figure
    fr = result.frames
    ax.plot(fr["time"], fr["level_dba"], lw=0.6)
    c = result.settings.criteria
    ax.axhline(c.threshold_dba, color="k", ls="--", lw=0.8,
               label=f"{c.threshold_dba:g} dB(A), {c.band[0]:g}-{c.band[1]:g} Hz ({c.setup})")
    for e in result.events:
        ax.axvspan(e.start_s, e.end_s, color="C3", alpha=0.2, lw=0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"L_A{c.time_weighting[0].upper()} [dB(A)]")
    ax.legend(loc="lower right")
    ax.set_title(f"Squeal level and events ({len(result.events)})" + _tag(result))
    return fig


def polar_plot(result: Any, ax: Any = None):
    """Squeal level and run-out against disc angle over all revolutions (polar).

    Parameters
    ----------
    result : MeasurementResult
        A result of :func:`squealkit.measurement.analyze_recording`.
    ax : matplotlib Axes, optional
        Polar axes to draw into (``projection="polar"``); a new figure if omitted.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig = _figure(figsize=(5.5, 5.5))
        ax = fig.add_subplot(projection="polar")
    elif ax.name != "polar":
        raise ValueError(f"polar_plot needs polar axes (projection='polar'), not {ax.name!r} axes.")
    else:
        fig = ax.figure
    pol = result.polar
    ang = np.append(pol["angle"].values, pol["angle"].values[0])
    lev = np.append(pol["angle_level_db"].values, pol["angle_level_db"].values[0])
    ax.plot(ang, lev, label="squeal-band level [dB]")
    sro = np.append(pol["angle_sro"].values, pol["angle_sro"].values[0])
    span = np.nanmax(sro) - np.nanmin(sro)
    if span > 0 and np.all(np.isfinite(lev)):
        lo, hi = np.nanmin(lev), np.nanmax(lev)
        ax.plot(ang, lo + (sro - np.nanmin(sro)) / span * (hi - lo), "--", label="run-out (scaled)")
    ax.legend(loc="lower left", fontsize="small")
    ax.set_title("Level against disc angle" + _tag(result))
    return fig


def event_phase_plot(result: Any, ax: Any = None):
    """Run-out phase of each squeal event: where on the disc it sounds, relative to the run-out crest.

    A polar plot with the macro run-out's crest at the top and angles growing clockwise (the
    disc's sense of rotation, as in the campaign report): each event is a point at its
    ``runout_phase_deg``, at a radius of its peak level and coloured by its frequency; a line
    from the centre marks the recording's ``runout_phase_deg`` (all the squeal energy).
    Negative angles lie before the crest, on the rising run-out.

    Parameters
    ----------
    result : MeasurementResult
        From :func:`~squealkit.measurement.analyze_recording`.
    ax : matplotlib.projections.polar.PolarAxes, optional
        Draw here (a polar axes); default: a new figure.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from squealkit.measurement import analyze_recording, synthetic_recording
    >>> res = analyze_recording(synthetic_recording(duration=1.0, seed=1), mic="mic",
    ...                         displacement="displacement", rpm=900, radius=0.05)
    >>> fig = event_phase_plot(res)
    """
    if ax is None:
        fig = _figure(figsize=(5.5, 5.0))
        ax = fig.add_subplot(projection="polar")
    fig = ax.figure
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ev = [e for e in result.events if e.runout_phase_deg is not None]
    if ev:
        theta = np.radians([e.runout_phase_deg for e in ev])
        level = np.array([e.peak_dba for e in ev])
        sc = ax.scatter(theta, level, c=[e.frequency_hz for e in ev], cmap="viridis", s=28, edgecolors="k",
                        linewidths=0.4, zorder=3)
        fig.colorbar(sc, ax=ax, pad=0.1, shrink=0.7, label="event frequency [Hz]")
        lo = min(float(level.min()), result.settings.threshold_dba) - 3.0
        ax.set_ylim(lo, float(level.max()) + 3.0)
        if result.runout_phase_deg is not None:
            ph = np.radians(result.runout_phase_deg)
            ax.plot([ph, ph], [lo, float(level.max()) + 3.0], color="C3", lw=1.5,
                    label=f"all squeal: {result.runout_phase_deg:+.0f} deg")
            ax.legend(loc="lower left", fontsize="small", bbox_to_anchor=(-0.1, -0.12))
        ax.set_rlabel_position(157.5)
    else:
        ax.text(0.5, 0.5, "no squeal events", transform=ax.transAxes, ha="center", va="center")
    ticks = np.arange(-135, 181, 45)
    ax.set_xticks(np.radians(ticks % 360), [f"{t:+d}" if t not in (0, 180) else f"{t}" for t in ticks])
    ax.set_thetalim(0.0, 2 * np.pi)  # the whole disc, whatever the events cover
    ax.set_title(f"Run-out phase of the {len(ev)} events (crest at 0 deg; radius: peak dB(A))" + _tag(result),
                 fontsize=9)
    return fig


def measurement_figures(result: Any, signals: xr.Dataset | None = None, *,
                        zoom: tuple[float, float] | None = None) -> dict[str, Any]:
    """All figures of a measurement, keyed by a short name (for ``analyze --plot``).

    The zoom, the band-pass of Fig. 13 and the spectrogram follow the squeal found
    (:func:`squealkit.measurement.squeal_views`, as :func:`squealkit.measurement.measurement_signals`
    computed them): three revolutions at the actual disc speed from the onset of the squeal, the
    band around its frequency. ``zoom`` overrides the time range drawn.

    Parameters
    ----------
    result : MeasurementResult
        The analysis (:func:`squealkit.measurement.analyze_recording`).
    signals : xarray.Dataset, optional
        What the figures draw (:func:`squealkit.measurement.measurement_signals`); default
        ``result.signals`` (``analyze_recording(..., keep_signals=True)``).
    zoom : (float, float), optional
        Time window [s] of the zoomed figures (default: the signals' ``zoom_start``, ``zoom_end``).

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``time``, ``spectrogram``, ``zoom``, ``runout``, ``band``, ``level`` and ``polar``.
    """
    if isinstance(result, xr.Dataset):  # the recording call form (rec, result) computed the signals here
        raise InputError("measurement_figures() draws a result and its signals: use measurement_figures(result, "
                         "measurement_signals(recording, result)), not measurement_figures(recording, result).")
    if signals is None:
        signals = result.signals
    if not _is_signals(signals):
        raise InputError("measurement_figures needs the signals the figures draw: analyze_recording(..., "
                         "keep_signals=True), or pass measurement_signals(recording, result).")
    a = signals.attrs
    z = zoom if zoom is not None else (None if np.isnan(a["zoom_start"]) else (a["zoom_start"], a["zoom_end"]))
    return {
        "time": time_history_plot(signals),
        "spectrogram": spectrogram_plot(signals, result),
        "zoom": time_history_plot(signals, t_range=z),
        "runout": runout_plot(signals, t_range=z),
        "band": band_vs_pressure_plot(signals, t_range=z),
        "level": level_plot(result),
        "polar": polar_plot(result),
    }

