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
from typing import Any

import numpy as np
import xarray as xr
from numba import njit
from numpy.typing import NDArray
from scipy import fft as sp_fft
from scipy import signal

from .. import __version__
from .._threads import thread_limit
from .._validation import InputError, validate_fs, validate_positive
from .criteria import SquealCriteria, band_weighted_signal, exponential_average, squeal_criteria
from .events import SquealEvent, link_components, tonal_components
from .filters import lowpass, lowpass_decimated
from .readers import DEFAULT_BLOCK, RecordingSource, open_recording
from .runout import revolution_frequency, surface_speed
from .spectral import P_REF, a_weighting_db, phase_advance_freq, refine_peak
from .tacho import ConstantSpeed, read_tacho

__all__ = ["AnalysisSettings", "MeasurementResult", "analyze_recording"]

#: Bins either side of a line's peak bin summed in the phase-advance estimate: the Hann main
#: lobe's core, which holds nearly all of a tone's energy (see phase_advance_freq).
_LOBE = 2


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
        What a tacho channel holds (see :func:`squealkit.measurement.tacho.read_tacho`).
    pulses_per_rev : int, default 1
        Tacho pulses per revolution.
    tacho_level : float or None, default None
        Trigger level of the pulses (default: halfway between the first block's extremes).
    angle_unit : {"deg", "rad", "rev"}, default "deg"
        Unit of an angle tacho channel.
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

    def validated(self, fs: float) -> AnalysisSettings:
        """These settings, checked against each other and the sample rate.

        Parameters
        ----------
        fs : float
            Sample rate [Hz] of the recording (the band must lie below ``fs / 2``).

        Returns
        -------
        AnalysisSettings
            ``self``, unchanged.

        Raises
        ------
        InputError
            If a setting is out of range.
        """
        validate_positive("rpm", self.rpm)
        validate_positive("radius", self.radius)
        validate_positive("chunk_s", self.chunk_s)
        validate_positive("acoustic_delay", self.acoustic_delay, allow_zero=True)
        if self.polarity not in (1, -1):
            raise InputError(f"Parameter polarity={self.polarity!r} must be 1 or -1 (probe reading reversed).")
        if not math.isfinite(self.probe_offset_deg) or abs(self.probe_offset_deg) >= 360:
            raise InputError(f"Parameter probe_offset_deg={self.probe_offset_deg!r} must lie in (-360, 360).")
        if self.band[1] >= fs / 2:
            raise InputError(f"Parameter band={self.band!r}: upper edge must lie below fs/2 = {fs / 2:g} Hz.")
        if not (isinstance(self.nperseg, int) and self.nperseg >= 16):
            raise InputError(f"Parameter nperseg={self.nperseg!r} must be a whole number >= 16.")
        if not (isinstance(self.hop, int) and 1 <= self.hop <= self.nperseg):
            raise InputError(f"Parameter hop={self.hop!r} must be a whole number in [1, nperseg].")
        return self


@dataclass(frozen=True)
class MeasurementResult:
    """What a recording says about squeal and run-out.

    Attributes
    ----------
    squeal_frequency_hz : float or None
        Dominant squeal frequency [Hz]; None without squeal. The strongest A-weighted line of
        the squeal spectrum, refined from its phase advance between successive frames
        (:func:`~squealkit.measurement.spectral.phase_advance_freq`): to a few mHz on synthetic
        bursts, where the bin interpolation was off by up to 6 Hz (bins of 78 Hz).
    harmonics : tuple of dict
        ``order``, ``frequency_hz``, ``level_db`` of harmonics 2-5 of the squeal (frequencies
        refined the same way).
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
    b = 1.0 - a
    for j in range(p.shape[1]):
        y = state[j]
        for m in range(p.shape[0]):
            y = a * y + b * p[m, j]
            out[m, j] = y
        state[j] = y


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
                fs = 1.0 / float(np.median(np.diff(ds["time"].values[:64])))
            else:
                raise InputError("The recording has no 'fs' attribute or time coordinate; give fs.")
        self.fs = validate_fs(fs)
        self.channels = tuple(str(n) for n in ds.data_vars if ds[n].ndim == 1)
        self.n_samples = int(ds.sizes[ds[self.channels[0]].dims[0]]) if self.channels else 0
        self.units = {n: str(ds[n].attrs.get("units", "")) for n in self.channels}
        self.path = Path(str(ds.attrs.get("source", "<dataset>")))
        self.fmt = "dataset"

    resolve = RecordingSource.resolve

    def iter_blocks(self, channels, *, block=DEFAULT_BLOCK):
        names = [self.resolve(c) for c in channels]
        for start in range(0, self.n_samples, block):
            out = {}
            for n in names:
                v = np.asarray(self.ds[n].values[start:start + block], dtype=np.float64)
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
        Tacho channel: disc angle and speed from it (:mod:`squealkit.measurement.tacho`;
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
    **options
        Further :class:`AnalysisSettings` fields (``lowpass_freq``, ``macro_orders``,
        ``nperseg``, ``hop``, ``freq_tol``, ``n_angle_bins``, ``chunk_s``), and the rig's
        geometry: ``probe_offset_deg`` (the probe sits this far upstream of the pin, so it sees
        the surface that much rotation before the pin), ``acoustic_delay`` [s] (pin to
        microphone) and ``polarity`` (-1: the probe reads the run-out reversed).

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
    if isinstance(recording, xr.Dataset):
        src: Any = _DatasetSource(recording, fs)
        attrs = dict(recording.attrs)
    elif isinstance(recording, RecordingSource):
        src, attrs = recording, {"source": str(recording.path), "synthetic": recording.synthetic}
    elif hasattr(recording, "iter_blocks"):  # e.g. a SyntheticSource
        src, attrs = recording, {"source": str(recording.path), "synthetic": recording.fmt == "synthetic"}
    else:
        src = open_recording(recording, fs=fs)
        attrs = {"source": str(src.path), "synthetic": src.synthetic}
    crit = squeal_criteria(setup, band=band, threshold_dba=threshold_dba, time_weighting=time_weighting,
                           min_duration=min_duration)
    fs_ = float(src.fs)
    rotation: Any
    if tacho is not None:
        tk = {k: options[k] for k in ("tacho_kind", "pulses_per_rev", "tacho_level", "angle_unit") if k in options}
        rotation = read_tacho(src, tacho, kind=tk.get("tacho_kind", "pulses"),
                              pulses_per_rev=tk.get("pulses_per_rev", 1), level=tk.get("tacho_level"),
                              angle_unit=tk.get("angle_unit", "deg"))
        span = src.n_samples / fs_
        rpm = 60.0 * float(rotation.turns(span) - rotation.turns(0.0)) / span  # mean speed
    elif rpm is None:
        raise InputError("Give the disc speed rpm, or a tacho channel.")
    else:
        rotation = ConstantSpeed(validate_positive("rpm", rpm))
    try:
        s = AnalysisSettings(rpm=rpm, radius=radius, criteria=crit, **options)
    except TypeError as e:
        raise InputError(f"Unknown analysis option: {e}") from e
    s = s.validated(fs_)
    mic_n, disp_n = src.resolve(mic), src.resolve(displacement)
    if mic_n == disp_n:
        raise InputError(f"The microphone and displacement channels are the same ({mic_n!r}).")
    total = src.n_samples
    if total < s.nperseg:
        raise InputError(f"Recording has {total} samples, fewer than one analysis frame ({s.nperseg}).")
    f_rev = revolution_frequency(s.rpm)
    v = surface_speed(s.rpm, s.radius)
    n, hop = s.nperseg, s.hop
    freq = np.fft.rfftfreq(n, 1 / fs_)
    lo, hi = int(np.searchsorted(freq, s.band[0])), int(np.searchsorted(freq, s.band[1], side="right"))
    if hi - lo < 5:
        raise InputError(f"Band {s.band} Hz holds fewer than 5 bins of {fs_ / n:g} Hz; widen it or raise nperseg.")
    w_a = 10 ** (a_weighting_db(freq[lo:hi]) / 10)
    win = signal.windows.hann(s.nperseg, sym=False)
    win32 = win.astype(np.float32)
    w_a32 = w_a.astype(np.float32)
    pscale = 2.0 / (s.nperseg * float(np.sum(win**2)))
    thr_power = P_REF**2 * 10 ** (s.threshold_dba / 10)
    n_threads = thread_limit()  # FFT threads: this process's share (one on a one-thread Dask worker)
    half_width = max(2, int(0.5 * s.freq_tol * n / fs_))  # bins of a tonal component either side
    # the Fast level is compared and stored as mean square until the end
    core = max(hop, round(s.chunk_s * fs_ / hop) * hop)
    # the slowest speed decides how far the probe's view of the pin's surface lies back in time
    t_span = np.linspace(0.0, total / fs_, 257)
    f_min = max(float(np.min(rotation.rev_per_s(t_span))), 1e-3 * f_rev)
    lag = s.acoustic_delay + abs(s.probe_offset_deg) / 360.0 / f_min
    margin = max(n, int(0.25 * fs_), int(4 * fs_ / ((s.macro_orders + 0.5) * f_rev)), int(lag * fs_) + n)
    off_turns = s.probe_offset_deg / 360.0
    n_frames = (total - n) // hop + 1
    half = (n - hop) // 2  # frame "interval" [start + half, start + half + hop) for energy sums
    # run-out is analysed at fs / dec, dec a divisor of hop with fs / dec >= 4 lowpass_freq
    dec = max(d for d in range(1, hop + 1) if hop % d == 0 and fs_ / d >= 4 * s.lowpass_freq)
    fs_d = fs_ / dec
    f_macro = (s.macro_orders + 0.5) * f_rev
    if f_macro >= s.lowpass_freq:
        raise InputError(f"macro_orders={s.macro_orders} at {s.rpm:g} rpm puts the macro corner ({f_macro:g} Hz) "
                         f"above lowpass_freq={s.lowpass_freq:g} Hz.")

    level = np.full(n_frames, -np.inf)  # Fast (time-weighted) level: max over each frame's interval
    leq = np.empty(n_frames)  # the frame's own A-weighted band level (Hann window)
    laf_state = 0.0  # time-weighted mean square carried from core to core
    laf_max = 0.0
    spec_state = np.zeros(hi - lo)  # time-weighted A-weighted power spectrum carried likewise
    a_frames = math.exp(-hop / fs_ / s.criteria.time_constant_s)
    a_tw = s.criteria.time_constant_s
    ridge_f = np.empty(n_frames)
    e_tot = np.empty(n_frames)
    e_rise = np.empty(n_frames)
    slope_f = np.empty(n_frames)
    comp_frame: list[NDArray] = [np.empty(0, np.intp)]
    comp_freq: list[NDArray] = [np.empty(0)]
    comp_level: list[NDArray] = [np.empty(0)]
    comp_pow: list[NDArray] = [np.empty(0)]
    comp_cross: list[NDArray] = [np.empty(0, np.complex128)]
    mic_spec_sum = np.zeros(freq.size)  # summed over loud frames, band bins only
    mic_cross_sum = np.zeros(freq.size, np.complex128)  # X_m conj(X_m-1) summed likewise
    rev0 = math.floor(float(rotation.turns(0.0)))  # revolutions count from the first mark (or t = 0)
    n_rev = math.floor(float(rotation.turns((total - 1) / fs_))) - rev0 + 1
    rev_max = np.full((3, n_rev), -np.inf)  # sro, macro, micro per revolution
    rev_min = np.full((3, n_rev), np.inf)
    nb = s.n_angle_bins
    ang_q = np.zeros(nb)
    ang_macro = np.zeros(nb)
    ang_cnt = np.zeros(nb)
    ang_e = np.zeros(nb)
    ang_ecnt = np.zeros(nb)
    max_tan = 0.0
    frame_turns = np.zeros(n_frames)  # disc position under the pin when each frame pair's sound left it

    # an in-memory recording is one block (windows are views of it); files are read block by block
    block = total if isinstance(src, _DatasetSource) else max(core, DEFAULT_BLOCK)
    for c0, c1, w0, data in _windows(src, [mic_n, disp_n], core, margin, block):
        p, q = data[mic_n], data[disp_n]
        f0 = -(-c0 // hop)
        f1 = min(n_frames, (c1 - 1) // hop + 1)
        # the run-out grid: every dec-th sample, from g0 (a multiple of dec: one grid for all cores)
        o = (-w0) % dec
        g0 = w0 + o
        ci = slice(-(-(c0 - g0) // dec), -(-(c1 - g0) // dec))
        # A-weighted band mean square on the grid, time weighted (IEC 61672-1) from the state of the
        # previous core on, through this core and on into the margin (for the frames ending there)
        pw = band_weighted_signal(p[o:], fs_, s.band, workers=n_threads)
        m_full = pw.size // dec
        ms = np.zeros(-(-(p.size - o) // dec))
        ms[:m_full] = np.square(pw[:m_full * dec], dtype=np.float32).reshape(-1, dec).mean(axis=1, dtype=np.float64)
        laf = exponential_average(ms[ci.start:], dec / fs_, a_tw, initial=laf_state)
        if ci.stop > ci.start:
            laf_state = float(laf[ci.stop - ci.start - 1])
            laf_max = max(laf_max, float(laf[:ci.stop - ci.start].max()))
        if f1 > f0:
            a = -(-(np.arange(f0, f1) * hop + half - g0) // dec)
            b = a + hop // dec
            level[f0:f1] = np.maximum.reduceat(laf[:b[-1] - ci.start], a - ci.start)
        # frames [f0, f1) start inside the core; their samples lie in the window
        if f1 > f0:
            # frames [fp, f1): one before the core's first (its samples lie in the margin), so
            # every frame but the recording's first has its predecessor for the phase advance
            fp = max(f0 - 1, 0)
            seg = p[fp * hop - w0: (f1 - 1) * hop + n - w0]
            frames_ = np.lib.stride_tricks.sliding_window_view(seg.astype(np.float32), n)[::hop]
            # single precision (7 digits) for the framed spectra: levels, peaks and their refinement
            spec_p = sp_fft.rfft(frames_ * win32, axis=-1, workers=n_threads)[:, lo:hi]
            spec = spec_p[f0 - fp:]  # frames [f0, f1)
            pb = spec.real**2
            pb += spec.imag**2
            pb *= np.float32(pscale)  # [Pa^2] per bin
            pa = pb * w_a32
            lev = pa.sum(axis=1, dtype=np.float64)
            leq[f0:f1] = 10 * np.log10(np.maximum(lev, 1e-300) / P_REF**2)
            ridge_f[f0:f1] = (_refine_rows(pb, np.argmax(pa, axis=1)) + lo) * fs_ / n
            # the A-weighted spectrum time weighted like the level (exponential over frames, same time
            # constant): a component's level is the frame's Fast level times its share of this spectrum,
            # so each tone's level is what the meter shows, split by what the meter has heard
            pa_tw, spec_state = _time_weight_rows(pa, a_frames, spec_state)
            loud = np.flatnonzero(level[f0:f1] >= thr_power)
            share_scale = level[f0:f1][loud] / np.maximum(pa_tw[loud].sum(axis=1, dtype=np.float64), 1e-300)
            if loud.size:
                # phase advance of every band bin from the previous frame (zero for frame 0)
                prev = loud + (f0 - fp - 1)
                cross = spec[loud] * np.conj(spec_p[np.maximum(prev, 0)])
                cross[prev < 0] = 0
                mic_cross_sum[lo:hi] += cross.sum(axis=0, dtype=np.complex128)
                # components (and their coarse frequency) from the time-weighted spectrum
                fr, ff, fl = tonal_components(pa_tw[loud], pa_tw[loud], lo, fs_, n, s.threshold_dba,
                                              scale=share_scale, half_width=half_width)
                # each component's frequency from its phase advance over the main lobe (unbiased
                # for growing and decaying squeal, where the two-bin ratio is not), where the tone is
                # in the frame itself (a quarter of its time-weighted power), not only remembered
                kc = np.clip(np.rint(ff * (n / fs_)).astype(np.intp) - lo, _LOBE, hi - lo - 1 - _LOBE)
                lobe = kc[:, None] + np.arange(-_LOBE, _LOBE + 1)
                c = cross[fr[:, None], lobe].sum(axis=1, dtype=np.complex128)
                now = pa[loud[fr][:, None], lobe].sum(axis=1) >= 0.25 * pa_tw[loud[fr][:, None], lobe].sum(axis=1)
                ff = np.where((prev[fr] >= 0) & now, phase_advance_freq(c, ff, fs_, hop), ff)
                # weights of the event's mean frequency: |c| (the cross power of the frame pair), so
                # a pair whose earlier frame is still in the noise (squeal onset) counts little
                wc = np.where(prev[fr] >= 0, np.abs(c) * pscale, pb[loud[fr][:, None], lobe].sum(axis=1))
                comp_frame.append(loud[fr] + f0)
                comp_freq.append(ff)
                comp_level.append(fl)
                comp_pow.append(wc)
                comp_cross.append(np.where(prev[fr] >= 0, c, 0))
                mic_spec_sum[lo:hi] += pb[loud].sum(axis=0, dtype=np.float64)
            # band mean square per frame (Hann frames at 50 % overlap sum to the signal energy)
            e_tot[f0:f1] = pb.sum(axis=1, dtype=np.float64)
        # run-out on every dec-th sample (fs / dec >= 4 lowpass_freq): the zero-phase Butterworth
        # low-pass at lowpass_freq (paper Fig. 12), run at fs / dec after linear-phase anti-alias
        # FIRs that pass up to 1.5 lowpass_freq and remove, 80 dB down, whatever would fold below
        # it; so the corner keeps its meaning (lowpass_decimated; tests compare the full rate)
        sro = lowpass_decimated(q[o:], s.lowpass_freq, fs_, dec)
        if s.polarity < 0:
            sro = -sro
        macro = lowpass(sro, f_macro, fs_d, order=2)
        micro = sro - macro
        # incline under the probe, dq / (r dphi) (paper eq. 11 with v = r dphi/dt at the actual speed)
        t_d = (g0 + np.arange(sro.size) * dec) / fs_
        # (a speed extrapolated past the last tacho mark of a stop is held above 1/1000 of the mean)
        rps = np.maximum(rotation.rev_per_s(t_d), 1e-3 * f_rev)
        tan_probe = np.gradient(sro) * fs_d / (2 * math.pi * s.radius * rps)
        # incline under the pin when the sound heard at t_d left it: emitted at t_d - acoustic_delay,
        # from the surface the probe saw probe_offset earlier in rotation
        if s.acoustic_delay or off_turns:
            t_src = rotation.time_at(rotation.turns(t_d - s.acoustic_delay) - off_turns)
            tan_t = np.interp(t_src, t_d, tan_probe)
        else:
            tan_t = tan_probe
        # A-weighted sound energy in the squeal band on the run-out grid (zero-phase: nothing shifted)
        e_d = ms
        cs_e, cs_r, cs_t = np.zeros((3, sro.size + 1))  # cumulative sums from 0
        np.cumsum(e_d, out=cs_e[1:])
        np.cumsum(np.where(tan_t > 0, e_d, 0.0), out=cs_r[1:])
        np.cumsum(tan_t, out=cs_t[1:])
        if f1 > f0:
            e_int = cs_e[b] - cs_e[a]
            share = np.divide(cs_r[b] - cs_r[a], e_int, out=np.full(e_int.shape, 0.5), where=e_int > 0)
            e_rise[f0:f1] = e_tot[f0:f1] * share
            slope_f[f0:f1] = (cs_t[b] - cs_t[a]) / (b - a)
        # the probe sees disc position turns + probe offset (angle 0: the first mark, under the pin)
        turns = rotation.turns(t_d[ci]) + off_turns
        rev = np.floor(turns).astype(np.int64) - rev0
        rev = np.clip(rev, 0, n_rev - 1)
        starts = np.concatenate([[0], np.flatnonzero(np.diff(rev)) + 1])
        r = rev[starts]  # distinct revolutions of this core; the next core may continue the last one
        for j, sig in enumerate((sro[ci], macro[ci], micro[ci])):
            rev_max[j, r] = np.maximum(rev_max[j, r], np.maximum.reduceat(sig, starts))
            rev_min[j, r] = np.minimum(rev_min[j, r], np.minimum.reduceat(sig, starts))
        abin = ((turns % 1.0) * nb).astype(np.int64) % nb
        ang_q += np.bincount(abin, sro[ci], nb)
        ang_macro += np.bincount(abin, macro[ci], nb)
        ang_cnt += np.bincount(abin, minlength=nb)
        max_tan = max(max_tan, float(np.max(np.abs(tan_probe[ci]))))
        if f1 > f0:  # the disc position under the pin when the frame's sound left it
            centre = rotation.turns((np.arange(f0, f1) * hop + n / 2) / fs_ - s.acoustic_delay)
            # the component weights are cross powers of a frame and its predecessor: centred half a hop earlier
            frame_turns[f0:f1] = rotation.turns((np.arange(f0, f1) * hop + (n - hop) / 2) / fs_ - s.acoustic_delay)
            fb = ((centre % 1.0) * nb).astype(np.int64) % nb
            ang_e += np.bincount(fb, e_tot[f0:f1], nb)
            ang_ecnt += np.bincount(fb, minlength=nb)
        if progress is not None:
            progress(c1, total)

    cf, comp_f, comp_c = np.concatenate(comp_frame), np.concatenate(comp_freq), np.concatenate(comp_cross)
    frame_start = np.arange(n_frames) * hop / fs_
    events, ev_frames, ev_weights = link_components(
        cf, comp_f, np.concatenate(comp_level), np.concatenate(comp_pow),
        frame_start + half / fs_, hop / fs_, freq_tol=s.freq_tol, min_duration=s.min_duration,
    )
    squeal_f: float | None = None
    harmonics: list[dict[str, float]] = []
    rising: float | None = None
    corr: float | None = None
    if events:
        cover = np.zeros(n_frames + 1, np.int64)  # +1 at each event's first frame, -1 after its last
        np.add.at(cover, np.array([fr[0] for fr in ev_frames]), 1)
        np.add.at(cover, np.array([fr[-1] for fr in ev_frames]) + 1, -1)
        in_ev = np.cumsum(cover[:-1]) > 0
        tot = float(e_tot[in_ev].sum())
        rising = float(e_rise[in_ev].sum() / tot) if tot > 0 else None
        mag = np.sqrt(mic_spec_sum)
        k0 = lo + int(np.argmax(mic_spec_sum[lo:hi] * w_a))
        # the dominant line's phase advance over its own components only: the main lobe of another
        # squeal line less than two bins away must not pull it (VDA 303: several frequencies)
        squeal_f = float(refine_peak(mag, k0)) * fs_ / n
        c_line = comp_c[np.abs(comp_f - squeal_f) < 0.5 * fs_ / n].sum()
        if c_line != 0:
            squeal_f = float(phase_advance_freq(c_line, squeal_f, fs_, hop))
        for h in range(2, 6):
            kh = round(h * squeal_f * n / fs_)
            if kh + 3 >= hi:
                break
            kk = kh - 2 + int(np.argmax(mic_spec_sum[kh - 2:kh + 3]))
            p_h = mic_spec_sum[kk - 2:kk + 3].sum() / max(int(in_ev.sum()), 1)
            f_h = float(refine_peak(mag, kk)) * fs_ / n  # then its phase advance over all loud frames
            f_h = float(phase_advance_freq(mic_cross_sum[kk - _LOBE:kk + _LOBE + 1].sum(), f_h, fs_, hop))
            harmonics.append({"order": h, "frequency_hz": f_h,
                              "level_db": float(10 * np.log10(max(p_h, 1e-300) / P_REF**2))})
        # growth rate of the squeal envelope against the SRO slope, over the frames near squeal
        with np.errstate(divide="ignore"):
            ln_e = np.log(np.maximum(e_tot, 1e-300))
        growth = np.gradient(ln_e) * 0.5 * fs_ / hop
        sel = leq >= s.threshold_dba - 20
        if sel.sum() > 3 and np.std(growth[sel]) > 0 and np.std(slope_f[sel]) > 0:
            corr = float(np.corrcoef(growth[sel], slope_f[sel])[0, 1])

    phase: float | None = None
    if events and ang_ecnt.any() and ang_cnt.any():
        # squeal energy's circular mean angle against the macro run-out's crest (both in the disc's frame)
        angle_c = (np.arange(nb) + 0.5) * 2 * math.pi / nb
        e_mean = np.divide(ang_e, ang_ecnt, out=np.zeros(nb), where=ang_ecnt > 0)
        z = np.sum(e_mean * np.exp(1j * angle_c))
        q_mean = np.divide(ang_macro, ang_cnt, out=np.full(nb, -np.inf), where=ang_cnt > 0)
        crest = angle_c[int(np.argmax(q_mean))]
        phase = float(np.degrees(np.angle(z * np.exp(-1j * crest))))
        # each event's own place on the disc: its component's power per frame at the frame's disc angle
        rot = np.exp(-1j * crest)
        events = [replace(e, runout_phase_deg=float(np.degrees(np.angle(
                      np.sum(w * np.exp(2j * math.pi * frame_turns[fr])) * rot))))
                  for e, fr, w in zip(events, ev_frames, ev_weights, strict=True)]
    level = 10 * np.log10(np.maximum(level, 1e-300) / P_REF**2)
    peak = float(10 * np.log10(max(laf_max, 1e-300) / P_REF**2))
    t_frames = frame_start + n / 2 / fs_
    frames = xr.Dataset(
        {
            "level_dba": ("time", level, {"units": "dB(A)", "long_name":
                                          f"L_A{s.criteria.time_weighting[0].upper()} {s.band[0]:g}-{s.band[1]:g} Hz "
                                          "(max over the frame's interval)"}),
            "leq_dba": ("time", leq, {"units": "dB(A)", "long_name": "A-weighted band level of the Hann frame"}),
            "ridge_freq": ("time", ridge_f, {"units": "Hz", "long_name": "strongest line in the band"}),
            "band_power": ("time", e_tot, {"units": "Pa^2", "long_name": "mean square in the band (Hann frame)"}),
            "rising_power": ("time", e_rise, {"units": "Pa^2", "long_name": "band_power x share on rising run-out"}),
            "tan_theta": ("time", slope_f, {"units": "1", "long_name": "mean SRO slope tan(theta)"}),
            "rpm": ("time", 60.0 * rotation.rev_per_s(t_frames), {"units": "rpm", "long_name": "disc speed"}),
        },
        coords={"time": ("time", t_frames, {"units": "s", "long_name": "frame centre"})},
    )
    revs = np.flatnonzero(np.isfinite(rev_max[0]))
    revolutions = xr.Dataset(
        {f"{k}_p2p": ("revolution", rev_max[j, revs] - rev_min[j, revs], {"units": "m"})
         for j, k in enumerate(("sro", "macro", "micro"))},
        coords={"revolution": ("revolution", revs.astype(np.int64))},
    )
    angle = (np.arange(nb) + 0.5) * 2 * math.pi / nb
    with np.errstate(divide="ignore", invalid="ignore"):
        polar = xr.Dataset(
            {
                "angle_sro": ("angle", ang_q / ang_cnt, {"units": "m", "long_name": "mean SRO at angle"}),
                "angle_macro": ("angle", ang_macro / ang_cnt, {"units": "m"}),
                "angle_level_db": ("angle", 10 * np.log10(ang_e / ang_ecnt / P_REF**2),
                                   {"units": "dB", "long_name": "mean squeal-band level at angle"}),
            },
            coords={"angle": ("angle", angle, {"units": "rad", "long_name": "disc angle from recording start"})},
        )
    n_loud = max(1, int((level >= s.threshold_dba).sum()))
    spectrum = xr.Dataset(
        {
            "mic_power_squeal": ("freq", mic_spec_sum / n_loud, {"units": "Pa^2", "long_name": "mean during squeal"}),
        },
        coords={"freq": ("freq", freq, {"units": "Hz"})},
    )
    attrs = {"source": str(attrs.get("source", src.path)), "synthetic": bool(attrs.get("synthetic", False)),
             "max_tan_theta": max_tan, "surface_speed": v}
    return MeasurementResult(
        squeal_frequency_hz=squeal_f, harmonics=tuple(harmonics), events=tuple(events), rising_fraction=rising,
        growth_slope_correlation=corr, peak_dba=peak, runout_phase_deg=phase, duration_s=total / fs_, fs=fs_,
        settings=s,
        frames=frames, revolutions=revolutions, polar=polar, spectrum=spectrum, attrs=attrs,
    )
