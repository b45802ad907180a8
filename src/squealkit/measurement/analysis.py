"""End-to-end analysis of a rig recording: squeal, its frequency and level, and the run-out.

:func:`analyze_recording` answers the rig user's questions (paper §5.2): is there squeal,
at what frequency and level, when, and does it grow on the rising run-out? It reads the
recording in blocks (bounded memory for hour-long files), filters each block with a margin
so the zero-phase filters see no artificial edge, and keeps only compact per-frame,
per-revolution and per-angle features.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from numba import njit
from numpy.typing import NDArray
from scipy import fft as sp_fft
from scipy import signal

from .. import __version__
from .._threads import thread_limit
from .._validation import PLAUSIBLE, InputError, validate_fs, validate_plausible, validate_positive
from .formats import DEFAULT_BLOCK, RecordingSource, open_recording
from .formats._common import _to_si
from .signal.filters import lowpass, lowpass_decimated
from .signal.spectral import P_REF, a_weighting_db, phase_advance_freq, refine_peak
from .signal.tacho import ConstantSpeed, read_tacho
from .squeal.criteria import EDGE_HZ, SquealCriteria, band_weighted_signal, exponential_average, squeal_criteria
from .squeal.events import DEFAULT_MIN_TNR_DB, SquealEvent, link_components, tonal_components, tone_to_noise_ratio
from .squeal.runout import revolution_frequency, surface_speed

__all__ = ["AnalysisSettings", "MeasurementResult", "analyze_recording"]

#: Bins either side of a line's peak bin summed in the phase-advance estimate: the Hann main
#: lobe's core, which holds nearly all of a tone's energy (see phase_advance_freq).
_LOBE = 2
#: How far [Hz] outside a band edge a component's refined frequency may lie and still count as
#: in the band: the phase-advance refinement's accuracy on a steady tone (a few mHz).
_EDGE_TOL_HZ = 0.01
#: A harmonic is reported only where the loud frames' summed spectrum has a peak within a bin of
#: h f0 whose bin stands this many dB above the median of the _HARMONIC_FLANK bins either side of
#: its main lobe (a Hann line in noise: its bin holds half its power).
_HARMONIC_SNR_DB = 10.0
_HARMONIC_FLANK = 8


@dataclass(frozen=True)
class AnalysisSettings:
    """Criteria and processing settings of :func:`analyze_recording` (all SI / Hz / s).

    Attributes
    ----------
    rpm : float
        Disc speed [rev/min] (without a tacho: constant).
    radius : float
        Probe (and pin) radius on the disc [m].
    criteria : SquealCriteria, default ``squeal_criteria()``
        What counts as squeal (band, threshold, time weighting, minimum duration).
    lowpass_freq : float, default 1000.0
        Corner [Hz] of the low-pass that keeps the surface run-out (paper Fig. 12).
    macro_orders : int, default 10
        Highest revolution order counted as macro run-out (see :func:`split_runout`).
    nperseg, hop : int, default 512, 256
        Frame length and hop [samples] of the spectral frames (Hann window).
    freq_tol : float, default 100.0
        Frequency tolerance [Hz] of one tonal line: the width of a component and how far it
        may move between frames and still join the same event.
    n_angle_bins : int, default 72
        Bins of disc angle of the polar result (72: 5 deg).
    chunk_s : float, default 10.0
        Length [s] of the blocks the recording is processed in (bounds memory).
    probe_offset_deg : float, default 0.0
        How far upstream of the pin the probe sits [deg], in (-360, 360).
    acoustic_delay : float, default 0.0
        Delay [s] from the pin to the microphone, >= 0.
    polarity : {1, -1}, default 1
        -1 when the probe reads the run-out reversed.
    tacho_kind : {"pulses", "angle"}, default "pulses"
        What a tacho channel holds (see :func:`squealkit.measurement.signal.tacho.read_tacho`).
    pulses_per_rev : int, default 1
        Tacho pulses per revolution.
    tacho_level : float or None, default None
        Trigger level of the pulses (default: halfway between the first block's extremes).
    angle_unit : {"deg", "rad", "rev"}, default "deg"
        Unit of an angle tacho channel.
    min_tnr_db : float or None, default 8.0
        The tonality a component needs to count as squeal: its tone-to-noise ratio [dB] over
        the masking noise in its critical band
        (:func:`~squealkit.measurement.squeal.events.tone_to_noise_ratio`; 8 dB is the ECMA-418-1
        criterion for a prominent tone at or above 1 kHz). None: every peak above the
        threshold counts (then loud broadband noise reads as squeal).
    """

    rpm: float
    radius: float
    criteria: SquealCriteria = field(default_factory=squeal_criteria)
    lowpass_freq: float = 1000.0
    macro_orders: int = 10
    nperseg: int = 512
    hop: int = 256
    freq_tol: float = 100.0
    n_angle_bins: int = 72
    chunk_s: float = 10.0
    probe_offset_deg: float = 0.0
    acoustic_delay: float = 0.0
    polarity: int = 1
    tacho_kind: str = "pulses"
    pulses_per_rev: int = 1
    tacho_level: float | None = None
    angle_unit: str = "deg"
    min_tnr_db: float | None = DEFAULT_MIN_TNR_DB

    @property
    def band(self) -> tuple[float, float]:
        """Squeal band [Hz] of the criteria."""
        return self.criteria.band

    @property
    def threshold_dba(self) -> float:
        """Squeal threshold [dB(A)] of the criteria."""
        return self.criteria.threshold_dba

    @property
    def min_duration(self) -> float:
        """Shortest tonal event [s] of the criteria."""
        return self.criteria.min_duration

    def validated(self, fs: float | None = None) -> AnalysisSettings:
        """These settings, checked against each other and the sample rate.

        Parameters
        ----------
        fs : float, optional
            Sample rate [Hz] of the recording (the band must lie below ``fs / 2``); None
            checks what does not depend on the recording (e.g. a campaign's options up front).

        Returns
        -------
        AnalysisSettings
            ``self``, unchanged.

        Raises
        ------
        InputError
            If a setting is out of range.
        """
        # None or NaN: no disc speed here (a campaign's comes from each application or its tacho;
        # require_runout=False leaves the run-out link out)
        if self.rpm is not None and not math.isnan(self.rpm):
            validate_plausible("rpm", self.rpm)
        validate_positive("radius", self.radius)
        validate_positive("chunk_s", self.chunk_s)
        validate_plausible("acoustic_delay", self.acoustic_delay)
        if self.tacho_kind not in ("pulses", "angle"):
            raise InputError(f"Parameter tacho_kind={self.tacho_kind!r} must be 'pulses' or 'angle'.")
        if isinstance(self.pulses_per_rev, bool) or not isinstance(self.pulses_per_rev, int | np.integer) \
                or self.pulses_per_rev < 1:
            raise InputError(f"Parameter pulses_per_rev={self.pulses_per_rev!r} must be a whole number >= 1.")
        if self.polarity not in (1, -1):
            raise InputError(f"Parameter polarity={self.polarity!r} must be 1 or -1 (probe reading reversed).")
        if not math.isfinite(self.probe_offset_deg) or abs(self.probe_offset_deg) >= 360:
            raise InputError(f"Parameter probe_offset_deg={self.probe_offset_deg!r} must lie in (-360, 360).")
        if fs is not None and self.band[1] >= fs / 2:
            raise InputError(f"Parameter band={self.band!r}: upper edge must lie below fs/2 = {fs / 2:g} Hz.")
        if not (isinstance(self.nperseg, int) and self.nperseg >= 16):
            raise InputError(f"Parameter nperseg={self.nperseg!r} must be a whole number >= 16.")
        if self.min_tnr_db is not None and not (isinstance(self.min_tnr_db, int | float)
                                                 and math.isfinite(self.min_tnr_db)):
            raise InputError(f"Parameter min_tnr_db={self.min_tnr_db!r} must be a finite number [dB] or None.")
        if not (isinstance(self.hop, int) and 1 <= self.hop <= self.nperseg):
            raise InputError(f"Parameter hop={self.hop!r} must be a whole number in [1, nperseg].")
        return self


def _check_pressure(channel: str, p: NDArray) -> None:
    """One line for a microphone channel whose samples no sound in air has (e.g. 1e299 Pa: a
    unit or scaling mistake), before they overflow the single-precision level computation."""
    hi = PLAUSIBLE["pressure_pa"][1]
    big = float(np.max(np.abs(p), initial=0.0))
    if big > hi:
        raise InputError(f"Microphone channel {channel!r} holds a sound pressure of {big:.3g} Pa, outside the "
                         f"accepted range [-{hi:g}, {hi:g}] Pa ({PLAUSIBLE['pressure_pa'][3]}): check the channel's "
                         "unit or scale.")


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

    @property
    def squeal(self) -> bool:
        """Whether any event met the criteria."""
        return bool(self.events)

    def plot(self, ax: Any = None, *, kind: str = "level", **kwargs: Any) -> Any:
        """Draw the result with :mod:`squealkit.plotting.measurement` (imported now, not before).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Where to draw (polar axes for ``kind="polar"``); a new figure if omitted.
        kind : {"level", "polar"}, default "level"
            :func:`~squealkit.plotting.measurement.level_plot` (level against time with the
            threshold and the events) or :func:`~squealkit.plotting.measurement.polar_plot`
            (level and run-out against disc angle).
        **kwargs
            Passed on to the plotting function.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ..plotting import measurement as plots

        funcs = {"level": plots.level_plot, "polar": plots.polar_plot}
        if kind not in funcs:
            raise InputError(f"Parameter kind={kind!r} must be 'level' or 'polar'.")
        return funcs[kind](self, ax=ax, **kwargs)

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


def _refine_rows(power: NDArray[np.float64], k: NDArray[np.intp]) -> NDArray[np.float64]:
    """Refined bin of the peak at ``k`` in each row of a power spectrum (Hann two-bin ratio)."""
    kk = np.clip(k, 1, power.shape[1] - 2)
    mag3 = np.sqrt(np.take_along_axis(power, kk[:, None] + np.array([-1, 0, 1]), axis=1))
    return np.atleast_1d(refine_peak(mag3, np.ones(kk.size, np.intp))) - 1 + kk


@njit(cache=True)
def _ewma_rows(p, a, state, out):  # pragma: no cover - compiled
    """``y_m = a y_(m-1) + (1 - a) p_m`` row after row, ``state`` (float64) holding the last row: the
    same operations per column as a loop down each column, in memory order (six times faster)."""
    b = 1.0 - a
    for m in range(p.shape[0]):
        for j in range(p.shape[1]):
            y = a * state[j] + b * p[m, j]
            out[m, j] = y
            state[j] = y


@njit(cache=True)
def _mean_squares_kernel(x, dec, out):  # pragma: no cover - compiled
    for i in range(out.shape[0]):
        acc = 0.0
        for j in range(i * dec, (i + 1) * dec):
            acc += np.float64(x[j] * x[j])
        out[i] = acc / dec


def _mean_squares(x: NDArray[np.float32], dec: int) -> NDArray[np.float64]:
    """Mean square of each run of ``dec`` samples (``x.size // dec`` of them), squared in single precision
    and summed in double: ``np.square(x).reshape(-1, dec).mean(axis=1, dtype=np.float64)``.

    A compiled loop, four times faster than NumPy's reduction over short rows.
    """
    out = np.empty(x.size // dec)
    _mean_squares_kernel(x, dec, out)
    return out


@njit(cache=True, nogil=True)
def _running_sums_kernel(ms, tan_t, out):  # pragma: no cover - compiled
    e = r = t = 0.0
    for i in range(ms.shape[0]):
        e += ms[i]
        r += ms[i] if tan_t[i] > 0 else 0.0
        t += tan_t[i]
        out[0, i + 1] = e
        out[1, i + 1] = r
        out[2, i + 1] = t


def _running_sums(ms: NDArray[np.float64], tan_t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative sums from 0 (``size + 1`` each) of the band mean square, of its part on rising
    run-out (``tan_t > 0``) and of the incline: ``np.cumsum`` of ``ms``, ``np.where(tan_t > 0, ms, 0)``
    and ``tan_t`` after a 0, in one compiled pass (six times faster than the three and the where).
    """
    out = np.zeros((3, ms.size + 1))
    _running_sums_kernel(ms, tan_t, out)
    return out


@njit(cache=True, nogil=True)
def _angle_sums_kernel(turns, sro, macro, nb, out):  # pragma: no cover - compiled
    for i in range(turns.shape[0]):
        u = turns[i]
        b = np.int64((u - np.floor(u)) * nb) % nb
        out[0, b] += sro[i]
        out[1, b] += macro[i]
        out[2, b] += 1.0


def _angle_sums(turns: NDArray[np.float64], sro: NDArray[np.float64], macro: NDArray[np.float64],
                nb: int) -> NDArray[np.float64]:
    """SRO, macro run-out and sample count [m, m, 1] summed per disc angle bin, shape ``(3, nb)``:
    bin ``int((turns % 1) nb)`` of each sample at ``turns`` [rev], summed in sample order as
    ``np.bincount`` sums, in one compiled pass (half the time of the three bincounts).
    """
    out = np.zeros((3, nb))
    _angle_sums_kernel(turns, sro, macro, nb, out)
    return out


@njit(cache=True, nogil=True)
def _bin_powers_kernel(spec, scale, w_a, pb, pa):  # pragma: no cover - compiled
    for m in range(spec.shape[0]):
        for k in range(spec.shape[1]):
            re, im = spec[m, k].real, spec[m, k].imag
            x = re * re
            x += im * im
            x *= scale
            pb[m, k] = x
            pa[m, k] = x * w_a[k]


def _bin_powers(spec: NDArray[np.complex64], scale: np.float32, w_a: NDArray[np.float32]
                ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Power per bin ``pb = (re**2 + im**2) scale`` [Pa^2] of frame spectra and its A-weighted
    ``pa = pb w_a``, in single precision as NumPy computes them, in one compiled pass over the
    (strided) spectra: four times faster than the five array operations.
    """
    pb = np.empty(spec.shape, np.float32)
    pa = np.empty(spec.shape, np.float32)
    _bin_powers_kernel(spec, scale, w_a, pb, pa)
    return pb, pa


def _time_weight_rows(p: NDArray, a: float, state: NDArray[np.float64]) -> tuple[NDArray, NDArray[np.float64]]:
    """Exponential average over rows (frames): ``y_m = a y_(m-1) + (1 - a) p_m``; returns y and its last row.

    A compiled loop: ``scipy.signal.lfilter`` along the frame axis took 9 % of the analysis.
    """
    out = np.empty_like(p)
    st = np.array(state, dtype=np.float64)
    _ewma_rows(p, a, st, out)
    return out, st


class _DatasetSource:
    """Block iteration over an in-memory Dataset (same interface as RecordingSource)."""

    def __init__(self, ds: xr.Dataset, fs: float | None):
        self.ds = ds
        if fs is None:
            if "fs" in ds.attrs:
                fs = ds.attrs["fs"]
            elif "time" in ds.coords and ds.sizes["time"] > 1:
                # least-squares slope of the whole time coordinate: rounded times leave it unbiased
                t = np.asarray(ds["time"].values, dtype=np.float64)
                k = np.arange(t.size, dtype=np.float64) - (t.size - 1) / 2.0
                fs = float(np.dot(k, k) / np.dot(k, t - t.mean())) if t.size > 2 else 1.0 / float(t[1] - t[0])
            else:
                raise InputError("The recording has no 'fs' attribute or time coordinate; give fs.")
        self.fs = validate_fs(fs)
        self.channels = tuple(str(n) for n in ds.data_vars if ds[n].ndim == 1)
        self.n_samples = int(ds.sizes[ds[self.channels[0]].dims[0]]) if self.channels else 0
        self.path = Path(str(ds.attrs.get("source", "<dataset>")))
        self.units, self._factors, _ = _to_si(self.path, {n: str(ds[n].attrs.get("units", ""))
                                                          for n in self.channels}, {})
        self.fmt = "dataset"

    resolve = RecordingSource.resolve

    def iter_blocks(self, channels, *, block=DEFAULT_BLOCK):
        names = [self.resolve(c) for c in channels]
        for start in range(0, self.n_samples, block):
            out = {}
            for n in names:
                v = np.asarray(self.ds[n].values[start:start + block], dtype=np.float64)
                if n in self._factors:  # a channel in um, mm, mPa...: in SI as every reader gives it
                    v = v * self._factors[n]
                if not np.all(np.isfinite(v)):
                    i = int(np.argmax(~np.isfinite(v)))
                    raise InputError(f"Channel {n!r} has a non-finite sample ({v[i]!r}) at sample {start + i}.")
                out[n] = v
            yield start, out


def _windows(
    src, names, core: int, margin: int, block: int
) -> Iterator[tuple[int, int, int, dict[str, NDArray]]]:
    """Yield ``(core_start, core_stop, window_start, {name: samples})`` with margins both sides.

    Each window is a view of one block where it fits in one, else one copy of its samples.
    """
    total = src.n_samples
    pieces: list[tuple[int, dict[str, NDArray]]] = []  # blocks still needed, in order
    buf_end = 0
    next_core = 0
    for start, blk in src.iter_blocks(names, block=block):
        pieces.append((start, blk))
        buf_end = start + len(blk[names[0]])
        while next_core < total and buf_end >= min(total, next_core + core + margin):
            w0 = max(0, next_core - margin)
            w1 = min(buf_end, next_core + core + margin)
            c1 = min(total, next_core + core)
            parts = [(s0, b) for s0, b in pieces if s0 < w1 and s0 + len(b[names[0]]) > w0]
            if len(parts) == 1:
                s0, b = parts[0]
                window = {n: b[n][w0 - s0:w1 - s0] for n in names}
            else:
                window = {n: np.concatenate([b[n][max(0, w0 - s0):w1 - s0] for s0, b in parts]) for n in names}
            yield next_core, c1, w0, window
            next_core = c1
            keep = max(0, next_core - margin)
            pieces = [(s0, b) for s0, b in pieces if s0 + len(b[names[0]]) > keep]
    if next_core < total:
        raise InputError(f"Recording ended after {buf_end} of {total} samples.")


# -- The analysis in steps ------------------------------------------------------------------------
# analyze_recording reads the recording, fixes the framing (_plan), then streams it in windows
# (a core plus margins both sides). Each window goes through the filter step (the A-weighted band
# level, _band_level; the run-out, _runout_signals), the spectral step (_frame_spectra) and the
# tonal components (_frame_components), and leaves compact per-frame, per-revolution and per-angle
# features in the accumulators (_Accumulators). At the end the components become events
# (_squeal_events), the squeal's lines and statistics are read from them (_squeal_lines,
# _runout_statistics), each event is placed on the disc (_runout_link), and the labelled result is
# assembled (_assemble).


def _open_source(recording: Any, fs: float | None) -> tuple[Any, dict[str, Any]]:
    """The block source of a recording and its attributes (source name, synthetic or not).

    Parameters
    ----------
    recording : path, xarray.Dataset or RecordingSource
        As for :func:`analyze_recording`; anything with ``iter_blocks`` (e.g. a synthetic
        source) is used as it is.
    fs : float or None
        Sample rate [Hz] where the recording does not carry one.

    Returns
    -------
    src : RecordingSource-like
        Has ``fs``, ``n_samples``, ``path``, ``resolve`` and ``iter_blocks``.
    attrs : dict
        ``source`` and ``synthetic`` (all of a Dataset's attributes).
    """
    if isinstance(recording, xr.Dataset):
        return _DatasetSource(recording, fs), dict(recording.attrs)
    if isinstance(recording, RecordingSource):
        return recording, {"source": str(recording.path), "synthetic": recording.synthetic}
    if hasattr(recording, "iter_blocks"):  # e.g. a SyntheticSource
        return recording, {"source": str(recording.path), "synthetic": recording.fmt == "synthetic"}
    src = open_recording(recording, fs=fs)
    return src, {"source": str(src.path), "synthetic": src.synthetic}


def _disc_rotation(src: Any, tacho: str | int | None, rpm: float | None, options: dict[str, Any], *,
                   required: bool = True) -> tuple[Any, float, str | None]:
    """The disc's position against time, from the tacho channel or the constant speed.

    Parameters
    ----------
    src : RecordingSource-like
        The recording (the tacho channel is read from it block by block).
    tacho : str, int or None
        Tacho channel, or None for a constant speed.
    rpm : float or None
        Constant disc speed [rpm] (used without a tacho).
    options : dict
        The analysis options; ``tacho_kind``, ``pulses_per_rev``, ``tacho_level`` and
        ``angle_unit`` apply to the tacho.
    required : bool
        Raise where the rotation cannot be had (no speed given, a tacho that cannot give one);
        otherwise return None and the reason.

    Returns
    -------
    rotation : DiscAngle, ConstantSpeed or None
        Has ``turns(t)``, ``rev_per_s(t)`` and ``time_at(turns)``.
    rpm : float
        The speed [rpm] (with a tacho: the mean speed over the recording); NaN without rotation.
    unavailable : str or None
        Why there is no rotation (then the run-out link cannot be computed).
    """
    fs = float(src.fs)
    if tacho is not None:
        tk = {k: options[k] for k in ("tacho_kind", "pulses_per_rev", "tacho_level", "angle_unit") if k in options}
        try:
            rotation = read_tacho(src, tacho, kind=tk.get("tacho_kind", "pulses"),
                                  pulses_per_rev=tk.get("pulses_per_rev", 1), level=tk.get("tacho_level"),
                                  angle_unit=tk.get("angle_unit", "deg"))
        except InputError as e:
            if required:
                raise
            return None, math.nan, f"no disc speed from the tacho channel {tacho!r}: {e}"
        span = src.n_samples / fs
        return rotation, 60.0 * float(rotation.turns(span) - rotation.turns(0.0)) / span, None  # mean speed
    if rpm is None:
        if required:
            raise InputError("Give the disc speed rpm, or a tacho channel.")
        return None, math.nan, "no disc speed: neither an rpm nor a tacho channel was given"
    return ConstantSpeed(validate_positive("rpm", rpm)), rpm, None


@dataclass(frozen=True)
class _Plan:
    """The framing of one recording's analysis: frames, band bins, run-out grid and windows.

    Frame ``m`` covers samples ``[m hop, m hop + n)``; its "interval" (for energy sums and the
    level) is ``[m hop + half, m hop + half + hop)``. Bins ``[lo, hi)`` of the frames are analysed:
    those of the band (``band_bins`` of them, relative to ``lo``) and a guard of a component's
    width either side, so a tone at a band edge is a peak with both its flanks (whether it lies
    in the band is decided by its refined frequency). The run-out is analysed on every ``dec``-th
    sample (``fs_d = fs / dec``). Windows have a core of ``core`` samples and ``margin`` samples
    either side.
    """

    fs: float
    total: int
    n: int
    hop: int
    n_frames: int
    half: int
    freq: NDArray[np.float64]
    lo: int
    hi: int
    band_bins: slice
    w_a: NDArray[np.float64]
    w_a32: NDArray[np.float32]
    win32: NDArray[np.float32]
    pscale: float
    thr_power: float
    half_width: int
    n_threads: int
    core: int
    margin: int
    dec: int
    fs_d: float
    f_rev: float
    f_macro: float
    off_turns: float
    a_frames: float
    rev0: int
    n_rev: int
    nb: int


def _plan(s: AnalysisSettings, fs: float, total: int, rotation: Any) -> _Plan:
    """Fix the framing of the analysis of ``total`` samples at ``fs`` (and check it is possible).

    Parameters
    ----------
    s : AnalysisSettings
        Validated settings.
    fs : float
        Sample rate [Hz].
    total : int
        Samples in the recording.
    rotation : DiscAngle, ConstantSpeed or None
        The disc's rotation (its slowest speed sets how far back the margins reach); None:
        the squeal alone, no run-out.

    Returns
    -------
    _Plan
    """
    if total < s.nperseg:
        raise InputError(f"Recording has {total} samples, fewer than one analysis frame ({s.nperseg}).")
    f_rev = math.nan if rotation is None else revolution_frequency(s.rpm)
    n, hop = s.nperseg, s.hop
    freq = np.fft.rfftfreq(n, 1 / fs)
    blo, bhi = int(np.searchsorted(freq, s.band[0])), int(np.searchsorted(freq, s.band[1], side="right"))
    if bhi - blo < 5:
        raise InputError(f"Band {s.band} Hz holds fewer than 5 bins of {fs / n:g} Hz; widen it or raise nperseg.")
    half_width = max(2, int(0.5 * s.freq_tol * n / fs))  # bins of a tonal component either side
    lo, hi = max(1, blo - half_width - 1), min(freq.size, bhi + half_width + 1)
    w_a = 10 ** (a_weighting_db(freq[lo:hi]) / 10)
    win = signal.windows.hann(n, sym=False)
    # run-out is analysed at fs / dec, dec a divisor of hop with fs / dec >= 4 lowpass_freq
    dec = max(d for d in range(1, hop + 1) if hop % d == 0 and fs / d >= 4 * s.lowpass_freq)
    if rotation is None:  # the squeal alone: no revolutions, margins for the frames only
        lag, f_macro, rev0, n_rev, macro_margin = s.acoustic_delay, math.nan, 0, 0, 0
    else:
        # the slowest speed decides how far the probe's view of the pin's surface lies back in time
        t_span = np.linspace(0.0, total / fs, 257)
        f_min = max(float(np.min(rotation.rev_per_s(t_span))), 1e-3 * f_rev)
        lag = s.acoustic_delay + abs(s.probe_offset_deg) / 360.0 / f_min
        f_macro = (s.macro_orders + 0.5) * f_rev
        if f_macro >= s.lowpass_freq:
            raise InputError(f"macro_orders={s.macro_orders} at {s.rpm:g} rpm puts the macro corner "
                             f"({f_macro:g} Hz) above lowpass_freq={s.lowpass_freq:g} Hz.")
        rev0 = math.floor(float(rotation.turns(0.0)))  # revolutions count from the first mark (or t = 0)
        n_rev = math.floor(float(rotation.turns((total - 1) / fs))) - rev0 + 1
        macro_margin = int(4 * fs / ((s.macro_orders + 0.5) * f_rev))
    return _Plan(
        fs=fs, total=total, n=n, hop=hop, n_frames=(total - n) // hop + 1, half=(n - hop) // 2, freq=freq,
        lo=lo, hi=hi, band_bins=slice(blo - lo, bhi - lo), w_a=w_a, w_a32=w_a.astype(np.float32),
        win32=win.astype(np.float32),
        pscale=2.0 / (n * float(np.sum(win**2))), thr_power=P_REF**2 * 10 ** (s.threshold_dba / 10),
        half_width=half_width,
        n_threads=thread_limit(),  # FFT threads: this process's share (one on a one-thread Dask worker)
        core=max(hop, round(s.chunk_s * fs / hop) * hop),
        margin=max(n, int(0.25 * fs), int(2.5 / EDGE_HZ * fs),  # the band filter rings 2 / EDGE_HZ
                   macro_margin, int(lag * fs) + n),
        dec=dec, fs_d=fs / dec, f_rev=f_rev, f_macro=f_macro, off_turns=s.probe_offset_deg / 360.0,
        a_frames=math.exp(-hop / fs / s.criteria.time_constant_s), rev0=rev0, n_rev=n_rev, nb=s.n_angle_bins,
    )


@dataclass
class _Accumulators:
    """What the windows leave behind: per-frame features, tonal components, per-revolution and
    per-angle sums, and the time-weighting states carried from one window to the next."""

    level: NDArray[np.float64]  # Fast (time-weighted) band mean square: max over each frame's interval
    rise_s: NDArray[np.float64]  # when the Fast level first reaches the threshold in each frame's interval [s]
    fall_s: NDArray[np.float64]  # when it last is at or above it there (end of that grid step) [s]
    leq: NDArray[np.float64]  # the frame's own A-weighted band level [dB(A)] (Hann window)
    ridge_f: NDArray[np.float64]
    e_tot: NDArray[np.float64]
    e_rise: NDArray[np.float64]
    slope_f: NDArray[np.float64]
    frame_turns: NDArray[np.float64]  # disc position under the pin when each frame pair's sound left it
    spec_state: NDArray[np.float64]  # time-weighted A-weighted power spectrum (band bins)
    mic_spec_sum: NDArray[np.float64]  # summed over loud frames, band bins only
    mic_cross_sum: NDArray[np.complex128]  # X_m conj(X_m-1) summed likewise
    rev_max: NDArray[np.float64]  # sro, macro, micro per revolution
    rev_min: NDArray[np.float64]
    ang_q: NDArray[np.float64]
    ang_macro: NDArray[np.float64]
    ang_cnt: NDArray[np.float64]
    ang_e: NDArray[np.float64]
    ang_ecnt: NDArray[np.float64]
    comp_frame: list[NDArray] = field(default_factory=lambda: [np.empty(0, np.intp)])
    comp_freq: list[NDArray] = field(default_factory=lambda: [np.empty(0)])
    comp_level: list[NDArray] = field(default_factory=lambda: [np.empty(0)])
    comp_pow: list[NDArray] = field(default_factory=lambda: [np.empty(0)])
    comp_cross: list[NDArray] = field(default_factory=lambda: [np.empty(0, np.complex128)])
    laf_state: float = 0.0  # time-weighted mean square carried from core to core
    laf_max: float = 0.0
    max_tan: float = 0.0

    @classmethod
    def empty(cls, plan: _Plan) -> _Accumulators:
        """Accumulators for ``plan``, before the first window."""
        nf, nb = plan.n_frames, plan.nb
        return cls(
            level=np.full(nf, -np.inf), rise_s=np.full(nf, np.nan), fall_s=np.full(nf, np.nan),
            leq=np.empty(nf), ridge_f=np.empty(nf), e_tot=np.empty(nf),
            e_rise=np.full(nf, np.nan), slope_f=np.full(nf, np.nan), frame_turns=np.zeros(nf),
            spec_state=np.zeros(plan.hi - plan.lo), mic_spec_sum=np.zeros(plan.freq.size),
            mic_cross_sum=np.zeros(plan.freq.size, np.complex128),
            rev_max=np.full((3, plan.n_rev), -np.inf), rev_min=np.full((3, plan.n_rev), np.inf),
            ang_q=np.zeros(nb), ang_macro=np.zeros(nb), ang_cnt=np.zeros(nb), ang_e=np.zeros(nb),
            ang_ecnt=np.zeros(nb),
        )


@dataclass(frozen=True)
class _Window:
    """Where one window lies: its core ``[c0, c1)`` (samples), its first sample ``w0``, the frames
    ``[f0, f1)`` that start in the core, and the run-out grid (every ``dec``-th sample from ``g0``,
    a multiple of ``dec``, so all windows share one grid; ``o = g0 - w0``). ``ci`` is the core on
    the window's grid; frame ``f0 + j``'s interval is grid samples ``[a[j], b[j])``."""

    c0: int
    c1: int
    w0: int
    f0: int
    f1: int
    o: int
    g0: int
    ci: slice
    a: NDArray[np.intp]
    b: NDArray[np.intp]

    @classmethod
    def at(cls, plan: _Plan, c0: int, c1: int, w0: int) -> _Window:
        """The window of core ``[c0, c1)`` starting at sample ``w0``."""
        hop, dec = plan.hop, plan.dec
        f0 = -(-c0 // hop)
        f1 = min(plan.n_frames, (c1 - 1) // hop + 1)
        o = (-w0) % dec
        g0 = w0 + o
        ci = slice(-(-(c0 - g0) // dec), -(-(c1 - g0) // dec))
        a = -(-(np.arange(f0, f1) * hop + plan.half - g0) // dec)
        return cls(c0, c1, w0, f0, f1, o, g0, ci, a, a + hop // dec)


def _band_level(plan: _Plan, s: AnalysisSettings, win: _Window, p: NDArray, acc: _Accumulators) -> NDArray:
    """Filter step for the microphone: A-weighted band mean square on the run-out grid, and the level.

    The IEC 61672-1 time weighting runs from the previous core's state through this core and
    on into the margin (for the frames ending there); each frame's level is the maximum over
    its interval (``acc.level``, mean square), the recording's peak is kept in ``acc.laf_max``.

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    p : ndarray of float32
        The window's sound pressure [Pa].
    acc : _Accumulators
        Updated in place.

    Returns
    -------
    ndarray
        A-weighted band mean square [Pa^2] on the window's run-out grid.
    """
    dec, ci = plan.dec, win.ci
    ends = (win.w0 + win.o == 0, win.w0 + p.size == plan.total)  # the recording's own ends: continued
    pw = band_weighted_signal(p[win.o:], plan.fs, s.band, recording_ends=ends, workers=plan.n_threads)
    m_full = pw.size // dec
    ms = np.zeros(-(-(p.size - win.o) // dec))
    ms[:m_full] = _mean_squares(pw, dec)
    laf = exponential_average(ms[ci.start:], dec / plan.fs, s.criteria.time_constant_s, initial=acc.laf_state)
    if ci.stop > ci.start:
        acc.laf_state = float(laf[ci.stop - ci.start - 1])
        acc.laf_max = max(acc.laf_max, float(laf[:ci.stop - ci.start].max()))
    if win.f1 > win.f0:
        acc.level[win.f0:win.f1] = np.maximum.reduceat(laf[:win.b[-1] - ci.start], win.a - ci.start)
        # where in each frame's interval the level crosses the threshold (to one grid step, dec / fs)
        loud = laf[:win.b[-1] - ci.start] >= plan.thr_power
        j = np.arange(loud.size)
        a, b = win.a - ci.start, win.b - ci.start
        first = np.minimum.reduceat(np.where(loud, j, loud.size), a)
        last = np.maximum.reduceat(np.where(loud, j, -1), a)
        t_grid = (win.g0 + (np.arange(loud.size) + ci.start) * dec) / plan.fs
        ok = (first < b) & (last >= 0)
        acc.rise_s[win.f0:win.f1] = np.where(ok, t_grid[np.minimum(first, loud.size - 1)], np.nan)
        acc.fall_s[win.f0:win.f1] = np.where(ok, t_grid[np.maximum(last, 0)] + dec / plan.fs, np.nan)
    return ms


class _Spectra(NamedTuple):
    """Band bins of the Hann frames of one window (single precision).

    ``spec_p`` holds frames ``[fp, f1)`` (one before the core's first, for the phase advance);
    ``spec``, ``pb`` (power per bin [Pa^2]), ``pa`` (A-weighted) and ``pa_tw`` (``pa`` time
    weighted over frames) hold frames ``[f0, f1)``.
    """

    fp: int
    spec_p: NDArray[np.complex64]
    spec: NDArray[np.complex64]
    pb: NDArray[np.float32]
    pa: NDArray[np.float32]
    pa_tw: NDArray


def _frame_spectra(plan: _Plan, win: _Window, p: NDArray, acc: _Accumulators) -> _Spectra:
    """Spectral step: Hann frames of the frames starting in the core, band bins only.

    Single precision (7 digits) is enough for levels, peaks and their refinement. Writes each
    frame's A-weighted level (``leq``), strongest line (``ridge_f``) and band power
    (``e_tot``) into ``acc``, and the A-weighted spectrum time weighted like the level
    (exponential over frames, same time constant; state carried in ``acc.spec_state``).

    Parameters
    ----------
    plan : _Plan
    win : _Window
        Must hold at least one frame (``f1 > f0``).
    p : ndarray of float32
        The window's sound pressure [Pa].
    acc : _Accumulators
        Updated in place.

    Returns
    -------
    _Spectra
    """
    n, hop, w0, f0, f1 = plan.n, plan.hop, win.w0, win.f0, win.f1
    # frames [fp, f1): one before the core's first (its samples lie in the margin), so
    # every frame but the recording's first has its predecessor for the phase advance
    fp = max(f0 - 1, 0)
    seg = p[fp * hop - w0: (f1 - 1) * hop + n - w0]
    frames_ = np.lib.stride_tricks.sliding_window_view(seg, n)[::hop]
    spec_p = sp_fft.rfft(frames_ * plan.win32, axis=-1, workers=plan.n_threads)[:, plan.lo:plan.hi]
    spec = spec_p[f0 - fp:]  # frames [f0, f1)
    pb, pa = _bin_powers(spec, np.float32(plan.pscale), plan.w_a32)  # [Pa^2] per bin
    bb = plan.band_bins
    lev = pa[:, bb].sum(axis=1, dtype=np.float64)
    acc.leq[f0:f1] = 10 * np.log10(np.maximum(lev, 1e-300) / P_REF**2)
    acc.ridge_f[f0:f1] = (_refine_rows(pb, np.argmax(pa[:, bb], axis=1) + bb.start) + plan.lo) * plan.fs / n
    # a component's level is the frame's Fast level times its share of the time-weighted spectrum,
    # so each tone's level is what the meter shows, split by what the meter has heard
    pa_tw, acc.spec_state = _time_weight_rows(pa, plan.a_frames, acc.spec_state)
    # band mean square per frame (Hann frames at 50 % overlap sum to the signal energy)
    acc.e_tot[f0:f1] = pb[:, bb].sum(axis=1, dtype=np.float64)
    return _Spectra(fp, spec_p, spec, pb, pa, pa_tw)


def _rows(index: NDArray[np.intp]) -> slice | NDArray[np.intp]:
    """Row numbers as a slice where they are consecutive (a view, not a copy, of the rows they select:
    all frames of a squealing window are loud), else as they are."""
    if index.size and int(index[-1]) - int(index[0]) + 1 == index.size and bool(np.all(index[1:] > index[:-1])):
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def _frame_components(plan: _Plan, s: AnalysisSettings, win: _Window, sp: _Spectra, acc: _Accumulators) -> None:
    """Tonal components of the loud frames (level at or above the threshold), with their frequencies.

    Components (and their coarse frequency) come from the time-weighted spectrum
    (:func:`~squealkit.measurement.squeal.events.tonal_components`). Each component's frequency is
    then refined from its phase advance over the main lobe (unbiased for growing and decaying
    squeal, where the two-bin ratio is not), where the tone is in the frame itself (a quarter of
    its time-weighted power), not only remembered. A component counts only when it is tonal:
    its tone-to-noise ratio in the time-weighted spectrum reaches ``s.min_tnr_db``
    (:func:`~squealkit.measurement.squeal.events.tone_to_noise_ratio`). Appends to ``acc.comp_*`` and sums the loud
    frames' spectra and cross spectra (``acc.mic_spec_sum``, ``acc.mic_cross_sum``).

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    sp : _Spectra
        The window's frame spectra.
    acc : _Accumulators
        Updated in place.
    """
    f0, f1, lo, hi, n, fs = win.f0, win.f1, plan.lo, plan.hi, plan.n, plan.fs
    loud = np.flatnonzero(acc.level[f0:f1] >= plan.thr_power)
    if not loud.size:
        return
    pa, pa_tw, pb = sp.pa, sp.pa_tw, sp.pb
    rows = _rows(loud)
    # phase advance of every band bin from the previous frame (zero for frame 0)
    prev = loud + (f0 - sp.fp - 1)
    before = np.conjugate(sp.spec_p[_rows(np.maximum(prev, 0))])
    cross = np.multiply(sp.spec[rows], before, out=before)  # X_m conj(X_m-1): one fresh array per window
    cross[prev < 0] = 0
    acc.mic_cross_sum[lo:hi] += cross.sum(axis=0, dtype=np.complex128)
    ptw = pa_tw[rows]
    # every peak of the band and its guard bins (power ``own``), then its refined frequency
    fr, ff, fl = tonal_components(ptw, ptw, lo, fs, n, -np.inf, half_width=plan.half_width)
    own = P_REF**2 * 10 ** (fl / 10)
    kc = np.clip(np.rint(ff * (n / fs)).astype(np.intp) - lo, _LOBE, hi - lo - 1 - _LOBE)
    lobe = kc[:, None] + np.arange(-_LOBE, _LOBE + 1)
    c = cross[fr[:, None], lobe].sum(axis=1, dtype=np.complex128)
    now = pa[loud[fr][:, None], lobe].sum(axis=1) >= 0.25 * pa_tw[loud[fr][:, None], lobe].sum(axis=1)
    ff_bins, ff = ff, np.where((prev[fr] >= 0) & now, phase_advance_freq(c, ff, fs, plan.hop), ff)
    # SAE J2521's band: a component counts where its frequency lies in it, edges included. The
    # level the meter shows (band-limited to the same edges) is split among the components by
    # their share of the frame's spectrum less the components outside the band (capped at 1:
    # a tone at an edge has part of its lobe in the guard bins). Edges are taken to the refined
    # frequency's accuracy on a steady tone (_EDGE_TOL_HZ).
    inside = (ff >= s.band[0] - _EDGE_TOL_HZ) & (ff <= s.band[1] + _EDGE_TOL_HZ)
    heard = ptw.sum(axis=1, dtype=np.float64) - np.bincount(fr[~inside], own[~inside], minlength=loud.size)
    share = np.minimum(own / np.maximum(heard[fr], 1e-300), 1.0)
    fl = 10 * np.log10(np.maximum(share * acc.level[f0:f1][loud[fr]], 1e-300) / P_REF**2)
    keep = inside & (fl >= s.threshold_dba)
    if s.min_tnr_db is not None and keep.any():  # tonality: a peak in broadband noise is no squeal
        # over the band's bins where the lobe lies in them, else (at an edge) with the guard bins too
        bb, sel = plan.band_bins, np.flatnonzero(keep)
        kb = kc[sel] - bb.start
        edge = (kb < _LOBE) | (kb > bb.stop - bb.start - 1 - _LOBE)
        tnr = np.empty(sel.size)
        tnr[~edge] = tone_to_noise_ratio(ptw[:, bb], fr[sel[~edge]], kb[~edge], ff_bins[sel[~edge]], fs / n,
                                         half_width=_LOBE)
        tnr[edge] = tone_to_noise_ratio(ptw, fr[sel[edge]], kc[sel[edge]], ff_bins[sel[edge]], fs / n,
                                        half_width=_LOBE)
        keep[sel] = tnr >= s.min_tnr_db
    fr, ff, fl, kc, c, lobe = fr[keep], ff[keep], fl[keep], kc[keep], c[keep], lobe[keep]
    # weights of the event's mean frequency: |c| (the cross power of the frame pair), so
    # a pair whose earlier frame is still in the noise (squeal onset) counts little
    wc = np.where(prev[fr] >= 0, np.abs(c) * plan.pscale, pb[loud[fr][:, None], lobe].sum(axis=1))
    acc.comp_frame.append(loud[fr] + f0)
    acc.comp_freq.append(ff)
    acc.comp_level.append(fl)
    acc.comp_pow.append(wc)
    acc.comp_cross.append(np.where(prev[fr] >= 0, c, 0))
    acc.mic_spec_sum[lo:hi] += pb[rows].sum(axis=0, dtype=np.float64)


class _Runout(NamedTuple):
    """The window's run-out on its grid: SRO, macro and micro run-out [m], grid times ``t_d``
    [s], the incline under the probe and under the pin (``tan_t``, at the sound's source)."""

    sro: NDArray[np.float64]
    macro: NDArray[np.float64]
    micro: NDArray[np.float64]
    t_d: NDArray[np.float64]
    tan_probe: NDArray[np.float64]
    tan_t: NDArray[np.float64]


def _runout_signals(plan: _Plan, s: AnalysisSettings, win: _Window, q: NDArray, rotation: Any) -> _Runout:
    """Filter step for the probe: run-out on the grid, split into macro and micro, and its incline.

    The zero-phase Butterworth low-pass at ``lowpass_freq`` (paper Fig. 12) runs at
    ``fs / dec`` after linear-phase anti-alias FIRs that pass up to 1.5 ``lowpass_freq`` and
    remove, 80 dB down, whatever would fold below it; so the corner keeps its meaning
    (:func:`~squealkit.measurement.signal.filters.lowpass_decimated`). The incline is
    ``dq / (r dphi)`` (paper eq. 11 with ``v = r dphi/dt`` at the actual speed).

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    q : ndarray
        The window's probe displacement [m].
    rotation : DiscAngle or ConstantSpeed

    Returns
    -------
    _Runout
    """
    fs, dec = plan.fs, plan.dec
    sro = lowpass_decimated(q[win.o:], s.lowpass_freq, fs, dec)
    if s.polarity < 0:
        sro = -sro
    macro = lowpass(sro, plan.f_macro, plan.fs_d, order=2)
    micro = sro - macro
    t_d = (win.g0 + np.arange(sro.size) * dec) / fs
    # (a speed extrapolated past the last tacho mark of a stop is held above 1/1000 of the mean)
    rps = np.maximum(rotation.rev_per_s(t_d), 1e-3 * plan.f_rev)
    tan_probe = np.gradient(sro) * plan.fs_d / (2 * math.pi * s.radius * rps)
    # incline under the pin when the sound heard at t_d left it: emitted at t_d - acoustic_delay,
    # from the surface the probe saw probe_offset earlier in rotation
    if s.acoustic_delay or plan.off_turns:
        t_src = rotation.time_at(rotation.turns(t_d - s.acoustic_delay) - plan.off_turns)
        tan_t = np.interp(t_src, t_d, tan_probe)
    else:
        tan_t = tan_probe
    return _Runout(sro, macro, micro, t_d, tan_probe, tan_t)


def _accumulate_runout(
    plan: _Plan, s: AnalysisSettings, win: _Window, ro: _Runout, ms: NDArray, rotation: Any, acc: _Accumulators
) -> None:
    """Tie the window's sound to its run-out: per frame, per revolution and per disc angle.

    Per frame: the share of the band energy on rising run-out (``e_rise``), the mean incline
    (``slope_f``) and the disc position under the pin when its sound left it
    (``frame_turns``); per revolution: run-out extremes; per angle bin: mean run-out and
    band energy. All in ``acc``.

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    win : _Window
    ro : _Runout
        The window's run-out.
    ms : ndarray
        A-weighted band mean square on the same grid (zero-phase: nothing shifted).
    rotation : DiscAngle or ConstantSpeed
    acc : _Accumulators
        Updated in place.
    """
    f0, f1, ci, hop, n, fs, nb = win.f0, win.f1, win.ci, plan.hop, plan.n, plan.fs, plan.nb
    cs_e, cs_r, cs_t = _running_sums(ms, ro.tan_t)
    if f1 > f0:
        a, b = win.a, win.b
        e_int = cs_e[b] - cs_e[a]
        share = np.divide(cs_r[b] - cs_r[a], e_int, out=np.full(e_int.shape, 0.5), where=e_int > 0)
        acc.e_rise[f0:f1] = acc.e_tot[f0:f1] * share
        acc.slope_f[f0:f1] = (cs_t[b] - cs_t[a]) / (b - a)
    # the probe sees disc position turns + probe offset (angle 0: the first mark, under the pin)
    turns = rotation.turns(ro.t_d[ci]) + plan.off_turns
    whole = np.floor(turns)
    rev = whole.astype(np.int64) - plan.rev0
    rev = np.clip(rev, 0, plan.n_rev - 1)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(rev)) + 1])
    r = rev[starts]  # distinct revolutions of this core; the next core may continue the last one
    for j, sig in enumerate((ro.sro[ci], ro.macro[ci], ro.micro[ci])):
        acc.rev_max[j, r] = np.maximum(acc.rev_max[j, r], np.maximum.reduceat(sig, starts))
        acc.rev_min[j, r] = np.minimum(acc.rev_min[j, r], np.minimum.reduceat(sig, starts))
    ang_q, ang_macro, ang_cnt = _angle_sums(turns, ro.sro[ci], ro.macro[ci], nb)
    acc.ang_q += ang_q
    acc.ang_macro += ang_macro
    acc.ang_cnt += ang_cnt
    acc.max_tan = max(acc.max_tan, float(np.max(np.abs(ro.tan_probe[ci]))))
    if f1 > f0:  # the disc position under the pin when the frame's sound left it
        centre = rotation.turns((np.arange(f0, f1) * hop + n / 2) / fs - s.acoustic_delay)
        # the component weights are cross powers of a frame and its predecessor: centred half a hop earlier
        acc.frame_turns[f0:f1] = rotation.turns((np.arange(f0, f1) * hop + (n - hop) / 2) / fs - s.acoustic_delay)
        fb = ((centre % 1.0) * nb).astype(np.int64) % nb
        acc.ang_e += np.bincount(fb, acc.e_tot[f0:f1], nb)
        acc.ang_ecnt += np.bincount(fb, minlength=nb)


def _squeal_events(
    plan: _Plan, s: AnalysisSettings, acc: _Accumulators
) -> tuple[list[SquealEvent], list[NDArray[np.intp]], list[NDArray[np.float64]]]:
    """Events step: link the tonal components of successive frames into events (VDA 303 tracks).

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    acc : _Accumulators
        After the last window.

    Returns
    -------
    events, frames, weights
        As :func:`~squealkit.measurement.squeal.events.link_components`.
    """
    frame_start = np.arange(plan.n_frames) * plan.hop / plan.fs
    events, frames, weights = link_components(
        np.concatenate(acc.comp_frame), np.concatenate(acc.comp_freq), np.concatenate(acc.comp_level),
        np.concatenate(acc.comp_pow), frame_start + plan.half / plan.fs, plan.hop / plan.fs,
        freq_tol=s.freq_tol, min_duration=s.min_duration,
    )
    # within its first and last frame, an event starts where the Fast level reaches the threshold
    # and ends where it last is at or above it (to dec / fs, not the hop)
    for i, (ev, fr) in enumerate(zip(events, frames, strict=True)):
        rise, fall = acc.rise_s[fr[0]], acc.fall_s[fr[-1]]
        start = float(rise) if np.isfinite(rise) else ev.start_s
        end = float(fall) if np.isfinite(fall) and fall > start else ev.end_s
        events[i] = replace(ev, start_s=start, end_s=end)
    return events, frames, weights


def _squeal_lines(plan: _Plan, acc: _Accumulators, in_ev: NDArray[np.bool_]) -> tuple[float, list[dict[str, float]]]:
    """The dominant squeal frequency and its harmonics 2-5, from the loud frames' spectra.

    The dominant line's phase advance is taken over its own components only: the main lobe of
    another squeal line less than two bins away must not pull it (VDA 303: several
    frequencies). Each harmonic's frequency comes from the two-bin ratio, then its phase
    advance over all loud frames.

    Parameters
    ----------
    plan : _Plan
    acc : _Accumulators
        After the last window (with at least one event).
    in_ev : ndarray of bool, shape (n_frames,)
        Frames inside an event.

    Returns
    -------
    squeal_frequency_hz : float
    harmonics : list of dict
        ``order``, ``frequency_hz``, ``level_db``.
    """
    fs, n, hop, lo, hi = plan.fs, plan.n, plan.hop, plan.lo, plan.hi
    spec_sum = acc.mic_spec_sum
    comp_f, comp_c = np.concatenate(acc.comp_freq), np.concatenate(acc.comp_cross)
    mag = np.sqrt(spec_sum)
    k0 = lo + int(np.argmax(spec_sum[lo:hi] * plan.w_a))
    squeal_f = float(refine_peak(mag, k0)) * fs / n
    c_line = comp_c[np.abs(comp_f - squeal_f) < 0.5 * fs / n].sum()
    if c_line != 0:
        squeal_f = float(phase_advance_freq(c_line, squeal_f, fs, hop))
    n_loud_ev = max(int(in_ev.sum()), 1)
    harmonics: list[dict[str, float]] = []
    for h in range(2, 6):
        kh = round(h * squeal_f * n / fs)
        if kh + 3 + _HARMONIC_FLANK >= hi:
            break
        kk = kh - 2 + int(np.argmax(spec_sum[kh - 2:kh + 3]))
        # a harmonic is there only as a peak standing _HARMONIC_SNR_DB above the floor around it
        flanks = np.concatenate([spec_sum[kk - 2 - _HARMONIC_FLANK:kk - 2], spec_sum[kk + 3:kk + 3 + _HARMONIC_FLANK]])
        if not (spec_sum[kk] >= spec_sum[kk - 1] and spec_sum[kk] >= spec_sum[kk + 1]
                and spec_sum[kk] > 10 ** (_HARMONIC_SNR_DB / 10) * np.median(flanks)):
            continue
        p_h = spec_sum[kk - 2:kk + 3].sum() / n_loud_ev
        f_h = float(refine_peak(mag, kk)) * fs / n  # then its phase advance over all loud frames
        f_h = float(phase_advance_freq(acc.mic_cross_sum[kk - _LOBE:kk + _LOBE + 1].sum(), f_h, fs, hop))
        if abs(f_h - h * squeal_f) > fs / n:  # not at h f0: no harmonic of this line
            continue
        harmonics.append({"order": h, "frequency_hz": f_h,
                          "level_db": float(10 * np.log10(max(p_h, 1e-300) / P_REF**2))})
    return squeal_f, harmonics


def _in_events(n_frames: int, ev_frames: list[NDArray[np.intp]]) -> NDArray[np.bool_]:
    """Whether each frame lies between the first and last frame of some event.

    Parameters
    ----------
    n_frames : int
    ev_frames : list of ndarray
        Each event's frames (ascending).

    Returns
    -------
    ndarray of bool, shape (n_frames,)
    """
    cover = np.zeros(n_frames + 1, np.int64)  # +1 at each event's first frame, -1 after its last
    np.add.at(cover, np.array([fr[0] for fr in ev_frames]), 1)
    np.add.at(cover, np.array([fr[-1] for fr in ev_frames]) + 1, -1)
    return np.cumsum(cover[:-1]) > 0


def _runout_statistics(
    plan: _Plan, s: AnalysisSettings, acc: _Accumulators, in_ev: NDArray[np.bool_]
) -> tuple[float | None, float | None]:
    """The rising fraction and the growth/run-out-slope correlation of a recording with squeal.

    Parameters
    ----------
    plan : _Plan
    s : AnalysisSettings
    acc : _Accumulators
        After the last window.
    in_ev : ndarray of bool, shape (n_frames,)
        Frames inside an event.

    Returns
    -------
    rising_fraction : float or None
        Share of the band energy during events on rising run-out.
    growth_slope_correlation : float or None
        Pearson correlation of the envelope's growth rate with the SRO slope over the frames
        within 20 dB of the threshold (None where either does not vary).
    """
    tot = float(acc.e_tot[in_ev].sum())
    rising = float(acc.e_rise[in_ev].sum() / tot) if tot > 0 else None
    with np.errstate(divide="ignore"):
        ln_e = np.log(np.maximum(acc.e_tot, 1e-300))
    growth = np.gradient(ln_e) * 0.5 * plan.fs / plan.hop
    sel = acc.leq >= s.threshold_dba - 20
    corr = None
    if sel.sum() > 3 and np.std(growth[sel]) > 0 and np.std(acc.slope_f[sel]) > 0:
        corr = float(np.corrcoef(growth[sel], acc.slope_f[sel])[0, 1])
    return rising, corr


def _runout_link(
    plan: _Plan, acc: _Accumulators, events: list[SquealEvent], ev_frames: list[NDArray[np.intp]],
    ev_weights: list[NDArray[np.float64]],
) -> tuple[float | None, list[SquealEvent]]:
    """Run-out link step: where on the disc the squeal sounds, relative to the macro run-out's crest.

    The squeal energy's circular mean disc angle against the macro run-out's crest (both in the
    disc's frame); each event's own place from its component's power per frame at the frame's
    disc angle.

    Parameters
    ----------
    plan : _Plan
    acc : _Accumulators
        After the last window.
    events, ev_frames, ev_weights
        As from :func:`_squeal_events`.

    Returns
    -------
    runout_phase_deg : float or None
        None without events or angle data.
    events : list of SquealEvent
        With ``runout_phase_deg`` set.
    """
    if not (events and acc.ang_ecnt.any() and acc.ang_cnt.any()):
        return None, events
    nb = plan.nb
    angle_c = (np.arange(nb) + 0.5) * 2 * math.pi / nb
    e_mean = np.divide(acc.ang_e, acc.ang_ecnt, out=np.zeros(nb), where=acc.ang_ecnt > 0)
    z = np.sum(e_mean * np.exp(1j * angle_c))
    q_mean = np.divide(acc.ang_macro, acc.ang_cnt, out=np.full(nb, -np.inf), where=acc.ang_cnt > 0)
    crest = angle_c[int(np.argmax(q_mean))]
    phase = float(np.degrees(np.angle(z * np.exp(-1j * crest))))
    rot = np.exp(-1j * crest)
    events = [replace(e, runout_phase_deg=float(np.degrees(np.angle(
                  np.sum(w * np.exp(2j * math.pi * acc.frame_turns[fr])) * rot))))
              for e, fr, w in zip(events, ev_frames, ev_weights, strict=True)]
    return phase, events


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


def _read_block(src: Any, plan: _Plan) -> int:
    """Samples per block to read from ``src``: an in-memory recording is one block (windows are views
    of it); a file is read in blocks of four cores, so most windows are views too (copying every window
    cost about 7 % of the analysis); a generated source in blocks of one core (its temporaries scale
    with the block: bounded memory first)."""
    if isinstance(src, _DatasetSource):
        return plan.total
    return max((4 if isinstance(src, RecordingSource) else 1) * plan.core, DEFAULT_BLOCK)


def analyze_recording(
    recording: str | Path | xr.Dataset | RecordingSource,
    *,
    mic: str | int,
    displacement: str | int,
    rpm: float | None = None,
    radius: float,
    tacho: str | int | None = None,
    setup: str | None = None,
    band: tuple[float, float] | None = None,
    threshold_dba: float = 70.0,
    min_duration: float = 0.01,
    time_weighting: str = "fast",
    fs: float | None = None,
    progress: Callable[[int, int], None] | None = None,
    require_runout: bool = True,
    **options: Any,
) -> MeasurementResult:
    """Analyse a microphone + displacement recording for squeal and its tie to run-out.

    Parameters
    ----------
    recording : path, xarray.Dataset or RecordingSource
        The recording (see :func:`squealkit.measurement.open_recording` for formats).
    mic, displacement : str or int
        Channel name or index of the calibrated microphone [Pa] and the eddy-current
        probe [m].
    rpm : float, optional
        Disc speed [rpm] (paper: 900) when there is no tacho (constant speed).
    radius : float
        Probe (and pin) radius on the disc [m].
    tacho : str or int, optional
        Tacho channel: disc angle and speed from it (:mod:`squealkit.measurement.signal.tacho`;
        options ``tacho_kind`` "pulses" or "angle", ``pulses_per_rev``, ``tacho_level``,
        ``angle_unit``), so a decelerating stop is analysed at its actual speed; revolutions
        and angles count from the first pulse.
    setup : {"component", "corner"}, optional
        SAE J2521 setup whose squeal band applies (default ``"component"``, 2-16 kHz: brakes
        not on a full corner, such as a pin-on-disc rig; ``"corner"``: 1.25-16 kHz).
    band : (float, float), optional
        A user band [Hz] instead of the setup's.
    threshold_dba : float
        Squeal threshold [dB(A)] (SAE J2521: 70).
    min_duration : float
        Shortest event [s] (no standard fixes it).
    time_weighting : {"fast", "slow"}
        IEC 61672-1 time weighting of the level (default Fast, 125 ms).
    fs : float, optional
        Sample rate [Hz] where the recording does not carry one.
    progress : callable, optional
        Called as ``progress(samples_done, samples_total)``.
    require_runout : bool, default True
        Without a disc speed (no ``rpm`` nor ``tacho``, or a tacho that cannot give one, e.g.
        fewer than 3 marks in a short low-speed drag) raise; with False analyse the squeal alone
        (SAE J2521 occurrence needs no speed) and say why in the result's
        ``runout_unavailable`` (the run-out results are then None or NaN).
    **options
        Further :class:`AnalysisSettings` fields (``lowpass_freq``, ``macro_orders``,
        ``nperseg``, ``hop``, ``freq_tol``, ``n_angle_bins``, ``chunk_s``), and the rig's
        geometry: ``probe_offset_deg`` (the probe sits this far upstream of the pin, so it sees
        the surface that much rotation before the pin), ``acoustic_delay`` [s] (pin to
        microphone) and ``polarity`` (-1: the probe reads the run-out reversed); and
        ``min_tnr_db``, the tonality a squeal component needs (tone-to-noise ratio [dB], default
        8 as ECMA-418-1 for a prominent tone; None: none).

    Returns
    -------
    MeasurementResult

    Examples
    --------
    >>> from squealkit.measurement import synthetic_recording
    >>> rec = synthetic_recording(duration=1.0, seed=1)
    >>> res = analyze_recording(rec, mic="mic", displacement="displacement", rpm=900, radius=0.05)
    >>> abs(res.squeal_frequency_hz - 2388.0) < 5 and res.rising_fraction > 0.8
    True
    """
    src, attrs = _open_source(recording, fs)
    crit = squeal_criteria(setup, band=band, threshold_dba=threshold_dba, time_weighting=time_weighting,
                           min_duration=min_duration)
    fs_ = float(src.fs)
    rotation, rpm, unavailable = _disc_rotation(src, tacho, rpm, options, required=require_runout)
    try:
        s = AnalysisSettings(rpm=rpm, radius=radius, criteria=crit, **options)
    except TypeError as e:
        raise InputError(f"Unknown analysis option: {e}") from e
    s = s.validated(fs_)
    mic_n, disp_n = src.resolve(mic), src.resolve(displacement)
    if mic_n == disp_n:
        raise InputError(f"The microphone and displacement channels are the same ({mic_n!r}).")
    plan = _plan(s, fs_, src.n_samples, rotation)
    acc = _Accumulators.empty(plan)
    block = _read_block(src, plan)
    wanted = [mic_n] if rotation is None else [mic_n, disp_n]  # no speed: the probe is not read
    for c0, c1, w0, data in _windows(src, wanted, plan.core, plan.margin, block):
        win = _Window.at(plan, c0, c1, w0)
        _check_pressure(mic_n, data[mic_n])
        p = data[mic_n].astype(np.float32)  # the band level and the frames: single precision
        ms = _band_level(plan, s, win, p, acc)
        if win.f1 > win.f0:
            _frame_components(plan, s, win, _frame_spectra(plan, win, p, acc), acc)
        if rotation is not None:
            _accumulate_runout(plan, s, win, _runout_signals(plan, s, win, data[disp_n], rotation), ms, rotation,
                               acc)
        if progress is not None:
            progress(c1, plan.total)

    events, ev_frames, ev_weights = _squeal_events(plan, s, acc)
    squeal_f: float | None = None
    harmonics: list[dict[str, float]] = []
    rising: float | None = None
    corr: float | None = None
    if events:
        in_ev = _in_events(plan.n_frames, ev_frames)
        squeal_f, harmonics = _squeal_lines(plan, acc, in_ev)
        if rotation is not None:
            rising, corr = _runout_statistics(plan, s, acc, in_ev)
    phase, events = _runout_link(plan, acc, events, ev_frames, ev_weights)
    return _assemble(plan, s, acc, rotation, src, attrs, events=events, squeal_f=squeal_f, harmonics=harmonics,
                     rising=rising, corr=corr, phase=phase, unavailable=unavailable)
