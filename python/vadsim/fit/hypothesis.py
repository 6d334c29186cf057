"""A hypothesis -- some candidate physics plus the nuisance constants -- and the costs of its
points on a campaign.

Why this module exists: a diagnosis compares many models of the same campaign (the calibrated
base model, each candidate, pairs of candidates), and every one must be fitted and scored the
same way or the comparison is meaningless. Here one :class:`Hypothesis` is a list of candidates
and nuisance constants; its parameters form one point, searched in the unit box of their
:class:`~vadsim.fit.candidates.ParamSpec` (log where the effect spans decades, wrapping where
the constant is periodic). :class:`HypothesisCosts` evaluates points on the campaign's events
once each, and every stage of a fit (:mod:`vadsim.fit.stages`, :mod:`vadsim.fit.intervals`,
:mod:`vadsim.fit.scoring`) reads them; :mod:`vadsim.fit.hypothesis_fit` runs the stages.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from vadsim.compare import CampaignEvaluator, EventEval
from vadsim.fit.candidates import CANDIDATES, Candidate, ParamSpec
from vadsim.fit.nuisance import WIDEN_BY, NuisanceSpec, widen
from vadsim.model.change import ModelChange

__all__ = ["Fold", "Hypothesis", "HypothesisCosts", "Point"]

Point = tuple[float, ...]
Fold = tuple[str, list[str], list[str]]

@dataclass(frozen=True)
class Hypothesis:
    """Candidates (by key) and nuisance constants; a point is their parameters in order."""

    keys: tuple[str, ...] = ()
    nuisance: tuple[NuisanceSpec, ...] = ()
    ranges: tuple[tuple[str, str, float, float], ...] = ()
    """Candidate parameters searched over another range than the library's, as ``(candidate
    key, parameter, lo, hi)``: a fitted value at an end of its range widens it
    (:meth:`widened`)."""

    @property
    def candidates(self) -> list[Candidate]:
        """The candidates, in selection order."""
        return [CANDIDATES[k] for k in self.keys]

    def params_of(self, candidate: Candidate) -> list[ParamSpec]:
        """``candidate``'s parameters with the ranges of :attr:`ranges`."""
        own = {name: (lo, hi) for key, name, lo, hi in self.ranges if key == candidate.key}
        return [replace(p, lo=own[p.name][0], hi=own[p.name][1]) if p.name in own else p
                for p in candidate.params]

    def widened(self, at_bounds: list[dict[str, Any]]
                ) -> tuple[Hypothesis, list[dict[str, Any]]]:
        """This hypothesis with every range a fit ended at an end of (``at_bounds``, as
        :attr:`~vadsim.fit.hypothesis_fit.HypothesisFit.at_bounds`) widened at that end;
        returns it and one record per change (``of``, ``name``, ``bound``, ``value``,
        ``from``, ``to``).

        Why: a value at its bound is evidence, not an estimate -- the records ask for more
        than the range allows (measured: an onset steeper than the hydraulic force's
        exponent 3 allows, held out at 3.01 with n at 3). Nuisance constants widen as
        :func:`~vadsim.fit.nuisance.widen`; a candidate's parameter by :data:`~vadsim.fit.
        nuisance.WIDEN_BY` of its range (of its log range where it is searched in log); a
        lower end at 0 stays (a magnitude: a force, a damping), a positive one stays
        positive (at least half of what it was), and no range passes the parameter's
        ``limits`` (what the model accepts)."""
        nuisance, changes = widen(self.nuisance, at_bounds)
        changes = [{"of": "nuisance", **c} for c in changes]
        hits = {(e["of"], e["param"]): e for e in at_bounds if e.get("of") != "nuisance"}
        ranges = {(k, n): (lo, hi) for k, n, lo, hi in self.ranges}
        for c in self.candidates:
            for p in self.params_of(c):
                edge = hits.get((c.id, p.name))
                if edge is None:
                    continue
                lo, hi = _wider(p, edge["bound"])
                if (lo, hi) == (p.lo, p.hi):
                    continue
                ranges[(c.key, p.name)] = (lo, hi)
                changes.append({"of": c.id, "name": p.name, "bound": edge["bound"],
                                "value": edge["value"], "from": [p.lo, p.hi], "to": [lo, hi]})
        out = Hypothesis(self.keys, nuisance,
                         tuple((k, n, lo, hi) for (k, n), (lo, hi) in ranges.items()))
        return out, changes

    @property
    def key(self) -> str:
        """``"none"`` or the candidates' keys joined by ``+``."""
        return "+".join(self.keys) or "none"

    @property
    def specs(self) -> list[ParamSpec]:
        """Every coordinate: the candidates' parameters, then the nuisance constants."""
        return [p for c in self.candidates for p in self.params_of(c)] + list(self.nuisance)

    @property
    def n_physics(self) -> int:
        """Coordinates that belong to candidate physics."""
        return sum(len(c.params) for c in self.candidates)

    def coordinates(self) -> list[tuple[int, ...]]:
        """Each candidate's coordinates (indices into a point), in order."""
        out, i = [], 0
        for c in self.candidates:
            out.append(tuple(range(i, i + len(c.params))))
            i += len(c.params)
        return out

    def extend(self, key: str) -> Hypothesis:
        """This hypothesis plus one candidate."""
        return Hypothesis((*self.keys, key), self.nuisance, self.ranges)

    def null_point(self) -> Point:
        """Candidates where they vanish (else the middle of their box); nuisance at base."""
        out = []
        for p in self.specs:
            out.append(p.null if p.null is not None else p.from_unit(0.5))
        return self.round(out)

    def round(self, values: Sequence[float]) -> Point:
        """A point with 6 significant digits (cache keys of runs must repeat exactly)."""
        return tuple(float(f"{float(v):.6g}") for v in values)

    def unit(self, point: Point) -> np.ndarray:
        """Point -> position in the unit box."""
        return np.array([p.to_unit(v) for p, v in zip(self.specs, point, strict=True)])

    def from_unit(self, u: Sequence[float] | np.ndarray) -> Point:
        """Position in the unit box (wrapped or clipped) -> point."""
        vals = []
        for p, x in zip(self.specs, u, strict=True):
            x = p.wrap(x) if isinstance(p, NuisanceSpec) else min(max(float(x), 0.0), 1.0)
            vals.append(p.from_unit(x))
        return self.round(vals)

    def split(self, point: Point) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
        """``({candidate key: {param: value}}, {nuisance name: value})``."""
        cands: dict[str, dict[str, float]] = {}
        i = 0
        for c in self.candidates:
            cands[c.key] = {p.name: point[i + j] for j, p in enumerate(c.params)}
            i += len(c.params)
        return cands, {p.name: point[i + j] for j, p in enumerate(self.nuisance)}

    def change(self, point: Point) -> ModelChange:
        """The model change at ``point``."""
        cands, nuis = self.split(point)
        out = ModelChange()
        for c in self.candidates:
            out = out.combine(c.change(cands[c.key], self.params_of(c)))
        for p in self.nuisance:
            out = out.combine(p.change(nuis[p.name]))
        return out


