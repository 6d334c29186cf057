"""One hypothesis fitted to a campaign and scored on held-out events: :func:`fit_hypothesis`
and its result, :class:`HypothesisFit`.

Why this module exists: a diagnosis compares many models of the same campaign (the calibrated
base model, each candidate, pairs of candidates), and every one must be fitted and scored the
same way or the comparison is meaningless. Here one :class:`~vadsim.fit.hypothesis.Hypothesis`
is a list of candidates and nuisance constants; its parameters form one point, searched in the
unit box of their :class:`~vadsim.fit.candidates.ParamSpec` (log where the effect spans
decades, wrapping where the constant is periodic). :func:`fit_hypothesis` runs the stages and
returns a :class:`HypothesisFit`:

* **grid** and **refine** (:mod:`vadsim.fit.stages`): grids over some coordinates, then
  local refinements, as the :class:`~vadsim.fit.stages.Stage` list given says;
* **interval** (:mod:`vadsim.fit.intervals`): per parameter, the wider of a 95 % profile
  interval from every point evaluated on all events and a delete-one-flow jackknife interval
  from the leave-one-flow-out folds' refits; a model that is reported has its intervals
  walked out from its optimum and along its profile too (:func:`with_searched_intervals`);
* **held-out score** (:mod:`vadsim.fit.scoring`): each fold refitted among the points
  evaluated on every event and its held-out events predicted at the *predictive* cost; the
  error is the RMS standardised residual pooled over all held-out predictions, and the score
  an AICc on those residuals.

Every stage reads the evaluations of one :class:`~vadsim.fit.hypothesis.HypothesisCosts`, so a
point is run once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from vadsim.compare import CampaignEvaluator
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.hypothesis import Fold, Hypothesis, HypothesisCosts, Point
from vadsim.fit.interval_profile import profile_intervals
from vadsim.fit.interval_walk import walk_intervals
from vadsim.fit.intervals import fold_estimates, jackknife_interval, profile_interval, widest
from vadsim.fit.nuisance import NuisanceSpec
from vadsim.fit.scoring import aicc, events_cost, is_block_fold, score_folds
from vadsim.fit.stages import Stage, run_stages

__all__ = ["AT_BOUND", "TOP_POINTS", "HypothesisFit", "fit_hypothesis",
           "with_searched_intervals"]

TOP_POINTS = 3
"""How many of the best points a fit keeps as starts for a finer fit."""


AT_BOUND = 1e-4
"""How close to an end of its search range, as a fraction of the range (of its log for a
log-scaled parameter), a fitted value counts as at that end: points carry 6 significant
digits, so a value the search clipped to a bound sits exactly on it."""



# ---------------------------------------------------------------------------------- results

@dataclass
class HypothesisFit:
    """One hypothesis fitted to the campaign and scored on held-out events."""

    keys: tuple[str, ...]
    nuisance_specs: tuple[NuisanceSpec, ...]
    point: Point
    k: int
    intervals: list[tuple[float, float]]
    rss: float
    n: int
    heldout_rms: float
    heldout_rms_lofo: float
    heldout_rms_block: float
    score: float
    heldout: dict[str, dict[str, float]] = field(default_factory=dict, repr=False)
    heldout_sim: dict[str, dict[str, float]] = field(default_factory=dict, repr=False)
    fold_values: dict[str, dict[str, float]] = field(default_factory=dict)
    predicted_values: dict[str, dict[str, float]] = field(default_factory=dict)
    """Folds whose held-out events were scored at another point than their fold point (see
    :func:`~vadsim.fit.scoring.predictive_cost`): that point's values by name."""
    n_evals: int = 0
    n_points: int = 0
    rss_start: float = math.nan
    n_heldout: int = 0  # held-out squared residuals behind heldout_rms and score
    """The training cost at the start point (what the fit improved on)."""
    top_points: tuple[Point, ...] = ()
    """The few points with the lowest training cost (starts for a finer fit)."""
    probe: bool = False
    """Only probed (a coarse grid on a subset of events, shorter runs) in a screening step:
    its held-out score is the probe's, on that subset, and it is never chosen."""
    point_rss: dict[Point, float] = field(default_factory=dict, repr=False)
    """Every point evaluated on all the fit's events, with its training cost (a pair step
    reads the first step's probes from it)."""
    ranges: tuple[tuple[str, str, float, float], ...] = ()
    """Candidate parameters searched over a widened range (:attr:`Hypothesis.ranges`)."""

    @property
    def hypothesis(self) -> Hypothesis:
        """The fitted hypothesis."""
        return Hypothesis(self.keys, self.nuisance_specs, self.ranges)

    @property
    def key(self) -> str:
        """``"none"`` or the candidate keys joined by ``+``."""
        return self.hypothesis.key

    @property
    def ids(self) -> list[str]:
        """The candidate ids, in selection order."""
        return [CANDIDATES[k].id for k in self.keys]

    @property
    def id(self) -> str:
        """``"none"`` or the candidate ids joined by ``+``."""
        return "+".join(self.ids) or "none"

    @property
    def aicc_train(self) -> float:
        """AICc of the training fit."""
        return aicc(self.n, self.rss / self.n, self.k)

    def _flat(self, point: Sequence[Any]) -> dict[str, Any]:
        cands, nuis = self.hypothesis.split(tuple(point))
        flat = {(f"{k}.{n}" if len(cands) > 1 else n): v
                for k, vals in cands.items() for n, v in vals.items()}
        return {**flat, **nuis}

    @property
    def values(self) -> dict[str, float]:
        """Every fitted value by name (candidate parameters as ``key.param`` when there are
        several candidates, plain ``param`` for one) and the nuisance constants by name."""
        return self._flat(self.point)

    @property
    def interval(self) -> dict[str, tuple[float, float]]:
        """95 % intervals (profile or jackknife, the wider), named as :attr:`values`."""
        return self._flat(self.intervals) if self.intervals else {}

    def intervals_by_id(self) -> tuple[dict[str, dict[str, tuple[float, float]]],
                                       dict[str, tuple[float, float]]]:
        """``({candidate id: {param: interval}}, {nuisance name: interval})``."""
        if not self.intervals:
            return {}, {}
        cands, nuis = self.hypothesis.split(tuple(self.intervals))  # type: ignore[arg-type]
        return ({CANDIDATES[k].id: v for k, v in cands.items()},  # type: ignore[misc]
                nuis)  # type: ignore[return-value]

    @property
    def at_bounds(self) -> list[dict[str, Any]]:
        """Fitted values left at an end of their search range (not a periodic constant's,
        nor a candidate's vanishing value): each as ``{"of": candidate id or "nuisance",
        "param", "value", "bound": "lower" | "upper"}``.

        Why: a value at the edge is a bound, not an estimate -- the recordings ask for more
        than the range allows (the 7in CDE field table's impact-face stiffness x0.25, the
        9.5in PDC's too; docs/DIAGNOSIS.md), so the physics named is at best a proxy for
        what moves the features, and a user must be told rather than read it off."""
        out: list[dict[str, Any]] = []
        owners = [CANDIDATES[k].id for k in self.keys for _ in CANDIDATES[k].params]
        owners += ["nuisance"] * len(self.nuisance_specs)
        for spec, value, of in zip(self.hypothesis.specs, self.point, owners, strict=True):
            if getattr(spec, "periodic", False) or (spec.null is not None
                                                    and float(value) == float(spec.null)):
                continue
            u = spec.to_unit(float(value))
            if u <= AT_BOUND or u >= 1.0 - AT_BOUND:
                out.append({"of": of, "param": spec.name, "value": float(value),
                            "bound": "lower" if u <= AT_BOUND else "upper"})
        return out

    @property
    def parameters(self) -> dict[str, dict[str, Any]]:
        """``{candidate id: public parameters (fixed choices included)}``."""
        cands, _ = self.hypothesis.split(self.point)
        return {CANDIDATES[k].id: CANDIDATES[k].public_parameters(v) for k, v in cands.items()}

    @property
    def nuisance(self) -> dict[str, float]:
        """Fitted nuisance constants by name."""
        return self.hypothesis.split(self.point)[1]

    def row(self) -> dict[str, Any]:
        """A JSON-ready ranking entry."""
        return {"candidate": self.key, "ids": self.ids, "k": self.k,
                "parameters": self.parameters, "nuisance": self.nuisance,
                "interval": {k: list(v) for k, v in self.interval.items()},
                "heldout_rms": self.heldout_rms, "heldout_rms_lofo": self.heldout_rms_lofo,
                "heldout_rms_block": self.heldout_rms_block, "score": self.score,
                "aicc_train": self.aicc_train, "rss_train": self.rss, "n_train": self.n,
                "probe_only": self.probe}


