"""Rig measurement analysis (paper §5): read, filter, find squeal, relate it to the run-out.

Start with :func:`analyze_recording`; try it on :func:`synthetic_recording` when you have no
data (synthetic recordings are labelled so wherever they appear).
"""

from .analysis import AnalysisSettings, MeasurementResult, analyze_recording
from .criteria import SETUPS, SquealCriteria, squeal_criteria, time_weighted_level
from .events import SquealEvent
from .filters import bandpass, butter_sos, highpass, lowpass, lowpass_decimated
from .readers import RecordingSource, open_recording, read_recording, recording_dataset
from .runout import incline, revolution_frequency, split_runout, surface_speed
from .spectral import a_weighting_db, phase_advance_freq, refine_peak, ridge, spectrogram
from .synthetic import SyntheticSource, synthetic_recording, synthetic_source
from .tacho import DiscAngle, angular_resample, synchronous_average, tacho_angle

__all__ = [
    "SETUPS",
    "AnalysisSettings",
    "DiscAngle",
    "MeasurementResult",
    "RecordingSource",
    "SquealCriteria",
    "SquealEvent",
    "SyntheticSource",
    "a_weighting_db",
    "analyze_recording",
    "angular_resample",
    "bandpass",
    "butter_sos",
    "highpass",
    "incline",
    "lowpass",
    "lowpass_decimated",
    "open_recording",
    "phase_advance_freq",
    "read_recording",
    "recording_dataset",
    "refine_peak",
    "revolution_frequency",
    "ridge",
    "spectrogram",
    "split_runout",
    "squeal_criteria",
    "surface_speed",
    "synchronous_average",
    "synthetic_recording",
    "synthetic_source",
    "tacho_angle",
    "time_weighted_level",
]
