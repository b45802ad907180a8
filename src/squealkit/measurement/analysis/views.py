"""Figure step: everything the measurement figures draw, computed here so plotting only draws.

:func:`figure_signals` filters a recording as the paper's Figs. 8-13 show it (spectrograms of
both channels, the low-passed run-out split into macro and micro, the band-passed displacement);
:func:`measurement_signals` does so with the settings of an analysis and the views of its squeal
(:func:`squeal_views`: the zoom, the band around the squeal, the spectrogram's top).
``analyze_recording(..., keep_signals=True)`` puts the latter in ``MeasurementResult.signals``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from ..._validation import InputError, validate_fs
from ..signal.filters import bandpass
from ..signal.spectral import P_REF, spectrogram
from ..squeal.runout import split_runout

__all__ = ["figure_signals", "measurement_signals", "squeal_views"]

#: Reference of the displacement's dB scale [m] (1 pm).
_DISP_REF = 1e-12


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


def _spectrogram_db(x: np.ndarray, fs: float, nperseg: int, name: str, ref: float,
                    freq_max: float) -> xr.DataArray:
    """Spectrogram of ``x`` in dB re ``ref`` up to ``freq_max``, dims ``(freq, frame_time)``."""
    sg = spectrogram(x, fs, nperseg=nperseg, name=name).sel(freq=slice(0, freq_max))
    db = 10 * np.log10(np.maximum(sg.values.T, 1e-30) / ref**2)
    return xr.DataArray(db, dims=("freq", "frame_time"),
                        coords={"freq": sg["freq"].values, "frame_time": sg["time"].values})


def figure_signals(rec: xr.Dataset, *, mic: str = "mic", displacement: str = "displacement",
                   rpm: float | None, lowpass_freq: float = 1000.0, macro_orders: int = 10,
                   band: tuple[float, float] = (1000.0, 2500.0), freq_max: float = 10000.0, nperseg: int = 1024,
                   zoom: tuple[float, float] | None = None) -> xr.Dataset:
    """The signals the measurement figures draw (paper Figs. 6-13), from a recording in memory.

    Parameters
    ----------
    rec : xarray.Dataset
        The recording (:func:`squealkit.measurement.read_recording`), with attribute ``fs`` [Hz]
        and a ``time`` coordinate [s].
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels.
    rpm : float or None
        Disc speed [rev/min] of the run-out split; None or NaN: no split (the run-out variables
        are NaN).
    lowpass_freq : float, default 1000.0
        Corner [Hz] of the low-pass that keeps the surface (:func:`~squealkit.measurement.split_runout`).
    macro_orders : int, default 10
        Highest revolution order counted as macro run-out.
    band : (float, float), default (1000.0, 2500.0)
        ``(freq_lower, freq_upper)`` [Hz] of the displacement's band-pass (paper Fig. 13).
    freq_max : float, default 10000.0
        Highest frequency [Hz] of the spectrograms.
    nperseg : int, default 1024
        Frame length [samples] of the spectrograms (Hann window, hop ``nperseg // 4``).
    zoom : (float, float), optional
        Time window [s] the zoomed figures show (attributes ``zoom_start``, ``zoom_end``; NaN: all).

    Returns
    -------
    xarray.Dataset
        Attribute ``kind = "measurement_signals"``. Along ``time``: ``mic`` [Pa] and
        ``displacement`` [m] as recorded, ``runout_lowpass``, ``runout_macro``,
        ``runout_micro`` [m] (``lowpass = macro + micro``) and ``displacement_band`` [m]; along
        ``(freq, frame_time)``: ``mic_level`` [dB re 20 uPa] and ``displacement_level``
        [dB re 1 pm]. Attributes: ``fs``, ``rpm``, ``lowpass_freq``, ``macro_orders``,
        ``freq_lower``, ``freq_upper``, ``freq_max``, ``zoom_start``, ``zoom_end``,
        ``synthetic``, and the channels' names (``mic_channel``, ``displacement_channel``).

    Examples
    --------
    >>> from squealkit.measurement import synthetic_recording
    >>> sig = figure_signals(synthetic_recording(duration=0.5, seed=1), rpm=900.0)
    >>> sig.attrs["kind"], sig["runout_macro"].attrs["units"]
    ('measurement_signals', 'm')
    """
    if mic not in rec or displacement not in rec:
        raise InputError(f"The recording has no channel {mic if mic not in rec else displacement!r}; "
                         f"channels: {', '.join(map(repr, rec.data_vars))}.")
    fs = validate_fs(float(rec.attrs["fs"]))
    p, q = rec[mic].values, rec[displacement].values
    if rpm is None or math.isnan(rpm):
        sro = macro = micro = np.full(q.shape, np.nan)
    else:
        sro, macro, micro = split_runout(q, fs, rpm, lowpass_freq=lowpass_freq, macro_orders=macro_orders)
    qb = bandpass(q, band[0], band[1], fs)
    mic_db = _spectrogram_db(p, fs, nperseg, mic, P_REF, freq_max)
    disp_db = _spectrogram_db(q, fs, nperseg, displacement, _DISP_REF, freq_max)
    t = rec["time"]
    ds = xr.Dataset(
        {
            "mic": ("time", p, {"units": rec[mic].attrs.get("units", ""), "long_name": "sound pressure"}),
            "displacement": ("time", q, {"units": "m", "long_name": "disc surface displacement"}),
            "runout_lowpass": ("time", sro, {"units": "m", "long_name": f"displacement low-passed at "
                                                                        f"{lowpass_freq:g} Hz (surface run-out)"}),
            "runout_macro": ("time", macro, {"units": "m", "long_name": f"macro run-out (orders <= {macro_orders})"}),
            "runout_micro": ("time", micro, {"units": "m", "long_name": "micro run-out"}),
            "displacement_band": ("time", qb, {"units": "m", "long_name": f"displacement band-passed "
                                                                           f"{band[0]:.0f}-{band[1]:.0f} Hz"}),
            "mic_level": (("freq", "frame_time"), mic_db.values, {"units": "dB re 20 uPa",
                                                                  "long_name": "sound pressure spectrogram"}),
            "displacement_level": (("freq", "frame_time"), disp_db.values,
                                   {"units": "dB re 1 pm", "long_name": "displacement spectrogram"}),
        },
        coords={"time": ("time", t.values, {"units": "s"}),
                "freq": ("freq", mic_db["freq"].values, {"units": "Hz"}),
                "frame_time": ("frame_time", mic_db["frame_time"].values, {"units": "s", "long_name": "frame centre"})},
        attrs={"kind": "measurement_signals", "fs": fs, "rpm": math.nan if rpm is None else float(rpm),
               "lowpass_freq": float(lowpass_freq), "macro_orders": int(macro_orders), "freq_lower": float(band[0]),
               "freq_upper": float(band[1]), "freq_max": float(freq_max), "nperseg": int(nperseg),
               "zoom_start": math.nan if zoom is None else float(zoom[0]),
               "zoom_end": math.nan if zoom is None else float(zoom[1]),
               "synthetic": int(bool(rec.attrs.get("synthetic", False))), "mic_channel": str(mic),
               "displacement_channel": str(displacement)},
    )
    return ds


def measurement_signals(rec: xr.Dataset, result: Any, *, mic: str = "mic", displacement: str = "displacement",
                        zoom: tuple[float, float] | None = None) -> xr.Dataset:
    """The signals the figures of an analysis draw: :func:`figure_signals` with its settings and views.

    The run-out split uses the analysis' ``lowpass_freq``, ``macro_orders`` and (mean) disc
    speed; the band-pass, the zoom and the spectrogram's top follow the squeal found
    (:func:`squeal_views`).

    Parameters
    ----------
    rec : xarray.Dataset
        The recording analysed, in memory.
    result : MeasurementResult
        Its analysis (:func:`squealkit.measurement.analyze_recording`).
    mic, displacement : str, default "mic", "displacement"
        Names of the microphone [Pa] and displacement [m] channels in ``rec``.
    zoom : (float, float), optional
        Time window [s] of the zoomed figures (default: the squeal's, from :func:`squeal_views`).

    Returns
    -------
    xarray.Dataset
        As :func:`figure_signals`.
    """
    views = squeal_views(result, float(rec["time"].values[-1]))
    s = result.settings
    rpm = None if result.runout_unavailable is not None else s.rpm
    return figure_signals(rec, mic=mic, displacement=displacement, rpm=rpm, lowpass_freq=s.lowpass_freq,
                          macro_orders=s.macro_orders, band=views["band"], freq_max=views["freq_max"],
                          zoom=zoom if zoom is not None else views["zoom"])
