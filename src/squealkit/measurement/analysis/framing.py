"""Framing step: the block source, the plan (frames, bins, run-out grid, margins), the windows and the accumulators."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy import signal

from ..._threads import thread_limit
from ..._validation import InputError, validate_fs, validate_positive
from ..formats import DEFAULT_BLOCK, RecordingSource, open_recording
from ..formats._common import _TimeFit, _to_si
from ..signal.spectral import P_REF, a_weighting_db
from ..signal.tacho import ConstantSpeed, read_tacho
from ..squeal.criteria import EDGE_HZ
from ..squeal.runout import revolution_frequency
from .settings import AnalysisSettings


class _DatasetSource:
    """Block iteration over an in-memory Dataset (same interface as RecordingSource)."""

    def __init__(self, ds: xr.Dataset, fs: float | None):
        self.ds = ds
        if fs is None:
            if "fs" in ds.attrs:
                fs = ds.attrs["fs"]
            elif "time" in ds.coords and ds.sizes["time"] > 1:
                # the readers' estimate: least squares over the whole time coordinate
                fit = _TimeFit()
                fit.add(ds["time"].values)
                fs = float(np.round(1.0 / fit.result()[0], 6))
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


def _read_block(src: Any, plan: _Plan) -> int:
    """Samples per block to read from ``src``: an in-memory recording is one block (windows are views
    of it); a file is read in blocks of four cores, so most windows are views too (copying every window
    cost about 7 % of the analysis); a generated source in blocks of one core (its temporaries scale
    with the block: bounded memory first)."""
    if isinstance(src, _DatasetSource):
        return plan.total
    return max((4 if isinstance(src, RecordingSource) else 1) * plan.core, DEFAULT_BLOCK)
