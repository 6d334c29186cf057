"""From what a user names (a folder, a TOML file, ``thesis:7in-cde``) to a loaded campaign and
the preset its ``tool`` and ``bit`` stand for."""

from __future__ import annotations

import os
from pathlib import Path

from vadsim.campaigns.format import Campaign, excerpt
from vadsim.campaigns.reading import load_campaign
from vadsim.campaigns.thesis import thesis_campaigns
from vadsim.model.presets import Preset, get_preset, load_preset_file

__all__ = ["campaign_preset", "load_any_campaign"]


def load_any_campaign(source: str | os.PathLike[str] | Campaign) -> Campaign:
    """A campaign from a folder or TOML file, or a shipped one: ``"thesis:7in-cde"``,
    ``"thesis:7in-rc"``, ``"thesis:9.5in-pdc"`` (the dissertation's field tables)."""
    if isinstance(source, Campaign):
        return source
    text = str(source)
    if text.startswith("thesis:"):
        key = text.split(":", 1)[1]
        shipped = thesis_campaigns()
        if key not in shipped:
            raise ValueError(f"unknown shipped campaign {excerpt(text)}: choose thesis:"
                             + ", thesis:".join(shipped))
        return shipped[key]
    return load_campaign(text)


def campaign_preset(campaign: Campaign) -> Preset:
    """The preset a campaign's ``tool`` and ``bit`` name (or its preset file)."""
    tool = campaign.tool
    if campaign.root is not None and (Path(campaign.root) / tool).is_file():
        return load_preset_file(Path(campaign.root) / tool)
    if Path(tool).is_file():
        return load_preset_file(tool)
    return get_preset(tool, campaign.bit)
