"""From what a user names (a folder, a TOML file, ``thesis:7in-cde``) to a loaded campaign and
the preset its ``tool`` and ``bit`` stand for."""

from __future__ import annotations

import os
from pathlib import Path

from vadsim.campaigns.format import Campaign, CampaignError, excerpt
from vadsim.campaigns.reading import CampaignPathError, load_campaign, tool_file
from vadsim.campaigns.thesis import thesis_campaigns
from vadsim.model.presets import Preset, get_preset, load_preset_file

__all__ = ["campaign_preset", "load_any_campaign"]


def load_any_campaign(source: str | os.PathLike[str] | Campaign, *,
                      allow_outside: bool = False) -> Campaign:
    """A campaign from a folder or TOML file, or a shipped one: ``"thesis:7in-cde"``,
    ``"thesis:7in-rc"``, ``"thesis:9.5in-pdc"`` (the dissertation's field tables).

    ``allow_outside`` is passed to :func:`~vadsim.campaigns.reading.load_campaign`: whether
    the campaign may read files outside its folder. A Campaign given as such is returned as
    is, with its own ``allow_outside``.
    """
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
    return load_campaign(text, allow_outside=allow_outside)


def campaign_preset(campaign: Campaign) -> Preset:
    """The preset a campaign's ``tool`` and ``bit`` name (or its preset file).

    A preset file is looked up relative to ``campaign.root`` (the current folder when it is
    None) and must lie inside it, as for :func:`~vadsim.campaigns.reading.load_campaign`,
    unless ``campaign.allow_outside``.

    Raises
    ------
    CampaignError
        If ``tool`` names a file outside the campaign folder and that is not allowed.
    """
    tool = campaign.tool
    root = Path(campaign.root) if campaign.root is not None else Path.cwd()
    try:
        preset_file = tool_file(root, tool, campaign.allow_outside)
    except CampaignPathError as exc:
        raise CampaignError(f"campaign {excerpt(campaign.name)}: key tool: {exc}") from None
    if preset_file is not None:
        return load_preset_file(preset_file)
    return get_preset(tool, campaign.bit)
