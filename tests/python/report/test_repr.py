"""Notebook reprs: a result shows what it holds (a summary table), not an object address."""

from __future__ import annotations

import html

import vadsim
from vadsim.campaigns import load_any_campaign


def test_a_run_shows_its_operating_point_labels_and_solver_work():
    r = vadsim.simulate("7in-cde", 200, cycles=40, analyse_cycles=20)
    page = html.unescape(r._repr_html_())
    assert page.startswith("<div>") and "7in-cde" in page
    assert "200 gal/min" in page
    assert f"{r.scenario}: {vadsim.signals.labels.regime_name(r.scenario)}" in page
    assert f"{r.stats['steps']} steps" in page


def test_a_campaign_lists_every_event_with_its_flow():
    camp = load_any_campaign("thesis:7in-cde")
    page = html.unescape(camp._repr_html_())
    assert camp.name in page
    for ev in camp.events:
        assert f">{ev.id}<" in page
        assert f">{ev.flow_gpm:g}<" in page
    assert f">{len(camp.events)}<" in page  # the event count
