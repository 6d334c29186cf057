"""The search stages of a hypothesis fit: grids over some coordinates, then local refinements.

* **grid** over some coordinates (the others held: e.g. a candidate's parameters at the
  nuisance constants "none" fitted): :func:`grid_points`;
* **refine** locally: bounded Brent along one coordinate, Nelder-Mead in several (the joint
  refinement of a candidate with the nuisance constants): :func:`refine`.

A :class:`Stage` says which coordinates each covers, how finely, and when it is skipped;
:func:`run_stages` runs a list of them from one start. Why a module of its own: the
diagnosis composes its own stages for each step (grids on a coarse engine, joint refinements
only where a candidate already helps), and every hypothesis is searched by the same code.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from scipy import optimize

from vadsim.fit.nuisance import NuisanceSpec

if TYPE_CHECKING:
    from vadsim.fit.hypothesis import Hypothesis, HypothesisCosts, Point

__all__ = ["COARSE_SEEDS", "ISLAND_CAP", "REFINE_GAIN", "REFINE_ROUNDS", "CappedCosts",
           "PointCost", "Stage", "capped_refine", "grid_points", "refine",
           "run_stages"]


COARSE_SEEDS = 3
"""How many of a coarse grid's best points are evaluated again at full fidelity."""

REFINE_ROUNDS = 4
"""At most this many Nelder-Mead rounds of ``maxfev`` evaluations each in a refinement of
several coordinates, each restarted from the best point with a fresh simplex."""

REFINE_GAIN = 0.05
"""A refinement runs another round only while its last round cut the cost by more than this
fraction: a candidate that is walking down a valley keeps going, one that does not help
stops after one round. Measured on blind-10 (a hydraulic force whose amplitude and flow
exponent trade off along a curved valley): one round of 16 evaluations ended at the grid
point (67.5, 1.69) with training cost 260, the truth (60, 2.0) costing 45; rounds reach
(60.1, 1.99) at 18."""


def grid_points(hyp: Hypothesis, start: Point, free: Sequence[int],
                max_per_axis: int | None = None, shape_per_axis: int | None = None,
                per_axis: int | None = None) -> list[Point]:
    """The grid over the ``free`` coordinates (each spec's ``grid`` points, at most
    ``max_per_axis``, and at most ``shape_per_axis`` for a candidate parameter without a
    null, e.g. a flow exponent; ``per_axis`` points instead of the spec's own, where
    given; a periodic one starts at ``start``), the others held at ``start``. The start
    point itself is always included."""
    specs, u0 = hyp.specs, hyp.unit(start)
    axes = []
    for i in free:
        p = specs[i]
        n = p.grid if per_axis is None else per_axis
        n = n if max_per_axis is None else min(n, max_per_axis)
        if shape_per_axis is not None and not isinstance(p, NuisanceSpec) and p.null is None:
            n = min(n, shape_per_axis)
        if isinstance(p, NuisanceSpec) and p.periodic:
            axes.append([(u0[i] + k / n) % 1.0 for k in range(n)])
        else:
            axes.append(sorted({*np.linspace(0.0, 1.0, n).tolist(), float(u0[i])}))
    out: dict[Point, None] = {start: None}
    for combo in np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(free), -1).T:
        u = u0.copy()
        u[list(free)] = combo
        out[hyp.from_unit(u)] = None
    return list(out)


class PointCost(Protocol):
    """What :func:`refine` walks: a hypothesis and a training cost at each of its points
    (:class:`~vadsim.fit.hypothesis.HypothesisCosts`, or :class:`CappedCosts`)."""

    hyp: Hypothesis

    def rss(self, point: Point) -> float: ...


