"""What a recording says about squeal and run-out: the labelled result of
:func:`~squealkit.measurement.analyze_recording`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from ... import __version__
from ..._validation import InputError
from ..squeal.events import SquealEvent
from .settings import AnalysisSettings


@dataclass(frozen=True)
class MeasurementResult:
    """What a recording says about squeal and run-out.

    Attributes
    ----------
    squeal_frequency_hz : float or None
        Dominant squeal frequency [Hz]; None without squeal. The strongest A-weighted line of
        the squeal spectrum, refined from its phase advance between successive frames
        (:func:`~squealkit.measurement.signal.spectral.phase_advance_freq`): to a few mHz on synthetic
        bursts, where the bin interpolation was off by up to 6 Hz (bins of 78 Hz).
    harmonics : tuple of dict
        ``order``, ``frequency_hz``, ``level_db`` of the harmonics 2-5 of the squeal that are
        there: a peak within a bin of ``h f0`` standing 10 dB above the spectrum around it
        (frequencies refined the same way); an absent harmonic is not listed.
    events : tuple of SquealEvent
        Their ``frequency_hz`` is the mean of the components' phase-advance frequencies, weighted
        by the cross power of each frame pair.
    rising_fraction : float or None
        Share of the sound energy (above the band's lower edge) during events that falls on
        rising run-out (``tan(theta) > 0``); 0.5 means no preference. None without squeal.
    growth_slope_correlation : float or None
        Pearson correlation of the squeal envelope's growth rate with the SRO slope.
    runout_phase_deg : float or None
        Where on the disc the squeal sounds, relative to the run-out: the circular mean disc
        angle of the squeal-band energy minus the angle of the macro run-out's maximum
        [deg, -180 to 180]; negative: before the crest, on the rising run-out. None without squeal.
    peak_dba : float
        The application's peak level (SAE J2521): the highest time-weighted (Fast unless the
        criteria say Slow), A-weighted level in the criteria band [dB(A)], whether or not it
        reached the threshold. Independent of the analysis frames.
    duration_s : float
        Length of the recording [s].
    fs : float
        Its sample rate [Hz].
    settings : AnalysisSettings
        The settings the analysis ran with.
    frames, revolutions, polar, spectrum : xarray.Dataset
        Per-frame level, ridge and slope; per-revolution run-out peak-to-peak; squeal level
        and run-out against disc angle; mean spectra.
    attrs : dict
        ``source`` (the file), ``synthetic``, ``max_tan_theta`` (largest run-out slope [1]) and
        ``surface_speed`` [m/s].
    runout_unavailable : str or None
        Why the run-out link could not be computed (no disc speed, a tacho that gives none),
        when the analysis was asked for the squeal alone in that case (``require_runout=False``);
        then the run-out results are None or NaN. None when it was computed.
    signals : xarray.Dataset or None
        What the figures draw (spectrograms, the run-out split, the band-passed displacement;
        :func:`~squealkit.measurement.analysis.views.measurement_signals`), when the analysis was
        asked for them (``keep_signals=True``); None otherwise.
    """

    squeal_frequency_hz: float | None
    harmonics: tuple[dict[str, float], ...]
    events: tuple[SquealEvent, ...]
    rising_fraction: float | None
    growth_slope_correlation: float | None
    peak_dba: float
    runout_phase_deg: float | None
    duration_s: float
    fs: float
    settings: AnalysisSettings
    frames: xr.Dataset = field(repr=False)
    revolutions: xr.Dataset = field(repr=False)
    polar: xr.Dataset = field(repr=False)
    spectrum: xr.Dataset = field(repr=False)
    attrs: dict[str, Any] = field(default_factory=dict, repr=False)
    runout_unavailable: str | None = None
    signals: xr.Dataset | None = field(default=None, repr=False)

    @property
    def squeal(self) -> bool:
        """Whether any event met the criteria."""
        return bool(self.events)

    def plot(self, ax: Any = None, *, kind: str = "level", **kwargs: Any) -> Any:
        """Draw the result with :mod:`squealkit.plotting.measurement` (imported now, not before).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw (polar axes for ``kind="polar"``); a new figure if omitted. The kinds
            that draw ``signals`` make their own figure.
        kind : {"level", "polar", "event_phase", "time", "spectrogram", "runout", "band"}, default "level"
            :func:`~squealkit.plotting.measurement.level_plot` (level against time with the
            threshold and the events), :func:`~squealkit.plotting.measurement.polar_plot`
            (level and run-out against disc angle),
            :func:`~squealkit.plotting.measurement.event_phase_plot`; or, from ``signals``
            (``keep_signals=True``), the paper's Figs. 6-7, 8-9, 12 and 13.
        **kwargs
            Passed on to the plotting function (e.g. ``t_range`` for the signals' figures).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ...plotting import measurement as plots

        funcs = {"level": plots.level_plot, "polar": plots.polar_plot, "event_phase": plots.event_phase_plot}
        drawn = {"time": plots.time_history_plot, "runout": plots.runout_plot, "band": plots.band_vs_pressure_plot}
        if kind in funcs:
            return funcs[kind](self, ax=ax, **kwargs)
        if kind not in (*drawn, "spectrogram"):
            kinds = ", ".join(map(repr, (*funcs, *drawn, "spectrogram")))
            raise InputError(f"Parameter kind={kind!r} must be one of {kinds}.")
        if self.signals is None:
            raise InputError(f"kind={kind!r} draws the result's signals: analyze with keep_signals=True.")
        if kind == "spectrogram":
            return plots.spectrogram_plot(self.signals, self, **kwargs)
        return drawn[kind](self.signals, **kwargs)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (stable keys; see the CLI's ``--json``)."""
        rev = self.revolutions
        return {
            "source": self.attrs.get("source"),
            "synthetic": bool(self.attrs.get("synthetic", False)),
            "duration_s": self.duration_s,
            "fs": self.fs,
            "squeal": self.squeal,
            "squeal_frequency_hz": self.squeal_frequency_hz,
            "harmonics": list(self.harmonics),
            "peak_dba": self.peak_dba,
            "n_events": len(self.events),
            "events": [e.to_dict() for e in self.events],
            "growth_slope_correlation": self.growth_slope_correlation,
            "rising_fraction": self.rising_fraction,
            "runout_phase_deg": self.runout_phase_deg,
            "runout_unavailable": self.runout_unavailable,
            "runout": {
                "n_revolutions": int(rev.sizes["revolution"]),
                "sro_p2p_m": float(rev["sro_p2p"].median()) if rev.sizes["revolution"] else None,
                "macro_p2p_m": float(rev["macro_p2p"].median()) if rev.sizes["revolution"] else None,
                "micro_p2p_m": float(rev["micro_p2p"].median()) if rev.sizes["revolution"] else None,
                "max_tan_theta": float(self.attrs.get("max_tan_theta", float("nan"))),
            },
            "criteria": self.settings.criteria.to_dict(),
            "settings": {
                "rpm": self.settings.rpm, "radius_m": self.settings.radius, "band_hz": list(self.settings.band),
                "threshold_dba": self.settings.threshold_dba, "min_duration_s": self.settings.min_duration,
                "min_tnr_db": self.settings.min_tnr_db,
            },
        }

    def to_dataset(self) -> xr.Dataset:
        """All labelled results in one Dataset (saves to netCDF with :func:`squealkit.io.save_dataset`)."""
        ds = xr.merge([self.frames, self.revolutions, self.polar, self.spectrum], combine_attrs="override")
        ev = self.events
        ds = ds.assign(
            event_start=("event", np.array([e.start_s for e in ev]), {"units": "s"}),
            event_end=("event", np.array([e.end_s for e in ev]), {"units": "s"}),
            event_frequency=("event", np.array([e.frequency_hz for e in ev]), {"units": "Hz"}),
            event_peak=("event", np.array([e.peak_dba for e in ev]), {"units": "dB(A)"}),
            event_runout_phase=("event", np.array([np.nan if e.runout_phase_deg is None else e.runout_phase_deg
                                                   for e in ev]), {"units": "deg"}),
        )
        ds.attrs = {k: int(v) if isinstance(v, bool) else v for k, v in self.to_dict().items()
                    if isinstance(v, int | float | str)}
        ds.attrs.update(squealkit_version=__version__, synthetic=int(bool(self.attrs.get("synthetic", False))),
                        criteria=self.settings.criteria.describe())
        return ds
