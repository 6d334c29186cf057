"""The search stages' walk across a multistable cost (vadsim.fit.stages.capped_refine):
an event that lands on another response between two islands is a bounded miss on the
capped cost, so the walk crosses to the better island that a plain refinement cannot
reach."""

from __future__ import annotations

import numpy as np
from vadsim.fit.hypothesis import Hypothesis
from vadsim.fit.stages import CappedCosts, capped_refine, refine

HYP = Hypothesis(("contact_law",))
"""Two coordinates (a contact law's factor and shape); the cost is laid in unit coordinates."""

TARGET = np.array([0.75, 0.5])
"""Where the nine smooth events' cost vanishes: the truth's island."""


class Landscape:
    """Nine events with a smooth cost around TARGET and one that lands on another response
    (5,000 spreads) in a band of the first coordinate between the start and TARGET."""

    def __init__(self, band: tuple[float, float] = (0.45, 0.6)) -> None:
        self.hyp, self.band = HYP, band

    def event_rss(self, points):
        rows = []
        for p in points:
            u = HYP.unit(p)
            smooth = [(k + 1) * float(np.sum((u - TARGET) ** 2)) + 0.1 for k in range(9)]
            flip = 5000.0 if self.band[0] < u[0] < self.band[1] else 0.1
            rows.append([*smooth, flip])
        return np.array(rows)

    def rss(self, point) -> float:
        return float(self.event_rss([point])[0].sum())


def test_the_capped_walk_crosses_a_flipped_event_to_the_better_island():
    costs = Landscape()
    start = HYP.from_unit([0.44, 0.5])  # the edge of the first island, next to the band
    plain, _ = refine(costs, start, range(2), 200)
    assert plain >= costs.rss(HYP.from_unit([0.45, 0.5])) - 1e-9  # stays on its island
    rss, point = capped_refine(costs, start, 200)
    u = HYP.unit(point)
    assert u[0] > 0.6  # across the band
    assert rss < 1.0 + 1e-3 < 0.25 * plain  # the landscape's floor is 10 events x 0.1
    assert np.allclose(u, TARGET, atol=0.05)
    assert rss == costs.rss(point)  # the true cost, not the capped one


def test_the_cap_bounds_each_event_at_its_multiple_of_the_start_or_the_median_event():
    costs = Landscape()
    start = HYP.from_unit([0.44, 0.5])
    per_event = costs.event_rss([start])[0]
    caps = 3.0 * np.maximum(per_event, np.median(per_event))
    capped = CappedCosts(costs, caps)
    inside = HYP.from_unit([0.5, 0.5])
    assert costs.rss(inside) > 5000.0
    assert capped.rss(inside) <= float(caps.sum())
    assert capped.rss(start) == costs.rss(start)  # nothing capped where the walk starts


def test_without_a_band_the_capped_walk_ends_where_a_plain_refinement_does():
    costs = Landscape(band=(2.0, 3.0))  # no event ever flips
    start = HYP.from_unit([0.44, 0.5])
    plain, _ = refine(costs, start, range(2), 200)
    rss, point = capped_refine(costs, start, 200)
    assert rss <= plain * 1.05 + 1e-6
    assert np.allclose(HYP.unit(point), TARGET, atol=0.05)