def refine(costs: PointCost, start: Point, free: Sequence[int], maxfev: int
           ) -> tuple[float, Point]:
    """Local refinement of ``free`` coordinates from ``start``: bounded Brent within one grid
    step along a single non-periodic coordinate, Nelder-Mead (wrapping periodic ones)
    otherwise. Returns the best (rss, point) evaluated, never worse than the start."""
    hyp = costs.hyp
    specs, u0 = hyp.specs, hyp.unit(start)
    free = list(free)
    if not free or maxfev <= 0:
        return costs.rss(start), start

    def at(x: np.ndarray) -> Point:
        u = u0.copy()
        u[free] = x
        return hyp.from_unit(u)

    # the best point evaluated, not the optimiser's answer: Nelder-Mead stopped by maxfev
    # drops the iteration it was in, with a better point it may just have evaluated
    # (blind-16: 123.4 evaluated, 158.0 returned)
    best = (costs.rss(start), start)

    def cost(x: np.ndarray) -> float:
        nonlocal best
        point = at(x)
        r = costs.rss(point)
        if r < best[0]:
            best = (r, point)
        return r

    steps = np.array([0.5 / max(specs[i].grid - 1, 1) for i in free])
    one = len(free) == 1 and not getattr(specs[free[0]], "periodic", False)
    if one:
        lo, hi = max(0.0, u0[free[0]] - 2 * steps[0]), min(1.0, u0[free[0]] + 2 * steps[0])
        optimize.minimize_scalar(lambda x: cost(np.array([x])), bounds=(lo, hi),
                                 method="bounded", options={"maxiter": maxfev, "xatol": 1e-3})
    else:
        x0 = u0[free]
        for _round in range(REFINE_ROUNDS):
            before = best[0]
            simplex = np.vstack([x0] + [x0 + np.eye(len(free))[j] * steps[j]
                                        for j in range(len(free))])
            optimize.minimize(cost, x0, method="Nelder-Mead",
                              options={"initial_simplex": simplex, "maxfev": maxfev,
                                       "xatol": 1e-3, "fatol": 1e-3})
            if not best[0] < (1.0 - REFINE_GAIN) * before:
                break
            x0 = hyp.unit(best[1])[free]
    return best


@dataclass(frozen=True)
class Stage:
    """One search stage: a grid over ``grid`` coordinates (None: no grid; at most
    ``max_per_axis`` points per axis) then a refinement of ``refine`` coordinates with
    ``maxfev`` evaluations (``starts``: from the best few grid points); skipped unless the
    best cost so far is below ``if_rss_below`` (a joint refinement only where a candidate
    already helps). The grid is laid around the best point so far and, with
    ``nominal_anchor``, also around that point with the nuisance constants at their nominal
    values (the ones fitted without the right physics absorb part of a real effect).
    ``coarse``: the grid is evaluated on the coarse engine where the fit has one (a subset of
    events, shorter runs) and only its :data:`COARSE_SEEDS` best points at full fidelity --
    a grid only has to find the basin. ``shape_per_axis``: fewer grid points for the
    parameters without a null (a shape, e.g. a flow exponent), where a grid over many
    hypotheses would otherwise cost the product of every axis. ``per_axis``: that many grid
    points per axis in place of each spec's own (a fine profile of one coordinate)."""

    grid: tuple[int, ...] | None
    refine: tuple[int, ...]
    maxfev: int
    max_per_axis: int | None = None
    starts: int = 1
    if_rss_below: float = math.inf
    nominal_anchor: bool = False
    coarse: bool = False
    shape_per_axis: int | None = None
    per_axis: int | None = None


