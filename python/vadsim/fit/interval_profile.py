"""A reported model's 95 % intervals widened by a profile across the islands of its cost.

Why this module exists: the walk of :mod:`vadsim.fit.interval_walk` steps along each
coordinate alone and along the valley floor of a quadratic, and stops on each side at the first
point above the profile's threshold. Near a regime boundary the cost is a set of islands (one
event's response flips with a fraction of a per cent of WOB), so the walk stays on the island of
the best point while other islands lie within the threshold, and the truth on one of them is
outside every interval. Measured on the 44-campaign blind benchmark: 17 of 105 intervals missed
their truth, and at 13 of them (6 campaigns) the truth's training cost was within the threshold
(blind-11: the truth at WOB x1.000 costs 17.1 where the reported point at x1.049 costs 17.0).

The interval a profile defines holds every value of a coordinate at which the cost, minimised
over the others, stays within the threshold. This module walks that profile: for each
coordinate and side, outward in doubling steps from where the interval ends (at least about
an island's width, :data:`PROFILE_FIRST_STEP`), the others are
re-fitted by Nelder-Mead from the last step's point on the cost with each event capped
(:class:`~vadsim.fit.stages.CappedCosts`), which is never above the true cost and on which
the cost of the other events leads across a flipped event's ridge. A side ends where the capped
minimum passes the threshold (the true cost is then above it too) or at the box's edge. Every
point reached whose cost is within the threshold widens every coordinate's interval to its
values, as in the walk; its cost counts one event that flipped to another response at its cap
(:func:`ridge_cost`): the islands alternate finer than any step lands on (0.005 of WOB), and a
point one flip from them stands for them. A point with a smooth misfit above the threshold, or
two events flipped, widens nothing, and ends nothing: the next step may land on an island.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from scipy import optimize

from vadsim.fit.interval_walk import hull_of_points
from vadsim.fit.intervals import profile_limit
from vadsim.fit.nuisance import NuisanceSpec
from vadsim.fit.stages import CappedCosts

if TYPE_CHECKING:
    from vadsim.fit.hypothesis import HypothesisCosts, Point

__all__ = ["PROFILE_BISECTIONS", "PROFILE_FIRST_STEP", "PROFILE_MAXFEV_PER_COORD",
           "PROFILE_STEPS", "RIDGE_FACTOR", "profile_intervals", "ridge_cost"]

PROFILE_STEPS = 5
"""Doubling steps per coordinate and side after the first (which goes to twice the interval's
end, or :data:`PROFILE_FIRST_STEP`): the last reaches 32 times as far as the first."""

PROFILE_MAXFEV_PER_COORD = 6
"""Nelder-Mead evaluations per free coordinate at each step (it starts from the last step's
point, a continuation, so few are needed)."""

PROFILE_BISECTIONS = 1
"""Bisections between a side's last step inside the threshold and its first outside."""

PROFILE_FIRST_STEP = 1.0 / 64.0
"""The shortest first step, in the search box's unit coordinates: about one island's width
(islands alternate every 0.005-0.01 of WOB, 0.017-0.033 of its unit range, on the
44-campaign benchmark), so that a side whose interval is a single island's still steps
beyond it (blind-11: the WOB interval 0.0017 unit wide, the truth 0.16 unit away)."""

RIDGE_FACTOR = 10.0
"""An event whose cost is above this many times its cap (30 times its cost at the best
point, or the median event's) flipped to another response: :func:`ridge_cost` counts it at
its cap. A smooth misfit never gets there within the threshold: 30 times the median event's
cost is about 3 times the whole cost at the best point (ten events), and the threshold allows
the whole cost about 1.55 times it (ten events, three values fitted)."""

_FIRST_STEP = 1.0 / 256.0  # in the search box's unit coordinates, where an interval is a point


def profile_intervals(costs: HypothesisCosts, best: Point,
                      intervals: Sequence[tuple[float, float]], best_rss: float,
                      records: int) -> list[tuple[float, float]]:
    """``intervals`` widened by the profile across islands (module docstring).

    Parameters
    ----------
    costs
        The hypothesis' evaluations on every event of the fit (full fidelity).
    best
        The fit's best point.
    intervals
        The intervals so far, one per coordinate; each side's first step goes past its end.
    best_rss
        The training cost at ``best`` (the threshold's base).
    records
        The events the cost sums over (the threshold's unit).

    Returns
    -------
    list of (float, float)
        Per coordinate, the hull of its interval and the points reached within the threshold.
        A hypothesis of one coordinate is returned as it was (its slice is its profile).
    """
    hyp = costs.hyp
    k = len(hyp.specs)
    if k < 2:
        return list(intervals)
    limit = profile_limit(best_rss, records, k)
    capped = CappedCosts.around(costs, best)
    inside: list[Point] = []
    for j, spec in enumerate(hyp.specs):
        if isinstance(spec, NuisanceSpec) and spec.periodic:
            continue  # its slice walk spans its period already; a profile has no outside
        for side in (-1.0, 1.0):
            inside += _profile_side(costs, capped, best, intervals, j, side, limit)
    return hull_of_points(hyp.specs, best, intervals, inside)


