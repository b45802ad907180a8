"""Synthetic rig recordings with known truth (no public squeal recordings exist).

A recording mimics the pin-on-disc rig of paper §5: a microphone [Pa] and an eddy-current
probe [m] at 40 kHz, the disc at 900 rpm. The disc surface carries macro run-out (revolution
orders 1-2) and micro run-out (higher orders); the squeal at the coupled frequency (about
2388 Hz, paper §5.2) has an envelope whose logarithm grows in proportion to the run-out slope
``tan(theta)`` where the SRO rises and decays where it falls (paper §4, Fig. 4; eqs. 5-6:
the slope acts as extra friction), saturating at a limit-cycle level. Harmonics, a path from
disc vibration to the microphone, and seeded noise complete it. Every dataset is labelled
``synthetic = 1`` and carries its truth in attributes.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from .._validation import InputError, check_budget, check_memory, validate_fs, validate_plausible, validate_positive
from .formats import DEFAULT_BLOCK, RecordingSource, recording_dataset
from .squeal.criteria import P_REF, a_weighting_db, exponential_average

__all__ = ["SyntheticSource", "synthetic_recording"]

_N_ANGLE = 8192  # envelope samples per revolution
_TRUTH_BLOCK = 1 << 18  # points of the truth's level grid per block
#: A lower bound of the time to generate and write one sample of every channel [s] (work budget).
SECONDS_PER_SAMPLE = 1e-7


@dataclass(frozen=True)
class SyntheticSource:
    """A synthetic recording generated block by block (bounded memory for any duration).

    Same block interface as :class:`~squealkit.measurement.formats.readers.RecordingSource`.
    Build it with :func:`synthetic_source` (whose parameters these fields hold, in SI units);
    see the module docstring for the physics.

    Attributes
    ----------
    fs : float
        Sample rate [Hz].
    n_samples : int
        Samples per channel.
    rpm, rpm_end : float
        Disc speed [rev/min] at the start and, for a linear deceleration, at the end (else None).
    radius : float
        Probe radius [m].
    freq : float
        Squeal frequency [Hz].
    amp_pa : float
        Peak amplitude [Pa] of the saturated fundamental.
    harmonics : tuple of float
        Relative amplitudes of harmonics 2, 3, ...
    disp_squeal_m, noise_pa, noise_m : float
        Squeal on the displacement channel [m]; noise on the microphone [Pa] and displacement [m].
    seed : int or None
        Seed of the noise.
    sro_orders, sro_amps, sro_phases : ndarray
        Run-out revolution orders, amplitudes [m] and phases [rad].
    log_env : ndarray, shape (8192,)
        ``ln(envelope / amp_pa)`` over one revolution.
    probe_offset_deg, polarity, acoustic_delay, tacho_ppr
        Probe geometry [deg], probe polarity, pin-to-microphone delay [s], tacho pulses per revolution.
    channels : tuple of str
        ``("mic", "displacement", "tacho")``.
    units : dict
        ``Pa``, ``m`` and ``V``.
    path : Path
        ``<synthetic>``.
    fmt : str
        ``"synthetic"``.
    """

    fs: float
    n_samples: int
    rpm: float
    radius: float
    freq: float
    amp_pa: float
    harmonics: tuple[float, ...]
    disp_squeal_m: float
    noise_pa: float
    noise_m: float
    seed: int | None
    sro_orders: NDArray[np.float64] = field(repr=False)
    sro_amps: NDArray[np.float64] = field(repr=False)
    sro_phases: NDArray[np.float64] = field(repr=False)
    log_env: NDArray[np.float64] = field(repr=False)  # ln(envelope / amp_pa) over one revolution
    rpm_end: float | None = None  # speed at the end [rpm]: a linear deceleration from rpm (None: constant)
    probe_offset_deg: float = 0.0  # the probe sits this far upstream of the pin (sees the surface earlier)
    polarity: int = 1  # -1: the probe reads the run-out reversed
    acoustic_delay: float = 0.0  # [s] from the pin to the microphone
    tacho_ppr: int = 1  # pulses per revolution of the tacho channel
    channels: tuple[str, ...] = ("mic", "displacement", "tacho")
    units: dict[str, str] = field(default_factory=lambda: {"mic": "Pa", "displacement": "m", "tacho": "V"})
    path: Path = Path("<synthetic>")
    fmt: str = "synthetic"

    resolve = RecordingSource.resolve

    @property
    def duration(self) -> float:
        return self.n_samples / self.fs

    def turns(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Disc position [rev] at times ``t`` [s]: 0 at t = 0, constant speed or a linear deceleration.

        Parameters
        ----------
        t : ndarray
            Times [s].

        Returns
        -------
        ndarray, the shape of ``t``
        """
        f0 = self.rpm / 60.0
        if self.rpm_end is None:
            return t * f0
        f1 = self.rpm_end / 60.0
        return f0 * t + 0.5 * (f1 - f0) / self.duration * t * t

    def surface(self, turns: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """True run-out [m] and its slope tan(theta) at disc positions ``turns`` (revolutions).

        Parameters
        ----------
        turns : ndarray
            Disc positions [rev] from angle 0.

        Returns
        -------
        q, tan_theta : ndarray, the shape of ``turns``
            Run-out [m] and slope [1] at the probe radius.
        """
        ph = 2 * np.pi * np.multiply.outer(turns, self.sro_orders) + self.sro_phases
        q = np.sin(ph) @ self.sro_amps
        dq_dturn = np.cos(ph) @ (self.sro_amps * 2 * np.pi * self.sro_orders)
        return q, dq_dturn / (2 * np.pi * self.radius)

    def envelope(self, turns: NDArray[np.float64]) -> NDArray[np.float64]:
        """True squeal pressure amplitude [Pa] of the fundamental at ``turns``.

        Parameters
        ----------
        turns : ndarray
            Disc positions [rev] from angle 0.

        Returns
        -------
        ndarray, the shape of ``turns``
        """
        pos = (turns % 1.0) * _N_ANGLE
        grid = np.append(self.log_env, self.log_env[0])
        return self.amp_pa * np.exp(np.interp(pos, np.arange(_N_ANGLE + 1), grid))

    def block(self, start: int, stop: int) -> dict[str, NDArray[np.float64]]:
        """Samples ``start:stop`` of both channels (noise seeded by block start).

        Parameters
        ----------
        start, stop : int
            Sample range, ``0 <= start < stop <= n_samples``.

        Returns
        -------
        dict of str to ndarray
            ``mic`` [Pa], ``displacement`` [m] and ``tacho`` [V].
        """
        idx = np.arange(start, stop)
        t = idx / self.fs
        turns = self.turns(t)
        env = self.envelope(turns)
        grid = np.arange(_N_ANGLE + 1) / _N_ANGLE
        q_grid, _ = self.surface(grid)  # periodic surface, interpolated (error < 1e-3 of the micro part)
        q = self.polarity * np.interp((turns + self.probe_offset_deg / 360.0) % 1.0, grid, q_grid)
        ph = 2 * np.pi * self.freq * t
        tone = np.sin(ph)
        for h, a in enumerate(self.harmonics, start=2):
            tone = tone + a * np.sin(h * ph + 0.3 * h)
        rng = np.random.default_rng([self.seed if self.seed is not None else 0, start])
        if self.acoustic_delay:
            te = t - self.acoustic_delay
            ph_e = 2 * np.pi * self.freq * te
            tone_e = np.sin(ph_e)
            for h, a in enumerate(self.harmonics, start=2):
                tone_e = tone_e + a * np.sin(h * ph_e + 0.3 * h)
            mic = self.envelope(self.turns(te)) * tone_e * (te >= 0)
        else:
            mic = env * tone
        mic = mic + self.noise_pa * rng.standard_normal(idx.size)
        disp = q + self.disp_squeal_m * (env / self.amp_pa) * np.sin(ph - 0.5) \
            + self.noise_m * rng.standard_normal(idx.size)
        # tacho: a 5 V pulse per mark, 5 % of a revolution wide (1 per revolution) or 50 % duty (encoders)
        width = 0.05 if self.tacho_ppr == 1 else 0.5
        tacho = 5.0 * (((turns * self.tacho_ppr) % 1.0) < width)
        return {"mic": mic, "displacement": disp, "tacho": tacho}

    def iter_blocks(self, channels: Sequence[str | int], *, block: int = DEFAULT_BLOCK
                    ) -> Iterator[tuple[int, dict[str, NDArray[np.float64]]]]:
        """Yield ``(start_sample, {name: samples})`` in order, as :meth:`RecordingSource.iter_blocks`.

        Parameters
        ----------
        channels : sequence of str or int
            Channel names or indices (``mic``, ``displacement``, ``tacho``).
        block : int, optional
            Samples per block.

        Yields
        ------
        start_sample : int
        data : dict of str to ndarray
        """
        names = [self.resolve(c) for c in channels]
        for s in range(0, self.n_samples, block):
            data = self.block(s, min(self.n_samples, s + block))
            yield s, {n: data[n] for n in names}

    def truth(self, threshold_dba: float = 70.0, merge_gap: float = 0.01, time_constant: float = 0.125
              ) -> dict[str, object]:
        """Known answers: frequency, event intervals above ``threshold_dba``, rising fraction, peak level.

        Levels are those of the noise-free squeal (fundamental and harmonics), A-weighted and
        time weighted with ``time_constant`` [s] (IEC 61672-1 Fast: 0.125), as a sound level
        meter shows them.

        Parameters
        ----------
        threshold_dba : float, default 70.0
            Squeal threshold [dB(A)].
        merge_gap : float, default 0.01
            Gaps [s] shorter than this join two events into one.
        time_constant : float, default 0.125
            Exponential time constant [s] of the level.

        Returns
        -------
        dict
            ``frequency_hz``, ``event_starts_s``, ``event_ends_s``, ``rising_fraction``,
            ``threshold_dba``, ``runout_phase_deg``, ``peak_dba`` (None where there is no squeal).
        """
        step = 8
        dt = step / self.fs
        gain = 10 ** (a_weighting_db(self.freq) / 10) + sum(
            a * a * 10 ** (a_weighting_db(h * self.freq) / 10) for h, a in enumerate(self.harmonics, start=2))
        # block by block over the level grid (memory bounded for any duration); the meter's state
        # and the open event carry over from one block to the next
        idx_all = np.arange(0, self.n_samples, step)
        n_grid = idx_all.size
        del idx_all
        ms_last, on_last, peak = 0.0, False, -math.inf
        e_sum = e_rising = 0.0
        starts_l: list[NDArray[np.float64]] = []
        ends_l: list[NDArray[np.float64]] = []
        for g0 in range(0, n_grid, _TRUTH_BLOCK):
            t = np.arange(g0, min(n_grid, g0 + _TRUTH_BLOCK)) * step / self.fs
            turns = self.turns(t)
            env = self.envelope(turns)
            _, tan_t = self.surface(turns)
            ms = exponential_average(env**2 / 2 * gain, dt, time_constant, initial=ms_last)
            ms_last = float(ms[-1])
            level = 10 * np.log10(np.maximum(ms, 1e-300) / P_REF**2)
            on = level >= threshold_dba
            edges = np.flatnonzero(np.diff(np.concatenate([[on_last], on]).astype(np.int8)))
            rises = edges[on[edges]]  # the first sample of an event
            falls = edges[~on[edges]]  # the first sample after one (as the whole-record edges before)
            starts_l.append(t[rises])
            ends_l.append(t[falls])
            on_last = bool(on[-1])
            e = env**2 * on
            e_sum += float(e.sum())
            e_rising += float((e * (tan_t > 0)).sum())
            if on.any():
                peak = max(peak, float(level.max()))
        t_last = (n_grid - 1) * step / self.fs
        starts = np.concatenate(starts_l)
        ends = np.concatenate([*ends_l, [t_last]] if on_last else ends_l)
        if starts.size > 1:  # gaps shorter than merge_gap are one event
            keep = np.concatenate([[True], starts[1:] - ends[:-1] > merge_gap])
            ends = np.append(ends[np.flatnonzero(keep)[1:] - 1], ends[-1])
            starts = starts[keep]
        any_on = starts.size > 0
        rising = e_rising / e_sum if e_sum > 0 else None
        # where the squeal sounds against the macro run-out's crest (orders <= 10), in the disc's frame
        ang = (np.arange(_N_ANGLE) + 0.5) / _N_ANGLE
        macro = self.sro_orders <= 10
        q_macro = np.sin(2 * np.pi * np.multiply.outer(ang, self.sro_orders[macro]) + self.sro_phases[macro]) \
            @ self.sro_amps[macro]
        z = np.sum(self.envelope(ang) ** 2 * np.exp(2j * np.pi * ang))
        phase = float(np.degrees(np.angle(z * np.exp(-2j * np.pi * ang[np.argmax(q_macro)]))))
        return {"frequency_hz": self.freq if any_on else None, "event_starts_s": starts, "event_ends_s": ends,
                "rising_fraction": rising, "threshold_dba": threshold_dba,
                "runout_phase_deg": phase if any_on else None,
                "peak_dba": peak if any_on else None}


def synthetic_source(
    *,
    duration: float = 2.0,
    fs: float = 40000.0,
    rpm: float = 900.0,
    rpm_end: float | None = None,
    radius: float = 0.05,
    freq: float = 2388.0,
    level_dba: float = 90.0,
    squeal_on: str = "rising",
    growth_rate: float = 1500.0,
    decay_rate: float = 3000.0,
    dynamic_range_db: float = 60.0,
    macro_amps: Sequence[float] = (20e-6, 5e-6),
    micro_amp: float = 0.1e-6,
    micro_orders: tuple[int, int] = (20, 40),
    harmonics: Sequence[float] = (0.05, 0.02),
    disp_squeal_m: float = 0.5e-6,
    noise_pa: float = 2e-3,
    noise_m: float = 0.05e-6,
    seed: int | None = None,
    rng: np.random.Generator | None = None,
    probe_offset_deg: float = 0.0,
    polarity: int = 1,
    acoustic_delay: float = 0.0,
    tacho_ppr: int = 1,
) -> SyntheticSource:
    """Build a :class:`SyntheticSource`: a synthetic recording generated block by block.

    Parameters
    ----------
    duration : float, default 2.0
        Length [s] (as the paper's steady drag).
    fs : float, default 40000.0
        Sample rate [Hz] (paper: 40 kHz).
    rpm : float, default 900.0
        Disc speed [rev/min] (paper: 900).
    rpm_end : float, optional
        Speed at the end [rev/min]: the disc slows down linearly from ``rpm`` (a decelerating
        stop). The squeal envelope and the run-out are functions of the disc angle.
    radius : float, default 0.05
        Probe (and pin) radius [m].
    freq : float, default 2388.0
        Squeal frequency [Hz] (paper: about 2388 Hz, the coupled pin/disc mode); it and its
        harmonics must lie below ``fs / 2``.
    level_dba : float, default 90.0
        A-weighted level of the saturated squeal's fundamental [dB(A)].
    squeal_on : {"rising", "falling", "none"}, default "rising"
        On which run-out stage the squeal grows (the paper: rising).
    growth_rate, decay_rate : float, default 1500.0, 3000.0
        Largest growth rate of the envelope on the unstable stage and decay rate on the
        stable stage [1/s].
    dynamic_range_db : float, default 60.0
        How far below the saturated level the envelope may fall [dB].
    macro_amps : sequence of float, default (20e-6, 5e-6)
        Run-out amplitudes [m] of revolution orders 1, 2, ...
    micro_amp : float, default 0.1e-6
        Largest amplitude [m] of a micro run-out order (each is drawn in 0.3-1 times it).
    micro_orders : (int, int), default (20, 40)
        First and last revolution order of the micro run-out (inclusive).
    harmonics : sequence of float, default (0.05, 0.02)
        Amplitudes of harmonics 2, 3, ... relative to the fundamental.
    disp_squeal_m : float, default 0.5e-6
        Amplitude [m] of the squeal vibration on the displacement channel at full envelope.
    noise_pa, noise_m : float, default 2e-3, 0.05e-6
        Standard deviation of white noise on the microphone [Pa] and displacement [m] channels.
    seed : int, optional
        Seed of the run-out phases (unless ``rng`` is given) and of the noise.
    rng : numpy.random.Generator, optional
        Generator of the run-out phases and micro amplitudes (default: from ``seed``).
    probe_offset_deg : float, default 0.0
        The probe sits this many degrees upstream of the pin: it sees each point of the
        surface that much rotation before the pin does.
    polarity : {1, -1}, default 1
        -1: the probe reads the run-out reversed.
    acoustic_delay : float, default 0.0
        Delay [s] of the sound from the pin to the microphone, >= 0.
    tacho_ppr : int, default 1
        Pulses per revolution of the ``tacho`` channel (5 V pulses; the first edge of a
        once-per-revolution tacho is the disc's angle 0).

    Returns
    -------
    SyntheticSource
        The recording, with the block interface of
        :class:`~squealkit.measurement.formats.readers.RecordingSource` and its known truth
        (:meth:`SyntheticSource.truth`).

    Raises
    ------
    InputError
        On a non-positive duration, speed, radius or frequency, a squeal above ``fs / 2``,
        or an unknown ``squeal_on``.
    """
    fs = validate_fs(fs)
    duration = validate_positive("duration", duration)
    validate_positive("rpm", rpm)
    if rpm_end is not None:
        validate_positive("rpm_end", rpm_end)
    if polarity not in (1, -1):
        raise InputError(f"Parameter polarity={polarity!r} must be 1 or -1.")
    validate_positive("acoustic_delay", acoustic_delay, allow_zero=True)
    if not isinstance(tacho_ppr, int) or tacho_ppr < 1:
        raise InputError(f"Parameter tacho_ppr={tacho_ppr!r} must be a whole number >= 1.")
    extra = dict(rpm_end=None if rpm_end is None else float(rpm_end), probe_offset_deg=float(probe_offset_deg),
                 polarity=int(polarity), acoustic_delay=float(acoustic_delay), tacho_ppr=tacho_ppr)
    validate_positive("radius", radius)
    validate_positive("freq", freq)
    if freq * (len(harmonics) + 1) >= fs / 2:
        raise InputError(f"Squeal freq={freq!r} Hz and its harmonics must lie below fs/2 = {fs / 2:g} Hz.")
    if squeal_on not in ("rising", "falling", "none"):
        raise InputError(f"Parameter squeal_on={squeal_on!r} must be 'rising', 'falling' or 'none'.")
    level_dba = validate_plausible("level_dba", level_dba)
    check_budget(f"A synthetic recording of {duration:g} s at {fs:g} Hz", seconds=duration * fs * SECONDS_PER_SAMPLE,
                 hint="Use a shorter duration or a lower fs.")
    n_samples = round(duration * fs)
    if n_samples < 2:
        raise InputError(f"Parameter duration={duration!r} s gives fewer than 2 samples at fs={fs!r}.")
    if rng is None:
        rng = np.random.default_rng(seed)
    lo, hi = micro_orders
    orders = np.concatenate([np.arange(1, len(macro_amps) + 1), np.arange(lo, hi + 1)]).astype(float)
    n_micro = hi - lo + 1
    amps = np.concatenate([np.asarray(macro_amps, float), micro_amp * rng.uniform(0.3, 1.0, n_micro)])
    phases = rng.uniform(0, 2 * np.pi, orders.size)
    amp_pa = math.sqrt(2) * P_REF * 10 ** ((level_dba - float(a_weighting_db(freq))) / 20)
    src = SyntheticSource(fs, n_samples, float(rpm), float(radius), float(freq), amp_pa, tuple(harmonics),
                          disp_squeal_m, noise_pa, noise_m, seed, orders, amps, phases, np.zeros(_N_ANGLE), **extra)
    # envelope: d ln A / dt = growth_rate * s where s = +-tan(theta) / max|tan(theta)| > 0 (unstable
    # stage), decay_rate * s where s < 0 (stable stage: damping wins), clipped to [-range, 0]
    turns = np.arange(_N_ANGLE) / _N_ANGLE
    _, tan_t = src.surface(turns)
    if squeal_on == "none":
        log_env = np.full(_N_ANGLE, -50.0)
    else:
        sign = 1.0 if squeal_on == "rising" else -1.0
        drive = sign * tan_t / np.max(np.abs(tan_t))
        rate = np.where(drive > 0, growth_rate * drive, decay_rate * drive)
        dt = 60.0 / rpm / _N_ANGLE
        floor = -dynamic_range_db / 20 * math.log(10)
        x, log_env = 0.0, np.empty(_N_ANGLE)
        for _ in range(4):  # settle to the periodic solution
            for i in range(_N_ANGLE):
                x = min(0.0, max(floor, x + rate[i] * dt))
                log_env[i] = x
    return SyntheticSource(fs, n_samples, float(rpm), float(radius), float(freq), amp_pa, tuple(harmonics),
                           disp_squeal_m, noise_pa, noise_m, seed, orders, amps, phases, log_env, **extra)


def synthetic_recording(*, threshold_dba: float = 70.0, **kwargs) -> xr.Dataset:
    """A synthetic pin-on-disc recording with known truth, labelled ``synthetic``.

    Parameters
    ----------
    **kwargs
        The parameters of :func:`synthetic_source` (``duration``, ``fs``, ``rpm``, ``rpm_end``,
        ``radius``, ``freq``, ``level_dba``, ``squeal_on``, ``growth_rate``, ``decay_rate``,
        run-out, noise, ``seed``/``rng``, probe geometry and ``tacho_ppr``), with their defaults.
    threshold_dba : float
        Threshold for the truth's event intervals.

    Returns
    -------
    xarray.Dataset
        Channels ``mic`` [Pa], ``displacement`` [m] and ``tacho`` [V] on ``time`` [s]; attrs ``synthetic=1``,
        ``fs`` and ``truth_*`` (frequency, event starts/ends, rising fraction, run-out
        ``truth_sro``-free summary).

    Examples
    --------
    >>> rec = synthetic_recording(duration=0.5, seed=1)
    >>> rec.attrs["synthetic"], rec["mic"].attrs["units"]
    (1, 'Pa')
    """
    src = synthetic_source(**kwargs)
    check_memory(8.0 * 16 * src.n_samples, f"A synthetic recording of {src.n_samples} samples",
                 "Write it block by block: write_recording_blocks(source.iter_blocks(...)) (CLI: squealkit synth).")
    attrs = synthetic_attrs(src, threshold_dba, kwargs.get("squeal_on", "rising"))
    # the blocks squealkit synth writes (noise is seeded per block): file and dataset agree
    parts = [data for _, data in src.iter_blocks(src.channels)]
    data = {c: np.concatenate([p[c] for p in parts]) for c in src.channels}
    return recording_dataset(data, src.fs, src.units, attrs)


def synthetic_attrs(src: SyntheticSource, threshold_dba: float = 70.0, squeal_on: str = "rising") -> dict:
    """The attributes of a synthetic recording: the SYNTHETIC label, its settings and its truth.

    Computed block by block (bounded memory), so that a long recording can be written as it is
    generated (:func:`~squealkit.measurement.formats.writers.write_recording_blocks`).

    Parameters
    ----------
    src : SyntheticSource
        The recording, from :func:`synthetic_source`.
    threshold_dba : float
        Threshold of the truth's event intervals [dB(A)].
    squeal_on : str
        The run-out stage the squeal grows on (recorded as given to :func:`synthetic_source`).

    Returns
    -------
    dict
        ``synthetic = 1``, ``title``, settings and ``truth_*`` attributes (see :func:`synthetic_recording`).
    """
    tr = src.truth(threshold_dba)
    return {
        "synthetic": 1,
        "title": "SYNTHETIC pin-on-disc recording (squealkit), not a measurement",
        "source": "squealkit.measurement.synthetic",
        "rpm": src.rpm,
        "radius": src.radius,
        "seed": -1 if src.seed is None else int(src.seed),
        "squeal_on": squeal_on,
        "truth_frequency_hz": float("nan") if tr["frequency_hz"] is None else float(tr["frequency_hz"]),
        "truth_event_starts_s": np.asarray(tr["event_starts_s"]),
        "truth_event_ends_s": np.asarray(tr["event_ends_s"]),
        "truth_rising_fraction": float("nan") if tr["rising_fraction"] is None else tr["rising_fraction"],
        "truth_runout_phase_deg": float("nan") if tr["runout_phase_deg"] is None else tr["runout_phase_deg"],
        "truth_threshold_dba": threshold_dba,
        "rpm_end": float("nan") if src.rpm_end is None else src.rpm_end,
        "probe_offset_deg": src.probe_offset_deg,
        "polarity": src.polarity,
        "acoustic_delay": src.acoustic_delay,
        "tacho_ppr": src.tacho_ppr,
    }

