"""Rig measurement analysis (paper §5): read, filter, find squeal, relate it to the run-out.

Start with :func:`analyze_recording`; try it on :func:`synthetic_recording` when you have no
data (synthetic recordings are labelled so wherever they appear).
"""

from .analysis import (
    AnalysisSettings,
    MeasurementResult,
    analyze_recording,
    figure_signals,
    measurement_signals,
    squeal_views,
)
from .formats import RecordingSource, open_recording, read_recording, recording_dataset
from .signal.filters import bandpass, butter_sos, highpass, lowpass, lowpass_decimated
from .signal.spectral import a_weighting_db, phase_advance_freq, refine_peak, ridge, spectrogram
from .signal.tacho import DiscAngle, angular_resample, synchronous_average, tacho_angle
from .squeal.criteria import SETUPS, SquealCriteria, squeal_criteria, time_weighted_level
from .squeal.events import SquealEvent
from .squeal.runout import incline, revolution_frequency, split_runout, surface_speed
from .synthetic import SyntheticSource, synthetic_recording, synthetic_source

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
    "figure_signals",
    "highpass",
    "incline",
    "lowpass",
    "lowpass_decimated",
    "measurement_signals",
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
    "squeal_views",
    "surface_speed",
    "synchronous_average",
    "synthetic_recording",
    "synthetic_source",
    "tacho_angle",
    "time_weighted_level",
]

#: Modules that moved into formats/, signal/ and squeal/ (issue 28): the old paths are shims for one release.
_MOVED = ("criteria", "events", "filters", "readers", "runout", "spectral", "tacho", "writers")


def __getattr__(name: str):
    """``squealkit.measurement.filters`` and the other moved modules, imported (with their
    DeprecationWarning) when first named."""
    if name in _MOVED:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
