"""The dissertation's published field tables as campaigns."""

from __future__ import annotations

from pathlib import Path

from vadsim.campaigns.format import Campaign
from vadsim.campaigns.reading import load_campaign

__all__ = ["THESIS_CAMPAIGNS", "thesis_campaigns"]

#: Keys of :func:`thesis_campaigns`, in the dissertation's order.
THESIS_CAMPAIGNS: tuple[str, ...] = ("7in-cde", "7in-rc", "9.5in-pdc")


def _package_data() -> Path:
    return Path(__file__).resolve().parent.parent / "data"


def thesis_campaigns() -> dict[str, Campaign]:
    """The dissertation's published field table as three summary-only campaigns.

    Each event carries ``features`` ``x1_peak_mean_g`` and, where the field table reports it,
    ``x1_impact_hz``; ``reference`` keeps the dissertation's own simulation of the event
    (``sim_peak_g``, ``sim_impact_hz`` when reported, ``sim_behaviour``), the behaviour seen in
    the field (``field_behaviour``), the printed excitation frequency (``f_exc_hz``), the test
    id (``test``) and, where the printed table is odd, a ``note``.

    Returns
    -------
    dict of str to Campaign
        Keys ``"7in-cde"`` (10 events), ``"7in-rc"`` (6), ``"9.5in-pdc"`` (12); a fresh copy
        on every call. Sensors: ``x1`` (dof 1) and ``x5`` (dof 5), 1024 Hz, 250 g.
    """
    base = _package_data() / "campaigns"
    return {key: load_campaign(base / key) for key in THESIS_CAMPAIGNS}
