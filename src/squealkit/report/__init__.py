"""Reports: rebuild the paper (``reproduce``) or the same analysis for your own rig."""

from .document import Comparison, FigureRef, Section, Table
from .reproduce import ReproduceResult, reproduce

__all__ = ["Comparison", "FigureRef", "ReproduceResult", "Section", "Table", "reproduce"]
