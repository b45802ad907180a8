"""Signal processing of rig recordings, without squeal vocabulary: zero-phase filters
(:mod:`.filters`), spectra, A-weighting and peak refinement (:mod:`.spectral`), the disc's angle
from a tacho (:mod:`.tacho`)."""

from .filters import bandpass, butter_sos, highpass, lowpass, lowpass_decimated
from .spectral import P_REF, a_weighting_db, frame_power, phase_advance_freq, refine_peak, ridge, spectrogram
from .tacho import DiscAngle, angular_resample, synchronous_average, tacho_angle

__all__ = ["P_REF", "DiscAngle", "a_weighting_db", "angular_resample", "bandpass", "butter_sos", "frame_power",
           "highpass", "lowpass", "lowpass_decimated", "phase_advance_freq", "refine_peak", "ridge", "spectrogram",
           "synchronous_average", "tacho_angle"]
