"""Reports: rebuild the paper (``reproduce``) or the same analysis for your own rig."""

from .document import Comparison, FigureRef, Section, Table
from .reproduce import RecordingSpec, ReproduceResult, reproduce

__all__ = ["Comparison", "FigureRef", "RecordingSpec", "ReproduceResult", "Section", "Table", "reproduce"]