def _wider(p: ParamSpec, bound: str) -> tuple[float, float]:
    """``p``'s range widened at ``bound`` (:meth:`Hypothesis.widened`), 6 digits."""
    lo, hi, span = p.lo, p.hi, p.hi - p.lo
    if p.scale == "log":
        ratio = (hi / lo) ** WIDEN_BY
        lo, hi = (lo / ratio, hi) if bound == "lower" else (lo, hi * ratio)
    elif bound == "upper":
        hi += WIDEN_BY * span
    elif lo < 0.0:
        lo -= WIDEN_BY * span
    elif lo > 0.0:  # a positive lower end stays positive; one at 0 stays (a magnitude)
        lo = max(lo - WIDEN_BY * span, 0.5 * lo)
    lo, hi = max(lo, p.limits[0]), min(hi, p.limits[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return p.lo, p.hi
    return float(f"{lo:.6g}"), float(f"{hi:.6g}")


class HypothesisCosts:
    """A hypothesis' evaluations on the comparison engine, by point; remembers the points
    evaluated on every event (for the profile interval and the folds)."""

    def __init__(self, ev: CampaignEvaluator, hyp: Hypothesis, eids: list[str]) -> None:
        self.ev, self.hyp, self.eids = ev, hyp, eids
        self.points: dict[Point, None] = {}

    def _item(self, point: Point) -> tuple[Hashable, ModelChange | None]:
        if not self.hyp.specs:
            return "base", None
        return (self.hyp.key, point), self.hyp.change(point)

    def evaluate(self, points: Sequence[Point], eids: Sequence[str] | None = None
                 ) -> dict[tuple[Point, str], EventEval]:
        """Evaluations of every (point, event), in parallel where not cached."""
        eids = list(eids) if eids is not None else self.eids
        items = {pt: self._item(pt) for pt in points}
        got = self.ev.evaluate(list(items.values()), eids)
        if set(eids) == set(self.eids):
            self.points.update(dict.fromkeys(points))
        return {(pt, e): got[(items[pt][0], e)] for pt in points for e in eids}

    def rss(self, point: Point) -> float:
        """Sum of squared residuals over the fit's events."""
        got = self.evaluate([point])
        return float(sum(np.sum(got[(point, e)].z ** 2) for e in self.eids))

    def event_rss(self, points: Sequence[Point]) -> np.ndarray:
        """Points x events sums of squared residuals."""
        got = self.evaluate(points)
        return np.array([[np.sum(got[(p, e)].z ** 2) for e in self.eids] for p in points])