# ------------------------------------------------------------------------------------ fitting

def _rms(parts: Sequence[np.ndarray]) -> float:
    """RMS over the folds of one kind; NaN where there is none (a probe on a subset of
    events whose highest flows are all chosen keeps no flow block with training events)."""
    return math.sqrt(float(np.concatenate(parts).mean())) if parts else math.nan


def fit_hypothesis(ev: CampaignEvaluator, hyp: Hypothesis, start: Point,
                   stages: Sequence[Stage], folds: Sequence[Fold], eids: list[str],
                   progress: Callable[[str], None] = lambda _m: None,
                   alternatives: Sequence[Point] = (),
                   coarse: tuple[CampaignEvaluator, list[str]] | None = None
                   ) -> HypothesisFit:
    """Fit ``hyp`` through ``stages`` from ``start`` and from each of ``alternatives``
    (keeping the best end), then compute its interval and held-out score over every point
    evaluated on all events (at full fidelity: ``coarse``, a cheaper engine and its events,
    only evaluates the grids of stages marked ``coarse``).

    Why so many parameters: every hypothesis of a diagnosis is fitted by this one function,
    so all that differs between them comes in: the engine and its events, the hypothesis,
    its starts (``start``, ``alternatives``) and stages, the folds that score it, a coarse
    engine for the grids, and where to report."""
    n0, c0 = ev.n_evals, (coarse[0].n_evals if coarse is not None else 0)
    if any(e not in ev.keys for e in eids):
        ev.base(eids)  # the base model's run defines the compared keys
    n = sum(len(ev.keys[e]) for e in eids)
    costs = HypothesisCosts(ev, hyp, eids)
    rough = HypothesisCosts(coarse[0], hyp, coarse[1]) if coarse is not None else None
    # every start goes through the stages: an alternative that starts worse (a new effect's
    # own fit with the chosen ones at their nulls) can still end better, where the chosen
    # ones had absorbed part of the new effect and the stages cannot walk them back
    best_rss, best = math.inf, start
    for s0 in dict.fromkeys((start, *alternatives)):
        r, p = run_stages(costs, hyp, s0, stages, rough)
        if r < best_rss:
            best_rss, best = r, p
    points = list(costs.points) or [start]
    event_rss = costs.event_rss(points)
    point_rss = event_rss.sum(axis=1)
    specs = hyp.specs
    h = score_folds(costs, folds, points, event_rss)
    intervals: list[tuple[float, float]] = []
    if specs:
        lofo = [(name, train) for name, train, _test in folds
                if not is_block_fold(name) and name in h.fold_points]
        estimates = fold_estimates(
            hyp, best, points, [events_cost(event_rss, eids, train) for _n, train in lofo],
            [h.fold_points[name] for name, _t in lofo])
        intervals = widest(profile_interval(hyp, points, point_rss, len(eids)),
                           jackknife_interval(hyp, best, estimates))
    if not h.sq_lofo + h.sq_block:
        raise ValueError(f"{hyp.key}: no fold has both training and held-out events among "
                         f"{', '.join(eids)}")
    all_sq = np.concatenate(h.sq_lofo + h.sq_block)
    mse = float(all_sq.mean())
    k = len(specs)
    fit = HypothesisFit(
        keys=hyp.keys, nuisance_specs=hyp.nuisance, ranges=hyp.ranges, point=best, k=k,
        intervals=intervals, rss=best_rss, n=n, heldout_rms=math.sqrt(mse),
        heldout_rms_lofo=_rms(h.sq_lofo), heldout_rms_block=_rms(h.sq_block),
        score=aicc(int(all_sq.size), mse, k), heldout=h.held, heldout_sim=h.held_sim,
        fold_values=h.fold_values, predicted_values=h.predicted_values, n_points=len(points),
        n_evals=ev.n_evals - n0 + (coarse[0].n_evals - c0 if coarse is not None else 0),
        rss_start=costs.rss(start), n_heldout=int(all_sq.size),
        top_points=tuple(points[i] for i in np.argsort(point_rss)[:TOP_POINTS]),
        point_rss=dict(zip(points, point_rss.tolist(), strict=True)))
    progress(f"{fit.key}: held-out RMS {fit.heldout_rms:.3f}, score {fit.score:.1f}")
    return fit


