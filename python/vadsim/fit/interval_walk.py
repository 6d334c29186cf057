"""A reported model's 95 % intervals walked out from its optimum, with new evaluations.

Why this module exists: the profile interval (:func:`vadsim.fit.intervals.profile_interval`)
reads only the points a search happened to evaluate, and a search clusters them where it
walked down: on the own-classes blind benchmark a mount resonance written at 700.0 Hz was
reported as 700.71-700.85 Hz while the truth cost *less* than the chosen point (16.9 against
18.3); nothing had been evaluated on that side. An interval has to say how far the cost stays
within its threshold, so the reported model's are walked: from the best point, along each
coordinate alone (a slice) and along the valley floor of a quadratic fitted to the points
near the best (the profile's direction, where parameters trade off), outwards on each side
until the cost passes the profile's threshold, then bisected. Every walked point whose cost
is within the threshold widens the interval of each coordinate to its value (such a point's
value of one coordinate lies inside that coordinate's profile interval, whatever the
others), so the walk only widens, and never past the true profile interval.

The walkers of all coordinates, directions and sides step together, one batch of points a
round, so that a round's runs go to the workers at once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vadsim.fit.intervals import profile_limit, valley_directions
from vadsim.fit.nuisance import NuisanceSpec

if TYPE_CHECKING:
    from vadsim.fit.hypothesis import HypothesisCosts, Point

__all__ = ["WALK_BISECTIONS", "WALK_FIRST_STEP", "hull_of_points", "walk_intervals"]

WALK_FIRST_STEP = 1.0 / 1024.0
"""The shortest first step of a walker in the search box's unit coordinates; otherwise it
starts where the interval it widens ends on its side, and doubles its step while inside.
Why geometric from there: the cost's width differs by orders of magnitude between
parameters (blind-17's resonance: within its threshold over 699.6-701 Hz, 0.002 of its
search box, and far outside it at 1/32 of the box)."""

WALK_BISECTIONS = 3
"""Bisections between a walker's last point inside the threshold and its first outside."""

_MAX_ROUNDS = 16  # doubling from 1/1024 of the box to all of it is 10, then the bisections


@dataclass
class _Walker:
    """One direction and side: steps ``t`` along ``direction`` from the best point."""

    direction: np.ndarray
    t_in: float = 0.0
    t_out: float | None = None
    t_next: float = 0.0
    bisections: int = 0
    done: bool = False

    def advance(self, inside: bool, t_edge: float) -> None:
        """Take the result of the point at ``t_next`` and choose the next one."""
        if inside:
            self.t_in = self.t_next
        else:
            self.t_out = self.t_next
        if self.t_out is None:
            if self.t_in >= t_edge:
                self.done = True
            else:
                self.t_next = min(2.0 * self.t_in, t_edge)
            return
        if self.bisections >= WALK_BISECTIONS:
            self.done = True
            return
        self.bisections += 1
        self.t_next = 0.5 * (self.t_in + self.t_out)


def _edge(u0: np.ndarray, d: np.ndarray, periodic: np.ndarray) -> float:
    """How far ``u0 + t d`` stays in the unit box; a periodic coordinate wraps, so it goes
    at most half its period (further is nearer the start the other way)."""
    t = 1.0 / max(float(np.max(np.abs(d))), 1e-12)
    for j in np.flatnonzero(d != 0):
        if periodic[j]:
            t = min(t, 0.5 / abs(d[j]))
        else:
            t = min(t, ((1.0 - u0[j]) if d[j] > 0 else u0[j]) / abs(d[j]))
    return float(t)


def walk_intervals(costs: HypothesisCosts, best: Point, intervals: Sequence[tuple[float, float]],
                   points: Sequence[Point], point_rss: np.ndarray, records: int
                   ) -> list[tuple[float, float]]:
    """``intervals`` widened by walking from ``best`` (module docstring).

    Parameters
    ----------
    costs
        The hypothesis' evaluations on every event of the fit (full fidelity).
    best
        The fit's best point.
    intervals
        The intervals so far, one per coordinate (each walker's first step reaches its end).
    points, point_rss
        The points evaluated on every event and their costs (the valley's quadratic).
    records
        The events the cost sums over (the profile threshold's unit).

    Returns
    -------
    list of (float, float)
        Per coordinate, the hull of its interval and the walked points within the threshold.
    """
    hyp = costs.hyp
    specs = hyp.specs
    k = len(specs)
    if k == 0:
        return list(intervals)
    best_rss = float(np.min(point_rss)) if len(point_rss) else costs.rss(best)
    limit = profile_limit(best_rss, records, k)
    u0 = hyp.unit(best)
    periodic = np.array([isinstance(p, NuisanceSpec) and p.periodic for p in specs])
    ridges = valley_directions(hyp, best, points, point_rss)
    walkers: list[tuple[_Walker, float]] = []
    for j in range(k):
        lo_u, hi_u = (specs[j].to_unit(v) for v in intervals[j])
        directions = [np.eye(k)[j]]
        if ridges is not None and np.count_nonzero(ridges[j]) > 1:
            directions.append(ridges[j])
        for d in directions:
            for side in (-1.0, 1.0):
                w = _Walker(direction=side * d)
                edge = _edge(u0, w.direction, periodic)
                reach = (u0[j] - lo_u) if side < 0 else (hi_u - u0[j])
                if periodic[j]:  # its interval may be given unwrapped around the best
                    reach = ((reach + 0.5) % 1.0) - 0.5
                w.t_next = min(max(reach, WALK_FIRST_STEP), edge)
                if edge <= 0.0:
                    w.done = True
                walkers.append((w, edge))
    inside_points: list[Point] = []
    for _round in range(_MAX_ROUNDS):
        live = [(w, edge) for w, edge in walkers if not w.done]
        if not live:
            break
        batch = [hyp.from_unit(u0 + w.t_next * w.direction) for w, _e in live]
        rss = costs.event_rss(list(dict.fromkeys(batch))).sum(axis=1)
        by_point = dict(zip(dict.fromkeys(batch), rss.tolist(), strict=True))
        for (w, edge), pt in zip(live, batch, strict=True):
            inside = by_point[pt] <= limit
            if inside:
                inside_points.append(pt)
            w.advance(inside, edge)
    return hull_of_points(specs, best, intervals, inside_points)


def hull_of_points(specs: Sequence[object], best: Point,
                   intervals: Sequence[tuple[float, float]], points: Sequence[Point]
                   ) -> list[tuple[float, float]]:
    """Per coordinate, the hull of its interval and the values of ``points`` (periodic
    constants unwrapped around ``best``, as the jackknife reports them)."""
    out = []
    for j, (lo, hi) in enumerate(intervals):
        vals = [float(pt[j]) for pt in points]
        spec = specs[j]
        if isinstance(spec, NuisanceSpec) and spec.periodic:
            span = spec.hi - spec.lo
            vals = [float(best[j]) + ((v - float(best[j]) + 0.5 * span) % span) - 0.5 * span
                    for v in vals]
        out.append((min([lo, *vals]), max([hi, *vals])))
    return out
