"""Brake noise campaigns: a test matrix of applications, analysed into a DuckDB store, summarised.

Start with :func:`run_campaign`; try it on :func:`synthetic_campaign` when you have no data. A list of
recordings without a matrix: :func:`analyze_campaign` (the same analysis task, summarised in memory).
"""

from .matrix import Application, read_matrix
from .recordings import CampaignSummary, analyze_campaign, summarize_campaign
from .run import run_campaign
from .store import CampaignStore
from .summary import campaign_summary, third_octave_bands
from .synthetic import synthetic_campaign

__all__ = ["Application", "CampaignStore", "CampaignSummary", "analyze_campaign", "campaign_summary", "read_matrix",
           "run_campaign", "summarize_campaign", "synthetic_campaign", "third_octave_bands"]