def run_stages(costs: HypothesisCosts, hyp: Hypothesis, start: Point,
               stages: Sequence[Stage], coarse: HypothesisCosts | None = None
               ) -> tuple[float, Point]:
    """The stages from one start: the best (rss, point) reached.

    Why: :func:`~vadsim.fit.hypothesis_fit.fit_hypothesis` runs every one of its starts through
    the same stages and keeps the best end.

    Parameters
    ----------
    costs
        The hypothesis' evaluations on all the fit's events (full fidelity).
    hyp
        The hypothesis (``costs.hyp``).
    start
        The point the first stage starts from.
    stages
        The stages, in order.
    coarse
        The evaluations on the coarse engine, for the grids of stages marked ``coarse``
        (None: every grid at full fidelity).

    Returns
    -------
    tuple of (float, Point)
        The lowest training cost reached and its point, never worse than ``start``'s.
    """
    best_rss, best = costs.rss(start), start
    for st in stages:
        if best_rss >= st.if_rss_below:
            continue
        seeds = [best]
        if st.grid:
            anchors = [best]
            if st.nominal_anchor and hyp.nuisance:
                nominal = hyp.round([*best[:hyp.n_physics],
                                     *(float(p.null or 0.0) for p in hyp.nuisance)])
                anchors += [nominal] if nominal != best else []
            pts = list(dict.fromkeys(p for a in anchors
                                     for p in grid_points(hyp, a, st.grid, st.max_per_axis,
                                                             st.shape_per_axis,
                                                             st.per_axis)))
            if st.coarse and coarse is not None:
                rough = coarse.event_rss(pts).sum(axis=1)
                pts = [pts[i] for i in np.argsort(rough)[:max(st.starts, COARSE_SEEDS)]]
            total = costs.event_rss(pts).sum(axis=1)
            order = np.argsort(total)
            seeds = [pts[i] for i in order[:max(st.starts, 1)]]
            if total[order[0]] < best_rss:
                best_rss, best = float(total[order[0]]), pts[order[0]]
        for s in seeds if st.refine else []:
            r, p = refine(costs, s, st.refine, st.maxfev)
            if r < best_rss:
                best_rss, best = r, p
    return best_rss, best


ISLAND_CAP = 3.0
"""Each event's training cost is capped at this many times its cost at the start (or the
median event's, whichever is larger) in :func:`capped_refine`."""


class CappedCosts:
    """A hypothesis' training cost with each event's part capped (``caps``): an event that
    lands on another response (thousands of spreads at one event where the others move by
    a few) counts as a bounded miss, so the cost of the rest guides the walk across it."""

    def __init__(self, costs: HypothesisCosts, caps: np.ndarray) -> None:
        self.costs, self.hyp, self.caps = costs, costs.hyp, np.asarray(caps, dtype=float)

    @classmethod
    def around(cls, costs: HypothesisCosts, point: Point, cap: float = ISLAND_CAP
               ) -> CappedCosts:
        """Each event capped at ``cap`` times its cost at ``point``, or the median event's
        where that is larger (an event fitted almost exactly may still move by a median
        event's worth without counting as flipped)."""
        per_event = costs.event_rss([point])[0]
        return cls(costs, cap * np.maximum(per_event, float(np.median(per_event))))

    def rss(self, point: Point) -> float:
        return float(np.minimum(self.costs.event_rss([point])[0], self.caps).sum())


def capped_refine(costs: HypothesisCosts, start: Point, maxfev: int,
                  cap: float = ISLAND_CAP) -> tuple[float, Point]:
    """Nelder-Mead over every coordinate from ``start`` on the capped cost
    (:class:`CappedCosts`, each event at most ``cap`` times its start's cost, or the median
    event's), then locally on the true cost from where it ended: the (true rss, point)
    reached, which may be worse than the start's (the caller keeps the better).

    Why: the model is multistable, and near a regime boundary one event's response flips
    with a fraction of a per cent of WOB, so the cost is a set of islands each a local
    minimum. Measured on blind-11 of the 44-campaign benchmark (an impact-face stiffness
    x2.5): the chosen point cost 45.3, fine profiles and Nelder-Mead around it found nothing
    better, a 32-point Sobol design in twice its intervals nothing below 116; on the cost
    capped at 3 times each event's, Nelder-Mead walked to a point costing 17.0 (the truth
    17.1): across the ridges the other nine events' cost led it."""
    every = range(len(costs.hyp.specs))
    _, point = refine(CappedCosts.around(costs, start, cap), start, every, maxfev)
    return refine(costs, point, every, maxfev // 4 or 1)
