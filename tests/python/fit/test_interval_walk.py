"""A reported model's intervals walked out from its optimum (vadsim.fit.interval_walk), on
analytic costs whose profile intervals are known exactly."""

from __future__ import annotations

import math

import numpy as np
from vadsim.fit.hypothesis import Hypothesis
from vadsim.fit.interval_walk import walk_intervals
from vadsim.fit.intervals import profile_limit
from vadsim.fit.nuisance import DEFAULT_NUISANCE

HYP = Hypothesis(("hydraulic_force[anvil]",), DEFAULT_NUISANCE)  # f_ref, n, wob, theta0
OPTIMUM = np.array([0.32, 0.5, 0.5])  # f_ref 64, n 2, WOB x1 in the unit box
THETA0 = 2.26
RECORDS = 10
C0 = 20.0
# f_ref and n trade off (a curved valley in the real cost), the WOB is wide; in unit
# coordinates the cost is C0 + d' M d, with d the offset from the optimum
M = np.array([[4.0e4, -3.96e4, 0.0],
              [-3.96e4, 4.0e4, 0.0],
              [0.0, 0.0, 300.0]])


class QuadraticCosts:
    """The fake engine: a cost known in closed form, counting the points it is asked for."""

    def __init__(self) -> None:
        self.hyp = HYP
        self.asked = 0

    def cost(self, point) -> float:
        u = HYP.unit(point)
        d = u[:3] - OPTIMUM
        return float(C0 + d @ M @ d + 10.0 * (1.0 - math.cos(point[3] - THETA0)))

    def rss(self, point) -> float:
        return self.cost(point)

    def event_rss(self, points) -> np.ndarray:
        self.asked += len(points)
        return np.array([[self.cost(p)] for p in points])


def _profile_half_widths(limit: float) -> np.ndarray:
    """The exact profile interval's half-width per coordinate, in unit coordinates:
    min over the others of d' M d with d_j fixed is d_j^2 / (M^-1)_jj."""
    return np.sqrt((limit - C0) * np.diag(np.linalg.inv(M)))


def _searched(costs: QuadraticCosts) -> tuple[list, np.ndarray]:
    """What a search leaves: points on one side of the valley only (it walked down from
    above), enough for a quadratic."""
    rng = np.random.default_rng(3)
    pts = [HYP.from_unit([*(OPTIMUM + np.abs(rng.normal(0.0, 0.002, 3))),
                          (THETA0 + rng.normal(0.0, 0.05)) / math.pi])
           for _ in range(60)]
    best = HYP.from_unit([*OPTIMUM, THETA0 / math.pi])
    pts = [best, *pts]
    return pts, costs.event_rss(pts).sum(axis=1)


def test_walked_intervals_reach_the_profile_where_parameters_trade_off():
    costs = QuadraticCosts()
    points, rss = _searched(costs)
    best = points[0]
    limit = profile_limit(float(rss.min()), RECORDS, len(HYP.specs))
    half = _profile_half_widths(limit)
    spans = np.array([s.hi - s.lo for s in HYP.specs[:3]])
    # the intervals a search gives where its points cluster: far narrower than the profile
    given = [(v - 0.002 * (s.hi - s.lo), v + 0.002 * (s.hi - s.lo))
             for v, s in zip(best, HYP.specs, strict=True)]
    assert all(0.002 < 0.1 * h for h in half)
    costs.asked = 0
    walked = walk_intervals(costs, best, given, points, rss, RECORDS)
    for j in range(3):
        lo, hi = walked[j]
        exact_lo, exact_hi = best[j] - half[j] * spans[j], best[j] + half[j] * spans[j]
        # never past the profile interval (every point it keeps is within the threshold)
        assert lo >= exact_lo - 1e-9 and hi <= exact_hi + 1e-9, (j, walked[j])
        # and within a bisection's precision of it, on both sides
        assert lo <= best[j] - 0.85 * half[j] * spans[j], (j, walked[j], exact_lo)
        assert hi >= best[j] + 0.85 * half[j] * spans[j], (j, walked[j], exact_hi)
    # the walk along f_ref alone (a slice) reaches only sqrt(1/M_jj) of it: the valley's
    # direction is what reaches the profile where f_ref and n trade off
    assert half[0] > 5 * math.sqrt((limit - C0) / M[0, 0])
    # theta0's interval is given around the optimum, unwrapped
    assert walked[3][0] <= THETA0 <= walked[3][1]
    # a count, not a time: tens of points per coordinate, not a grid
    assert 0 < costs.asked <= 16 * 2 * 2 * len(HYP.specs)


def test_a_walk_only_widens():
    costs = QuadraticCosts()
    points, rss = _searched(costs)
    wide = [(s.lo, s.hi) for s in HYP.specs]
    walked = walk_intervals(costs, points[0], wide, points, rss, RECORDS)
    assert np.allclose(walked, wide, rtol=0, atol=1e-12)


def test_a_narrow_cost_in_a_wide_box_is_walked_from_the_intervals_end():
    """blind-17: a resonance's cost within its threshold over 1.5 Hz of a 100-1000 Hz box
    (the search's interval 0.14 Hz wide): steps doubled from the interval's end find the
    threshold; a first step of a fixed fraction of the box would have jumped past it."""
    hyp = Hypothesis(("sensor_chain[x1]",), ())
    (f_spec, _q_spec) = hyp.specs

    class Narrow(QuadraticCosts):
        def __init__(self) -> None:
            self.hyp, self.asked = hyp, 0

        def cost(self, point) -> float:
            return 17.0 + ((point[0] - 700.0) / 0.5) ** 2 + ((point[1] - 8.0) / 0.2) ** 2

    costs = Narrow()
    best = hyp.round([700.76, 7.83])
    limit = profile_limit(costs.cost(best), RECORDS, 2)
    walked = walk_intervals(costs, best, [(700.70, 700.84), (7.80, 7.98)], [best],
                            np.array([costs.cost(best)]), RECORDS)
    lo, hi = walked[0]
    assert lo <= 700.0 <= hi
    exact = 700.0 + 0.5 * math.sqrt(limit - 17.0 - ((best[1] - 8.0) / 0.2) ** 2)
    assert hi <= exact + 1e-6 and f_spec.lo < lo
