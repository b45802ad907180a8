"""Assembly step: the accumulated features labelled into a
:class:`~squealkit.measurement.MeasurementResult`."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from ..signal.spectral import P_REF
from ..squeal.criteria import EDGE_HZ
from ..squeal.events import SquealEvent
from ..squeal.runout import surface_speed
from .framing import _Accumulators, _Plan
from .result import MeasurementResult
from .settings import AnalysisSettings


def _assemble(
    plan: _Plan, s: AnalysisSettings, acc: _Accumulators, rotation: Any, src: Any, attrs: dict[str, Any], *,
    events: list[SquealEvent], squeal_f: float | None, harmonics: list[dict[str, float]],
    rising: float | None, corr: float | None, phase: float | None, unavailable: str | None = None,
) -> MeasurementResult:
    """Result step: label the accumulated features (frames, revolutions, angles, spectrum).

    Parameters
    ----------
    plan, s, acc
        The analysis after its last window.
    rotation : DiscAngle, ConstantSpeed or None
        For the frames' disc speed (None: unknown).
    src : RecordingSource-like
        For the source's name.
    attrs : dict
        The recording's attributes.
    events, squeal_f, harmonics, rising, corr, phase
        From the events and run-out link steps.
    unavailable : str, optional
        Why the run-out link could not be computed.

    Returns
    -------
    MeasurementResult
    """
    fs, n, hop, nb = plan.fs, plan.n, plan.hop, plan.nb
    level = 10 * np.log10(np.maximum(acc.level, 1e-300) / P_REF**2)
    peak = float(10 * np.log10(max(acc.laf_max, 1e-300) / P_REF**2))
    t_frames = np.arange(plan.n_frames) * hop / fs + n / 2 / fs
    frames = xr.Dataset(
        {
            "level_dba": ("time", level, {"units": "dB(A)", "long_name":
                                          f"L_A{s.criteria.time_weighting[0].upper()} {s.band[0]:g}-{s.band[1]:g} Hz "
                                          "(max over the frame's interval)"}),
            "leq_dba": ("time", acc.leq, {"units": "dB(A)", "long_name": "A-weighted band level of the Hann frame"}),
            "ridge_freq": ("time", acc.ridge_f, {"units": "Hz", "long_name": "strongest line in the band"}),
            "band_power": ("time", acc.e_tot, {"units": "Pa^2", "long_name": "mean square in the band (Hann frame)"}),
            "rising_power": ("time", acc.e_rise, {"units": "Pa^2",
                                                  "long_name": "band_power x share on rising run-out"}),
            "tan_theta": ("time", acc.slope_f, {"units": "1", "long_name": "mean SRO slope tan(theta)"}),
            "rpm": ("time", np.full(t_frames.size, np.nan) if rotation is None else 60.0 * rotation.rev_per_s(t_frames),
                    {"units": "rpm", "long_name": "disc speed"}),
        },
        coords={"time": ("time", t_frames, {"units": "s", "long_name": "frame centre"})},
    )
    revs = np.flatnonzero(np.isfinite(acc.rev_max[0]))
    revolutions = xr.Dataset(
        {f"{k}_p2p": ("revolution", acc.rev_max[j, revs] - acc.rev_min[j, revs], {"units": "m"})
         for j, k in enumerate(("sro", "macro", "micro"))},
        coords={"revolution": ("revolution", revs.astype(np.int64))},
    )
    angle = (np.arange(nb) + 0.5) * 2 * math.pi / nb
    with np.errstate(divide="ignore", invalid="ignore"):
        polar = xr.Dataset(
            {
                "angle_sro": ("angle", acc.ang_q / acc.ang_cnt, {"units": "m", "long_name": "mean SRO at angle"}),
                "angle_macro": ("angle", acc.ang_macro / acc.ang_cnt, {"units": "m"}),
                "angle_level_db": ("angle", 10 * np.log10(acc.ang_e / acc.ang_ecnt / P_REF**2),
                                   {"units": "dB", "long_name": "mean squeal-band level at angle"}),
            },
            coords={"angle": ("angle", angle, {"units": "rad", "long_name": "disc angle from recording start"})},
        )
    n_loud = max(1, int((level >= s.threshold_dba).sum()))
    spectrum = xr.Dataset(
        {"mic_power_squeal": ("freq", acc.mic_spec_sum / n_loud, {"units": "Pa^2",
                                                                   "long_name": "mean during squeal"})},
        coords={"freq": ("freq", plan.freq, {"units": "Hz"})},
    )
    out_attrs = {"source": str(attrs.get("source", src.path)), "synthetic": bool(attrs.get("synthetic", False)),
                 "max_tan_theta": acc.max_tan if rotation is not None else math.nan,
                 "surface_speed": surface_speed(s.rpm, s.radius) if rotation is not None else math.nan,
                 "min_tnr_db": s.min_tnr_db,
                 # the level's band filter: full level up to the band's edges, zero EDGE_HZ outside them
                 "band_rolloff_hz": EDGE_HZ}
    return MeasurementResult(
        squeal_frequency_hz=squeal_f, harmonics=tuple(harmonics), events=tuple(events), rising_fraction=rising,
        growth_slope_correlation=corr, peak_dba=peak, runout_phase_deg=phase, duration_s=plan.total / fs, fs=fs,
        settings=s, frames=frames, revolutions=revolutions, polar=polar, spectrum=spectrum, attrs=out_attrs,
        runout_unavailable=unavailable,
    )