def ridge_cost(per_event: np.ndarray, caps: np.ndarray) -> float:
    """The training cost of a point with its one event that flipped to another response, if
    one did (above :data:`RIDGE_FACTOR` times its cap), counted at its cap; the true cost
    where none or more than one did.

    Why: a point beside a flipped event stands for the islands around it. Measured on
    blind-11 (an impact-face stiffness x2.5): every point the profile reached between the
    chosen island (WOB x1.049) and the truth's (x1.000, an island 0.005 wide) had one event
    at 221-42,000 where its cap was 8.1 and the other nine within the threshold, and no
    step of any search lands on an island that narrow."""
    over = per_event > RIDGE_FACTOR * caps
    if np.count_nonzero(over) != 1:
        return float(per_event.sum())
    return float(np.where(over, caps, per_event).sum())


def _profile_side(costs: HypothesisCosts, capped: CappedCosts, best: Point,
                  intervals: Sequence[tuple[float, float]], j: int, side: float,
                  limit: float) -> list[Point]:
    """The points within ``limit`` that coordinate ``j``'s profile reaches on one side."""
    hyp = costs.hyp
    specs = hyp.specs
    u0 = hyp.unit(best)
    widths = np.array([max(abs(s.to_unit(hi) - s.to_unit(lo)), _FIRST_STEP)
                       for s, (lo, hi) in zip(specs, intervals, strict=True)])
    end = specs[j].to_unit(intervals[j][0] if side < 0 else intervals[j][1])
    edge = (1.0 - u0[j]) if side > 0 else u0[j]
    t = min(max(2.0 * side * (end - u0[j]), PROFILE_FIRST_STEP), edge)
    others = [i for i in range(len(specs)) if i != j]
    maxfev = PROFILE_MAXFEV_PER_COORD * len(others)
    inside: list[Point] = []
    t_in, u_in, t_out, bisections = 0.0, u0, None, 0
    for _step in range(PROFILE_STEPS + PROFILE_BISECTIONS):
        if t <= 0.0:
            break
        # the others predicted along the secant from the best point to the last step inside
        u = u0 + (u_in - u0) * (t / t_in) if t_in > 0.0 else u0.copy()
        u[j] = u0[j] + side * t
        capped_rss, u_best = _refit_others(capped, u, others, widths[others], maxfev)
        point = hyp.from_unit(u_best)
        if capped_rss > limit:
            t_out = t
        else:
            t_in, u_in = t, hyp.unit(point)
            if ridge_cost(costs.event_rss([point])[0], capped.caps) <= limit:
                inside.append(point)
        if t_out is not None:
            if bisections >= PROFILE_BISECTIONS or t_out - t_in <= _FIRST_STEP:
                break
            bisections += 1
            t = 0.5 * (t_in + t_out)
        elif t >= edge:
            break
        else:
            t = min(2.0 * t, edge)
    return inside


def _refit_others(capped: CappedCosts, u: np.ndarray, others: list[int], widths: np.ndarray,
                  maxfev: int) -> tuple[float, np.ndarray]:
    """Nelder-Mead over ``others`` from ``u`` on the capped cost, its first simplex one
    interval wide in each (the valley's own scale: a grid step is tens of times wider than
    a phase's valley and spends the evaluations shrinking); the best (cost, unit point)."""
    hyp = capped.hyp
    best: tuple[float, np.ndarray] = (capped.rss(hyp.from_unit(u)), u)

    def cost(x: np.ndarray) -> float:
        nonlocal best
        v = u.copy()
        v[others] = x  # from_unit clips a bounded coordinate and wraps a periodic one
        r = capped.rss(hyp.from_unit(v))
        if r < best[0]:
            best = (r, v)
        return r

    x0 = u[others]
    simplex = np.vstack([x0, x0 + np.diag(widths)])
    optimize.minimize(cost, x0, method="Nelder-Mead",
                      options={"initial_simplex": simplex, "maxfev": maxfev,
                               "xatol": 1e-4, "fatol": 1e-3})
    return best
