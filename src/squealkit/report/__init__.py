"""Reports: rebuild the paper (``reproduce``) or the same analysis for your own rig."""

from .document import Comparison, FigureRef, Section, Table
from .reproduce import RecordingSpec, ReproduceResult, reproduce
from .settings import ReportSettings

__all__ = ["Comparison", "FigureRef", "RecordingSpec", "ReportSettings", "ReproduceResult", "Section", "Table",
           "reproduce"]
