"""What a campaign holds, as text: ``vadsim campaign show``.

Why this module exists: an import (or a campaign written by hand) should be checked before a
diagnosis that takes minutes: the events with their flows, WOB and durations, the sensors
with their degree of freedom, rate and range, and how many samples each sensor clipped.
"""

from __future__ import annotations

import textwrap

import numpy as np

from vadsim.campaigns.format import Campaign
from vadsim.model.result import DOF_NAMES

__all__ = ["campaign_text"]


def _sensor_lines(campaign: Campaign) -> list[str]:
    lines = [f"sensors ({len(campaign.sensors)}):",
             f"  {'name':<8} {'dof':>3} {'on':<8} {'rate Hz':>8} {'range g':>8} "
             f"{'low-pass Hz':>11}"]
    for s in campaign.sensors.values():
        lowpass = f"{s.lowpass_hz:g}" if s.lowpass_hz is not None else "none"
        lines.append(f"  {s.name:<8} {s.dof:>3} {DOF_NAMES[s.dof - 1]:<8} {s.rate_hz:>8g} "
                     f"{s.range_g:>8g} {lowpass:>11}")
    return lines


def _event_lines(campaign: Campaign) -> list[str]:
    names = list(campaign.sensors)
    clip_head = "clipped samples (" + ", ".join(names) + ")"
    lines = [f"events ({len(campaign.events)}):",
             f"  {'event':<8} {'flow gal/min':>12} {'WOB klbf':>8} {'duration s':>10} "
             f"{'samples':>8}  {clip_head}"]
    total = 0.0
    for ev in campaign.events:
        if ev.data is not None:
            n = len(ev.data)
            rate = next(iter(campaign.sensors.values())).rate_hz
            duration = n / rate
            total += duration
            clips = ", ".join(str(int(np.count_nonzero(ev.clipped.get(s, []))))
                              for s in names)
            size = f"{duration:10.1f} {n:8d}  {clips}"
        else:
            size = f"{'-':>10} {'-':>8}  summary only: " + ", ".join(
                f"{k} = {v:g}" for k, v in ev.features.items())
        lines.append(f"  {ev.id:<8} {ev.flow_gpm:12.1f} {ev.wob_klbf:8.2f} {size}")
    if total:
        flows = [ev.flow_gpm for ev in campaign.events]
        lines.append(f"  {total:.1f} s of samples; flows {min(flows):g} to {max(flows):g} "
                     f"gal/min")
    return lines


def campaign_text(campaign: Campaign) -> str:
    """The campaign as a few aligned tables: what it is, its sensors and its events.

    Clipped samples are those at or beyond the sensor's range (RECORDINGS.md): their values
    are not to be trusted, and an event with many of them says the sensor saturated.
    """
    lines = [f"campaign: {campaign.name}",
             f"  tool {campaign.tool}, bit {campaign.bit}"
             + (f"; folder {campaign.root}" if campaign.root is not None else "")]
    if campaign.description:
        lines.append(textwrap.fill(campaign.description, 96, initial_indent="  ",
                                   subsequent_indent="  "))
    lines += _sensor_lines(campaign) + _event_lines(campaign)
    clipped = sum(ev.n_clipped for ev in campaign.events)
    if clipped:
        lines.append(f"note: {clipped} samples are clipped (at the sensor's range): their "
                     f"values are a floor on the real ones, and features using them are "
                     f"flagged")
    return "\n".join(lines)
