"""The settings of an analysis: criteria and processing options, checked against each other and the sample rate."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..._validation import PLAUSIBLE, InputError, validate_plausible, validate_positive
from ..squeal.criteria import SquealCriteria, squeal_criteria
from ..squeal.events import DEFAULT_MIN_TNR_DB


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
