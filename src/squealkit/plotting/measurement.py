"""Figures of a rig measurement: paper Figs. 6-13 equivalents and the polar plot.

Every function returns a :class:`matplotlib.figure.Figure` (no pyplot state) and imports
matplotlib only when called. Synthetic recordings say so in the title.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

__all__ = [
    "band_vs_pressure_plot",
    "event_phase_plot",
    "level_plot",
    "measurement_figures",
    "polar_plot",
    "runout_plot",
    "spectrogram_plot",
    "squeal_views",
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


def time_history_plot(rec: xr.Dataset, *, mic: str = "mic", displacement: str = "displacement",
                      t_range: tuple[float, float] | None = None):
    """Sound pressure and disc displacement against time (paper Figs. 6-7; zoom: Figs. 10-11).

    Parameters
    ----------
    rec : xarray.Dataset
        The recording (:func:`squealkit.measurement.read_recording`), with attribute ``fs`` [Hz].
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels.
    t_range : (float, float), optional
        Time window [s] drawn (default: all).

    Returns
    -------
    matplotlib.figure.Figure
    """
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


def spectrogram_plot(rec: xr.Dataset, result: Any = None, *, mic: str = "mic", displacement: str = "displacement",
                     nperseg: int = 1024, freq_max: float = 10000.0):
    """Spectrograms of both channels in dB (paper Figs. 8-9), with the squeal ridge if given.

    Parameters
    ----------
    rec : xarray.Dataset
        The recording (:func:`squealkit.measurement.read_recording`), with attribute ``fs`` [Hz].
    result : MeasurementResult, optional
        Its analysis: the ridge of the frames above the threshold is drawn on the sound.
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels.
    nperseg : int, default 1024
        Frame length [samples] (Hann window).
    freq_max : float, default 10000.0
        Highest frequency drawn [Hz].

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..measurement.signal.spectral import P_REF, spectrogram

    fs = float(rec.attrs["fs"])
    fig = _figure(figsize=(8, 6))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, name, ref, unit in ((axes[0], mic, P_REF, "dB re 20 uPa"), (axes[1], displacement, 1e-12, "dB re 1 pm")):
        sg = spectrogram(rec[name].values, fs, nperseg=nperseg, name=name).sel(freq=slice(0, freq_max))
        db = 10 * np.log10(np.maximum(sg.values.T, 1e-30) / ref**2)
        # rasterized: a vector mesh of every time-frequency cell made a 15-30 MB SVG
        m = ax.pcolormesh(sg["time"], sg["freq"], db, shading="auto", vmin=np.percentile(db, 5), rasterized=True)
        fig.colorbar(m, ax=ax, label=unit)
        ax.set_ylabel(f"{name}\nfrequency [Hz]")
    if result is not None and result.squeal:
        fr = result.frames
        loud = fr["level_dba"] >= result.settings.threshold_dba
        axes[0].plot(fr["time"][loud], fr["ridge_freq"][loud], ".", ms=1.5, color="w", label="ridge")
    t = rec["time"].values
    axes[1].set_xlim(float(t[0]), float(t[-1]))  # the recording, not the ridge's frames beyond it (a blank strip)
    axes[1].set_xlabel("time [s]")
    axes[0].set_title("Spectrograms" + _tag(rec))
    return fig


def runout_plot(rec: xr.Dataset, *, displacement: str = "displacement", rpm: float, lowpass_freq: float = 1000.0,
                macro_orders: int = 10, t_range: tuple[float, float] | None = None):
    """Low-passed displacement with its macro and micro run-out (paper Fig. 12).

    Parameters
    ----------
    rec : xarray.Dataset
        The recording (:func:`squealkit.measurement.read_recording`), with attribute ``fs`` [Hz].
    displacement : str, default "displacement"
        Name of the displacement channel [m].
    rpm : float
        Disc speed [rev/min].
    lowpass_freq : float, default 1000.0
        Corner [Hz] of the low-pass that keeps the surface (:func:`~squealkit.measurement.split_runout`).
    macro_orders : int, default 10
        Highest revolution order counted as macro run-out.
    t_range : (float, float), optional
        Time window [s] drawn (default: all).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..measurement.squeal.runout import split_runout

    fs = float(rec.attrs["fs"])
    sro, macro, micro = split_runout(rec[displacement].values, fs, rpm, lowpass_freq=lowpass_freq,
                                     macro_orders=macro_orders)
    t = rec["time"].values
    sel = slice(None) if t_range is None else (t >= t_range[0]) & (t <= t_range[1])
    fig = _figure(figsize=(8, 4))
    ax = fig.subplots()
    ax.plot(t[sel], sro[sel] * 1e6, lw=0.8, label=f"low-pass {lowpass_freq:g} Hz")
    ax.plot(t[sel], macro[sel] * 1e6, lw=1.2, label=f"macro (orders <= {macro_orders})")
    ax.plot(t[sel], micro[sel] * 1e6, lw=0.8, label="micro")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("run-out [um]")
    ax.legend(loc="upper right")
    ax.set_title("Disc surface run-out" + _tag(rec))
    return fig


def band_vs_pressure_plot(rec: xr.Dataset, *, mic: str = "mic", displacement: str = "displacement",
                          band: tuple[float, float] = (1000.0, 2500.0), t_range: tuple[float, float] | None = None):
    """Band-passed displacement (1000-2500 Hz) against the sound pressure (paper Fig. 13).

    Parameters
    ----------
    rec : xarray.Dataset
        The recording (:func:`squealkit.measurement.read_recording`), with attribute ``fs`` [Hz].
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels.
    band : (float, float), default (1000.0, 2500.0)
        ``(freq_lower, freq_upper)`` [Hz] of the displacement's band-pass (the paper's Fig. 13).
    t_range : (float, float), optional
        Time window [s] drawn (default: all).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..measurement.signal.filters import bandpass

    fs = float(rec.attrs["fs"])
    qb = bandpass(rec[displacement].values, band[0], band[1], fs)
    t = rec["time"].values
    sel = slice(None) if t_range is None else (t >= t_range[0]) & (t <= t_range[1])
    fig = _figure(figsize=(8, 5))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(t[sel], rec[mic].values[sel], lw=0.5)
    ax1.set_ylabel("sound pressure [Pa]")
    ax2.plot(t[sel], qb[sel] * 1e6, lw=0.5, color="C1", label=f"band-passed {band[0]:.0f}-{band[1]:.0f} Hz")
    # the band goes in the legend: in the axis label it made a label longer than the panel (issue 27)
    ax2.set_ylabel("displacement [um]")
    ax2.legend(loc="upper right", fontsize=8)
    ax2.set_xlabel("time [s]")
    ax1.set_title("Vibration band against sound pressure" + _tag(rec))
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


