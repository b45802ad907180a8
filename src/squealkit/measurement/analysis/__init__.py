"""End-to-end analysis of a rig recording, in named steps that each return a value.

:func:`analyze_recording` (``recording``) streams the recording in windows through the steps:
``framing`` (the plan, the windows, the accumulators), ``components`` (band level, frame spectra,
tonal components), ``runout_link`` (run-out split, its tie to the sound, each event's place on the
disc), ``lines`` (events, dominant line and harmonics) and ``assemble`` (the labelled
:class:`MeasurementResult`, ``result``). ``views`` derives from a result and its recording
everything the figures draw (:func:`measurement_signals`), so plotting only draws.
"""

from .recording import analyze_recording
from .result import MeasurementResult
from .settings import AnalysisSettings
from .views import figure_signals, measurement_signals, squeal_views

__all__ = ["AnalysisSettings", "MeasurementResult", "analyze_recording", "figure_signals", "measurement_signals",
           "squeal_views"]