def with_searched_intervals(ev: CampaignEvaluator, fit: HypothesisFit, eids: list[str],
                            progress: Callable[[str], None] = lambda _m: None,
                            search: str = "profile") -> HypothesisFit:
    """``fit`` with its intervals searched with new runs, as ``search`` (the policy's
    ``interval_search``) says: widened by walking the cost out from its optimum on every
    event (:func:`vadsim.fit.interval_walk.walk_intervals`) and, with ``search="profile"``,
    by following its profile across islands
    (:func:`vadsim.fit.interval_profile.profile_intervals`); ``search="search"`` returns
    ``fit`` as it is. The rest unchanged.

    Why only for a reported model: the walk runs new points (tens per coordinate), the
    profile hundreds, and only the model a diagnosis reports has its intervals read."""
    hyp = fit.hypothesis
    if not hyp.specs or not fit.point_rss or search == "search":
        return fit
    n0 = ev.n_evals
    costs = HypothesisCosts(ev, hyp, eids)
    intervals = walk_intervals(costs, fit.point, fit.intervals, list(fit.point_rss),
                               np.array(list(fit.point_rss.values())), len(eids))
    per_point = max(len(eids), 1)
    progress(f"{fit.key}: intervals walked out from the optimum "
             f"({(ev.n_evals - n0) // per_point} points)")
    if search == "profile" and len(hyp.specs) > 1:
        n1 = ev.n_evals
        intervals = profile_intervals(costs, fit.point, intervals, fit.rss, len(eids))
        progress(f"{fit.key}: intervals followed along the profile across islands "
                 f"({(ev.n_evals - n1) // per_point} points)")
    return replace(fit, intervals=intervals, n_evals=fit.n_evals + ev.n_evals - n0)
