"""Campaigns of recordings: the format (RECORDINGS.md), reading, writing, the dissertation's
field tables, synthetic campaigns written by the model, and imports of a continuous downhole
record with a surface log (``import_campaign``; ``flowstep`` writes a synthetic one).

``vadsim.campaigns`` (the old path) is this package.
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
from vadsim.campaigns.importing import ImportResult, import_campaign
from vadsim.campaigns.reading import load_campaign
from vadsim.campaigns.resolve import campaign_preset, load_any_campaign
from vadsim.campaigns.show import campaign_text
from vadsim.campaigns.stretches import StretchRules
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
    "ImportResult",
    "Sensor",
    "StretchRules",
    "campaign_preset",
    "campaign_text",
    "import_campaign",
    "load_any_campaign",
    "load_campaign",
    "save_campaign",
    "thesis_campaigns",
]
