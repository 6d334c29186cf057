"""The profile across islands (vadsim.fit.interval_profile) on costs whose profile
intervals are known exactly: a tilted valley, and the same valley with one event that lands on
another response in a band between the best point's island and the rest of the interval."""

from __future__ import annotations

import numpy as np
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.hypothesis import Hypothesis
from vadsim.fit.interval_profile import profile_intervals, ridge_cost
from vadsim.fit.interval_walk import walk_intervals
from vadsim.fit.intervals import profile_limit

HYP = Hypothesis(("contact_law",))
"""Two coordinates (a contact law's factor and shape); the cost is laid in unit coordinates."""

OPTIMUM = np.array([0.5, 0.5])
EVENTS = 10
FLOOR = 1.0
"""Each event's cost at the optimum."""

M = np.array([[4.0e4, -3.96e4], [-3.96e4, 4.0e4]])
"""The smooth part's curvature (unit coordinates): the two trade off along a narrow valley,
so each alone is pinned to a hundredth of the box while its profile spans a tenth."""


class Valley:
    """Nine events share ``d' M d`` around the optimum; the tenth (and the ninth, with
    ``flipping=2``) lands on another response (5,000 spreads) where the first coordinate lies
    in ``band``."""

    def __init__(self, band: tuple[float, float] = (2.0, 3.0), flipping: int = 1) -> None:
        self.hyp, self.band, self.asked, self.flipping = HYP, band, 0, flipping

    def event_rss(self, points) -> np.ndarray:
        self.asked += len(points)
        rows = []
        for p in points:
            u = HYP.unit(p)
            d = u - OPTIMUM
            smooth = FLOOR + float(d @ M @ d) / 9.0
            flip = 5000.0 if self.band[0] < u[0] < self.band[1] else FLOOR
            rows.append([smooth] * 9 + [flip])
            if self.flipping == 2:
                rows[-1][8] = flip
        return np.array(rows)

    def rss(self, point) -> float:
        return float(self.event_rss([point])[0].sum())


BEST = HYP.from_unit(OPTIMUM)
LIMIT = profile_limit(EVENTS * FLOOR, EVENTS, 2)


def _exact_half_widths() -> np.ndarray:
    """min over the other of d' M d with d_j fixed is d_j^2 / (M^-1)_jj."""
    return np.sqrt((LIMIT - EVENTS * FLOOR) * np.diag(np.linalg.inv(M)))


def _slice_walk(costs: Valley) -> list[tuple[float, float]]:
    """What the walk of each coordinate alone gives (no search points: no valley's
    quadratic), the profile's starting intervals."""
    start = [(v, v) for v in BEST]
    return walk_intervals(costs, BEST, start, [BEST], np.array([costs.rss(BEST)]), EVENTS)


def _unit_interval(interval: list[tuple[float, float]], j: int) -> tuple[float, float]:
    spec = HYP.specs[j]
    return spec.to_unit(interval[j][0]), spec.to_unit(interval[j][1])


def test_the_profile_reaches_along_a_valley_the_slices_cannot_and_never_past_its_end():
    costs = Valley()
    walked = _slice_walk(costs)
    profiled = profile_intervals(costs, BEST, walked, costs.rss(BEST), EVENTS)
    exact = _exact_half_widths()
    for j in range(2):
        lo_w, hi_w = _unit_interval(walked, j)
        lo, hi = _unit_interval(profiled, j)
        assert hi_w - OPTIMUM[j] < 0.2 * exact[j]  # a slice is pinned by the other
        # doubling then one bisection ends at least three quarters of the way ...
        assert hi - OPTIMUM[j] >= 0.75 * exact[j] - 1e-3
        assert OPTIMUM[j] - lo >= 0.75 * exact[j] - 1e-3
        # ... and only at points within the threshold
        assert hi - OPTIMUM[j] <= exact[j] + 1e-3
        assert OPTIMUM[j] - lo <= exact[j] + 1e-3


def test_the_profile_crosses_a_flipped_event_to_the_island_beyond_it():
    band = (0.53, 0.55)  # the first coordinate's profile ends near 0.578
    costs = Valley(band)
    walked = _slice_walk(costs)
    assert _unit_interval(walked, 0)[1] < band[0]
    profiled = profile_intervals(costs, BEST, walked, costs.rss(BEST), EVENTS)
    lo, hi = _unit_interval(profiled, 0)
    assert hi > band[1]  # beyond the band, on the island the walk could not reach
    assert hi - OPTIMUM[0] <= _exact_half_widths()[0] + 1e-3
    # the band itself is outside the threshold on the true cost
    inside_band = HYP.from_unit([0.54, 0.5 + 0.04 * 0.99])
    assert costs.rss(inside_band) > LIMIT


def test_a_point_one_flipped_event_from_the_islands_stands_for_them_two_do_not():
    """A band of one flipped event running past the profile's end: its points count with
    that event at its cap (ridge_cost), so the interval reaches into the band, never past
    the profile of the smooth events; with two events flipped it stays on the first island."""
    band = (0.53, 0.7)
    one = profile_intervals(Valley(band), BEST, _slice_walk(Valley(band)), 10.0, EVENTS)
    assert band[0] < _unit_interval(one, 0)[1] <= OPTIMUM[0] + _exact_half_widths()[0] + 1e-3
    two = profile_intervals(Valley(band, flipping=2), BEST, _slice_walk(Valley(band)), 10.0,
                            EVENTS)
    assert _unit_interval(two, 0)[1] < band[0]
    caps = np.full(EVENTS, 3.0)
    flipped = np.array([1.0] * 9 + [5000.0])
    assert ridge_cost(flipped, caps) == 12.0
    assert ridge_cost(np.array([1.0] * 9 + [29.0]), caps) == 38.0  # a smooth misfit counts
    assert ridge_cost(np.array([1.0] * 8 + [5000.0] * 2), caps) == 10008.0


def test_a_coordinate_alone_is_its_own_profile():
    key = next(k for k, c in CANDIDATES.items() if len(c.params) == 1)
    one = Hypothesis((key,))
    costs = Valley()
    costs.hyp = one
    best = one.from_unit([0.5])
    intervals = [(best[0], best[0])]
    assert profile_intervals(costs, best, intervals, 10.0, EVENTS) == intervals
    assert costs.asked == 0


def test_the_profile_costs_a_bounded_number_of_points():
    from vadsim.fit.interval_profile import (
        PROFILE_BISECTIONS,
        PROFILE_MAXFEV_PER_COORD,
        PROFILE_STEPS,
    )
    costs = Valley((0.53, 0.55))
    walked = _slice_walk(costs)
    costs.asked = 0
    profile_intervals(costs, BEST, walked, costs.rss(BEST), EVENTS)
    # two coordinates x two sides x steps, each a Nelder-Mead of the other coordinate
    # (scipy may pass maxfev by a simplex' worth) plus its start and its true cost
    per_step = PROFILE_MAXFEV_PER_COORD + 2 + 3
    assert costs.asked <= 1 + 4 * (PROFILE_STEPS + PROFILE_BISECTIONS) * per_step


def test_the_interval_search_is_refused_by_name_and_recorded():
    import pytest
    from vadsim.fit.diagnosis.policy import INTERVAL_SEARCHES, Policy

    for bad in ("quick", "", None, 1):
        with pytest.raises(ValueError, match="interval_search"):
            Policy(interval_search=bad)  # type: ignore[arg-type]
    for ok in INTERVAL_SEARCHES:
        assert Policy(interval_search=ok).as_dict()["interval_search"] == ok
    assert Policy().interval_search == "profile"
