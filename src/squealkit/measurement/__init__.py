"""Rig measurement analysis (paper §5): read, filter, find squeal, relate it to the run-out.

Start with :func:`analyze_recording`; try it on :func:`synthetic_recording` when you have no
data (synthetic recordings are labelled so wherever they appear).
"""

from .analysis import AnalysisSettings, MeasurementResult, analyze_recording
from .events import SquealEvent
from .filters import bandpass, butter_sos, highpass, lowpass, lowpass_decimated
from .readers import RecordingSource, open_recording, read_recording, recording_dataset
from .runout import incline, revolution_frequency, split_runout, surface_speed
from .spectral import a_weighting_db, phase_advance_freq, refine_peak, ridge, spectrogram
from .synthetic import SyntheticSource, synthetic_recording, synthetic_source

__all__ = [
    "AnalysisSettings",
    "MeasurementResult",
    "RecordingSource",
    "SquealEvent",
    "SyntheticSource",
    "a_weighting_db",
    "analyze_recording",
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
    "surface_speed",
    "synthetic_recording",
    "synthetic_source",
]