def squeal_views(result: Any, t_end: float, *, revolutions: float = 3.0) -> dict[str, Any]:
    """Where the figures look: a zoom over ``revolutions`` turns at the actual speed from the squeal's
    onset, the vibration band around the detected squeal frequency, the spectrogram's top.

    Without squeal: the first revolutions from the start, the paper's 1000-2500 Hz band (Fig. 13).

    Parameters
    ----------
    result : MeasurementResult
        A result of :func:`squealkit.measurement.analyze_recording`.
    t_end : float
        End of the recording [s]; the zoom stops there.
    revolutions : float, default 3.0
        Length of the zoom in disc revolutions.

    Returns
    -------
    dict
        ``zoom``: ``(t0, t1)`` [s]; ``band``: ``(freq_lower, freq_upper)`` [Hz] around the squeal
        frequency ``f`` (``max(lowpass_freq, 0.6 f)`` to ``min(1.25 f, 0.45 fs)``); ``freq_max``:
        top of the spectrogram [Hz].
    """
    fr = result.frames
    fs = result.fs
    t = fr["time"].values
    rpm = fr["rpm"].values if "rpm" in fr else np.full(t.size, result.settings.rpm)
    f_sq = result.squeal_frequency_hz
    if f_sq is not None:
        loud = np.flatnonzero(fr["leq_dba"].values >= result.settings.threshold_dba)
        i = int(loud[0]) if loud.size else int(np.argmax(fr["leq_dba"].values))
        turn = 60.0 / float(rpm[i])
        t0 = max(0.0, float(t[i]) - 0.5 * turn)
        band = (max(result.settings.lowpass_freq, 0.6 * f_sq), min(1.25 * f_sq, 0.45 * fs))
        freq_max = min(0.5 * fs, max(10000.0, 2.5 * f_sq))
    else:
        turn = 60.0 / float(rpm[0])
        t0, band, freq_max = 0.0, (1000.0, 2500.0), min(10000.0, 0.5 * fs)
    t1 = min(t_end, t0 + revolutions * turn)
    return {"zoom": (t0, t1), "band": band, "freq_max": freq_max}


def measurement_figures(rec: xr.Dataset, result: Any, *, mic: str = "mic", displacement: str = "displacement",
                        zoom: tuple[float, float] | None = None) -> dict[str, Any]:
    """All figures of a measurement, keyed by a short name (for ``analyze --plot``).

    The zoom, the band-pass of Fig. 13 and the spectrogram follow the squeal found
    (:func:`squeal_views`): three revolutions at the actual disc speed from the onset of the squeal,
    the band around its frequency. ``zoom`` overrides the time range.

    Parameters
    ----------
    rec : xarray.Dataset
        The recording (:func:`squealkit.measurement.read_recording`), with attribute ``fs`` [Hz].
    result : MeasurementResult
        Its analysis (:func:`squealkit.measurement.analyze_recording`).
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels.
    zoom : (float, float), optional
        Time window [s] of the zoomed figures (default: from :func:`squeal_views`).

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``time``, ``spectrogram``, ``zoom``, ``runout``, ``band``, ``level`` and ``polar``.
    """
    rpm = result.settings.rpm
    views = squeal_views(result, float(rec["time"].values[-1]))
    z = zoom if zoom is not None else views["zoom"]
    return {
        "time": time_history_plot(rec, mic=mic, displacement=displacement),
        "spectrogram": spectrogram_plot(rec, result, mic=mic, displacement=displacement,
                                        freq_max=views["freq_max"]),
        "zoom": time_history_plot(rec, mic=mic, displacement=displacement, t_range=z),
        "runout": runout_plot(rec, displacement=displacement, rpm=rpm, t_range=z,
                              lowpass_freq=result.settings.lowpass_freq, macro_orders=result.settings.macro_orders),
        "band": band_vs_pressure_plot(rec, mic=mic, displacement=displacement, t_range=z, band=views["band"]),
        "level": level_plot(result),
        "polar": polar_plot(result),
    }
