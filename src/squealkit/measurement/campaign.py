"""Moved to :mod:`squealkit.campaign` (one campaign path); this path keeps working for one release."""

import warnings

from ..campaign.recordings import CampaignSummary, analyze_campaign, summarize_campaign

__all__ = ["CampaignSummary", "analyze_campaign", "summarize_campaign"]

warnings.warn("squealkit.measurement.campaign is deprecated; use squealkit.campaign (same meaning).",
              DeprecationWarning, stacklevel=2)
