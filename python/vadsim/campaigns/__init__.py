"""Campaigns of recordings: the format (RECORDINGS.md), reading, writing, the dissertation's
field tables, and synthetic campaigns written by the model.

``vadsim.recordings`` (the old path) is this package.
"""

from vadsim.campaigns.format import (
    FEATURES,
    KNOWN_BITS,
    KNOWN_TOOLS,
    Campaign,
    CampaignError,
    ClippedSamplesWarning,
    Event,
    Sensor,
)
from vadsim.campaigns.reading import load_campaign
from vadsim.campaigns.resolve import campaign_preset, load_any_campaign
from vadsim.campaigns.thesis import THESIS_CAMPAIGNS, thesis_campaigns
from vadsim.campaigns.writing import save_campaign

__all__ = [
    "FEATURES",
    "KNOWN_BITS",
    "KNOWN_TOOLS",
    "THESIS_CAMPAIGNS",
    "Campaign",
    "CampaignError",
    "ClippedSamplesWarning",
    "Event",
    "Sensor",
    "campaign_preset",
    "load_any_campaign",
    "load_campaign",
    "save_campaign",
    "thesis_campaigns",
]
