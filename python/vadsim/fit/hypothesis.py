"""A hypothesis -- some candidate physics plus the nuisance constants -- fitted to a campaign
and scored on held-out events.

Why this module exists: a diagnosis compares many models of the same campaign (the calibrated
base model, each candidate, pairs of candidates), and every one must be fitted and scored the
same way or the comparison is meaningless. Here one :class:`Hypothesis` is a list of candidates
and nuisance constants; its parameters form one point, searched in the unit box of their
:class:`~vadsim.fit.candidates.ParamSpec` (log where the effect spans decades, wrapping where
the constant is periodic). The stages:

* **grid** over some coordinates (the others held: e.g. a candidate's parameters at the
  nuisance constants "none" fitted);
* **refine** locally: bounded Brent along one coordinate, Nelder-Mead in several (the joint
  refinement of a candidate with the nuisance constants);
* **interval**: per parameter, the wider of a 95 % profile interval from every point
  evaluated on all events (``RSS <= RSS_min + 3.84 s^2`` with ``s^2 = RSS_min / (n - k)``)
  and a delete-one-flow jackknife interval from the leave-one-flow-out folds' refits (the
  profile alone assumes independent residuals and is far too narrow for one record's
  correlated features: :func:`jackknife_interval`);
* **held-out score**: each fold chooses, among the points evaluated on every event, the one
  with the lowest *training* cost (refined by a parabola when the hypothesis has a single
  coordinate) and predicts its held-out events. Their cost is the *predictive* one: the
  least rise of the fold's training cost that buys the held-out events' fit,
  ``min_p [train(p) + test(p)] - min_p train(p)``, which is at most the prediction's own
  cost ``test(fold point)``. The error is the RMS standardised residual pooled over all
  held-out predictions, and the score an AICc on those residuals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize, stats

from vadsim.compare import CampaignEvaluator, EventEval
from vadsim.fit.candidates import CANDIDATES, Candidate, ParamSpec
from vadsim.fit.nuisance import NuisanceSpec
from vadsim.model.change import ModelChange

__all__ = ["AT_BOUND", "Fold", "Hypothesis", "HypothesisCosts", "HypothesisFit", "Point", "aicc",
           "fit_hypothesis", "fold_estimates", "jackknife_interval", "predictive_cost", "widest"]

Point = tuple[float, ...]
Fold = tuple[str, list[str], list[str]]

TOP_POINTS = 3
"""How many of the best points a fit keeps as starts for a finer fit."""

COARSE_SEEDS = 3
"""How many of a coarse grid's best points are evaluated again at full fidelity."""


AT_BOUND = 1e-4
"""How close to an end of its search range, as a fraction of the range (of its log for a
log-scaled parameter), a fitted value counts as at that end: points carry 6 significant
digits, so a value the search clipped to a bound sits exactly on it."""


@dataclass(frozen=True)
class Hypothesis:
    """Candidates (by key) and nuisance constants; a point is their parameters in order."""

    keys: tuple[str, ...] = ()
    nuisance: tuple[NuisanceSpec, ...] = ()

    @property
    def candidates(self) -> list[Candidate]:
        """The candidates, in selection order."""
        return [CANDIDATES[k] for k in self.keys]

    @property
    def key(self) -> str:
        """``"none"`` or the candidates' keys joined by ``+``."""
        return "+".join(self.keys) or "none"

    @property
    def specs(self) -> list[ParamSpec]:
        """Every coordinate: the candidates' parameters, then the nuisance constants."""
        return [p for c in self.candidates for p in c.params] + list(self.nuisance)

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
        return Hypothesis((*self.keys, key), self.nuisance)

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
            out = out.combine(c.change(cands[c.key]))
        for p in self.nuisance:
            out = out.combine(p.change(nuis[p.name]))
        return out


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


# ------------------------------------------------------------------------------- search stages

def grid_points(hyp: Hypothesis, start: Point, free: Sequence[int],
                max_per_axis: int | None = None, shape_per_axis: int | None = None
                ) -> list[Point]:
    """The grid over the ``free`` coordinates (each spec's ``grid`` points, at most
    ``max_per_axis``, and at most ``shape_per_axis`` for a candidate parameter without a
    null, e.g. a flow exponent; a periodic one starts at ``start``), the others held at
    ``start``. The start point itself is always included."""
    specs, u0 = hyp.specs, hyp.unit(start)
    axes = []
    for i in free:
        p = specs[i]
        n = p.grid if max_per_axis is None else min(p.grid, max_per_axis)
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


def refine(costs: HypothesisCosts, start: Point, free: Sequence[int], maxfev: int
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
        simplex = np.vstack([x0] + [x0 + np.eye(len(free))[j] * steps[j]
                                    for j in range(len(free))])
        optimize.minimize(cost, x0, method="Nelder-Mead",
                          options={"initial_simplex": simplex, "maxfev": maxfev,
                                   "xatol": 1e-3, "fatol": 1e-3})
    return best


def profile_interval(hyp: Hypothesis, points: list[Point], rss: np.ndarray, n: int
                     ) -> list[tuple[float, float]]:
    """95 % profile interval per coordinate from the evaluated points, widened to the
    neighbouring evaluated values outside it (the interval lies between them)."""
    k = len(hyp.specs)
    best = float(rss.min())
    limit = best + 3.84 * best / max(n - k, 1)
    out = []
    for j, p in enumerate(hyp.specs):
        vals = np.array([pt[j] for pt in points])
        uniq = np.unique(vals)
        prof = np.array([rss[vals == v].min() for v in uniq])
        inside = uniq[prof <= limit]
        lo, hi = float(inside.min()), float(inside.max())
        below, above = uniq[uniq < lo], uniq[uniq > hi]
        out.append((float(below.max()) if below.size else p.lo,
                    float(above.min()) if above.size else p.hi))
    return out


def _is_block(fold_name: str) -> bool:
    """The high-flow block fold (the others leave one flow out)."""
    return fold_name.startswith("block")


def _events_cost(event_rss: np.ndarray, eids: Sequence[str], events: Sequence[str]
                 ) -> np.ndarray:
    """Per point, the summed cost of ``events`` (columns of ``event_rss`` in ``eids``)."""
    return event_rss[:, [eids.index(e) for e in events]].sum(axis=1)


def jackknife_interval(hyp: Hypothesis, best: Point, fold_points: Sequence[Point]
                       ) -> list[tuple[float, float]]:
    """95 % delete-one-flow jackknife interval per coordinate around ``best``.

    Why: the profile interval's threshold assumes independent residuals, but one event's
    residuals are not -- a folded waveform's phase bins and the features of one record share
    its noise and its misfit -- so its ``s^2`` shrinks with every feature added and the
    interval becomes far narrower than the parameter's real uncertainty (blind-12: a mount
    resonance at 600 Hz reported as 620.1-621.0 Hz). Refitting without each flow's events
    (the leave-one-flow-out folds the held-out score already fits) shows how far the data
    can move the estimate: ``se^2 = (m-1)/m sum (u_i - mean u)^2`` over the ``m`` folds'
    estimates (:func:`fold_estimates`) as positions ``u_i`` in the search box (log where
    the parameter is searched in log, differences wrapped for a periodic constant), then
    ``best +- t(0.975, m-1) se``, clipped to the box. With fewer than 3 folds the interval
    is the point itself."""
    specs = hyp.specs
    m = len(fold_points)
    u0 = hyp.unit(best)
    if m < 3 or not specs:
        return [(float(v), float(v)) for v in best]
    t = float(stats.t.ppf(0.975, m - 1))
    offsets = _unit_offsets(hyp, best, fold_points)
    out = []
    for j, p in enumerate(specs):
        d = offsets[:, j]
        periodic = isinstance(p, NuisanceSpec) and p.periodic
        se = math.sqrt((m - 1) / m * float(np.sum((d - d.mean()) ** 2)))
        half = t * se
        if periodic:
            if half >= 0.5:
                out.append((float(p.lo), float(p.hi)))
                continue
            # the ends may pass the period's edge: report them unwrapped around best
            lo_u, hi_u = u0[j] - half, u0[j] + half
            span = p.hi - p.lo
            out.append((float(p.lo + lo_u * span), float(p.lo + hi_u * span)))
            continue
        lo_u, hi_u = max(u0[j] - half, 0.0), min(u0[j] + half, 1.0)
        out.append((float(p.from_unit(lo_u)), float(p.from_unit(hi_u))))
    return out


def _unit_offsets(hyp: Hypothesis, best: Point, points: Sequence[Point]) -> np.ndarray:
    """Points as offsets from ``best`` in the unit box (wrapped for a periodic constant)."""
    u = np.array([hyp.unit(p) for p in points]) - hyp.unit(best)
    for j, p in enumerate(hyp.specs):
        if isinstance(p, NuisanceSpec) and p.periodic:
            u[:, j] = (u[:, j] + 0.5) % 1.0 - 0.5
    return u


def _quadratic_min(x: np.ndarray, c: np.ndarray) -> np.ndarray | None:
    """Minimum of the quadratic least-squares fit of costs ``c`` at points ``x`` (rows),
    within the points' bounding box widened by its width on each side (a fold's optimum may
    lie past a cluster of refinement points, but not far: the fit is local); None where the
    fit is not a bowl (too few points for its coefficients, or a Hessian that is not
    positive definite)."""
    n, k = x.shape
    iu = np.triu_indices(k)
    feats = np.hstack([np.ones((n, 1)), x, (x[:, :, None] * x[:, None, :])[:, iu[0], iu[1]]])
    if n < 2 * feats.shape[1]:
        return None
    coef, _res, rank, _sv = np.linalg.lstsq(feats, c, rcond=None)
    if rank < feats.shape[1]:
        return None
    g = coef[1:k + 1]
    h = np.zeros((k, k))
    h[iu] = coef[k + 1:]
    h = h + h.T  # the diagonal doubles, as d2/dx2 of c_ii x_i^2 is 2 c_ii
    w = np.linalg.eigvalsh(h)
    if not w[0] > 1e-9 * max(abs(w[-1]), 1e-300):
        return None
    lo, hi = x.min(axis=0), x.max(axis=0)
    return np.clip(np.linalg.solve(h, -g), lo - (hi - lo), hi + (hi - lo))


def fold_estimates(hyp: Hypothesis, best: Point, points: Sequence[Point],
                   train_costs: Sequence[np.ndarray], fold_points: Sequence[Point]
                   ) -> list[Point]:
    """Each fold's estimate for the jackknife: the minimum of a quadratic fitted to the
    fold's training cost (``train_costs[i]``, one value per point) over the points nearest
    the optimum in cost, else the fold's own best evaluated point (``fold_points[i]``).

    Why: a fold's best evaluated point is one of the points the full fit searched, which
    cluster around the full fit's optimum; with several coordinates a fold whose own
    optimum lies between them picks one of the cluster and the jackknife spread shrinks
    towards zero. The costs are smooth near the optimum, so a quadratic through the points
    already evaluated (no new run) locates each fold's optimum between them."""
    specs = hyp.specs
    if not specs or len(points) < 3:
        return list(fold_points)
    u = _unit_offsets(hyp, best, points)
    total = np.sum(train_costs, axis=0) if len(train_costs) else np.zeros(len(points))
    free = np.flatnonzero(np.ptp(u, axis=0) > 0)
    n_coef = (len(free) + 1) * (len(free) + 2) // 2
    near = np.argsort(total)[:max(4 * n_coef, 30)]
    x = u[np.ix_(near, free)]
    scale = x.std(axis=0)
    scale[scale == 0] = 1.0
    out = []
    for cost, fallback in zip(train_costs, fold_points, strict=True):
        dx = _quadratic_min(x / scale, np.asarray(cost)[near]) if free.size else None
        if dx is None:
            out.append(fallback)
            continue
        pos = hyp.unit(best)
        pos[free] += dx * scale
        out.append(hyp.from_unit(pos))
    return out


def widest(a: Sequence[tuple[float, float]], b: Sequence[tuple[float, float]]
           ) -> list[tuple[float, float]]:
    """Per coordinate, the hull of two intervals."""
    return [(min(x[0], y[0]), max(x[1], y[1])) for x, y in zip(a, b, strict=True)]


def aicc(n: int, mse: float, k: int) -> float:
    """Corrected Akaike criterion of ``n`` residuals with mean square ``mse`` and ``k``
    fitted parameters."""
    pen = 2 * k + (2 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else math.inf)
    return n * math.log(max(mse, 1e-12)) + pen


def _parabola_min(u: np.ndarray, c: np.ndarray) -> float:
    """Minimum of the parabola through the best point and its neighbours (1-D)."""
    i = int(np.argmin(c))
    if i == 0 or i == len(u) - 1:
        return float(u[i])
    x0, x1, x2 = u[i - 1], u[i], u[i + 1]
    y0, y1, y2 = c[i - 1], c[i], c[i + 1]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    if den == 0:
        return float(x1)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
    if a <= 0:
        return float(x1)
    return float(min(max(-b / (2 * a), x0), x2))


def _fold_point(hyp: Hypothesis, points: list[Point], train_cost: np.ndarray) -> Point:
    if len(hyp.specs) == 1:
        us = np.array([hyp.unit(p)[0] for p in points])
        o = np.argsort(us)
        return hyp.from_unit([_parabola_min(us[o], train_cost[o])])
    return points[int(np.argmin(train_cost))]


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
    :func:`predictive_cost`): that point's values by name."""
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

    @property
    def hypothesis(self) -> Hypothesis:
        """The fitted hypothesis."""
        return Hypothesis(self.keys, self.nuisance_specs)

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


@dataclass
class _Heldout:
    held: dict[str, dict[str, float]] = field(default_factory=dict)
    held_sim: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_values: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_points: dict[str, Point] = field(default_factory=dict)
    sq_lofo: list[np.ndarray] = field(default_factory=list)
    sq_block: list[np.ndarray] = field(default_factory=list)
    predicted_values: dict[str, dict[str, float]] = field(default_factory=dict)
    """Folds whose held-out cost came from a point other than the fold point: its values."""


def predictive_cost(train: np.ndarray, test: np.ndarray, at_fold_point: float
                    ) -> tuple[float, int | None]:
    """A fold's held-out cost over evaluated points (``train``, ``test``: their training and
    held-out sums of squared standardised residuals) and the one that gives it (None: the
    fold point, whose held-out cost is ``at_fold_point``).

    The cost is the least rise of the training cost that buys the held-out events' fit,
    ``min_p [train(p) + test(p)] - min_p train(p)``, capped by ``at_fold_point``. Why not
    simply the fold point's prediction: near a regime boundary an event's response flips
    between parameter values that the training events cannot tell apart (measured: blind-01's
    450 gal/min event at RMS z 14.6 from a fold point whose all-event counterpart fits it at
    0.3; blind-16's 500 gal/min at 6.1), and one such flip then decides a verdict. For a
    model linear in its parameters with unit-variance residuals this rise is exactly the
    prediction's squared error over its *predictive* variance, noise plus the parameters'
    uncertainty, ``r^2 / (1 + h)``: the held-out residual standardised honestly, which a
    flip within the parameters' uncertainty cannot inflate. An event no training-consistent
    point fits keeps its whole cost."""
    train = np.asarray(train, dtype=float)
    test = np.asarray(test, dtype=float)
    if train.size == 0:
        return float(at_fold_point), None
    rise = train + test - float(np.min(train))
    i = int(np.argmin(rise))
    if rise[i] < at_fold_point:
        return float(rise[i]), i
    return float(at_fold_point), None


def score_folds(costs: HypothesisCosts, folds: Sequence[Fold], points: list[Point],
                event_rss: np.ndarray) -> _Heldout:
    """Refit on each fold's training events (choosing among evaluated points) and predict its
    held-out events, at the predictive cost (:func:`predictive_cost`)."""
    hyp, eids, ev = costs.hyp, costs.eids, costs.ev
    names = [p.name for p in hyp.specs]
    out = _Heldout()
    for name, train, test in folds:
        tc = _events_cost(event_rss, eids, train)
        pt = _fold_point(hyp, points, tc) if hyp.specs else ()
        if hyp.specs:
            out.fold_values[name] = dict(zip(names, pt, strict=True))
            out.fold_points[name] = pt
        res = costs.evaluate([pt], test)
        own = float(sum(np.sum(res[(pt, e)].z ** 2) for e in test))
        test_rss = _events_cost(event_rss, eids, test)
        cost, via = predictive_cost(tc, test_rss, own) if hyp.specs else (own, None)
        scale, uniform = 1.0, 0.0
        if via is not None:
            # the held-out residuals of the point that buys their fit, scaled so that their
            # squares sum to the predictive cost (its rise of the training cost included)
            pt = points[via]
            out.predicted_values[name] = dict(zip(names, pt, strict=True))
            res = costs.evaluate([pt], test)
            at = float(test_rss[via])
            if at > 0:
                scale = math.sqrt(cost / at)
            else:  # the point fits them exactly: its rise of the training cost is all
                uniform = math.sqrt(cost / sum(res[(pt, e)].z.size or 1 for e in test))
        block = _is_block(name)
        for e in test:
            z = res[(pt, e)].z * scale + uniform
            (out.sq_block if block else out.sq_lofo).append(z ** 2)
            if not block:
                out.held[e] = dict(zip(ev.keys[e], map(float, z), strict=True))
                out.held_sim[e] = dict(zip(ev.keys[e], map(float, res[(pt, e)].values),
                                           strict=True))
    return out


# ------------------------------------------------------------------------------------ fitting

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
    hypotheses would otherwise cost the product of every axis."""

    grid: tuple[int, ...] | None
    refine: tuple[int, ...]
    maxfev: int
    max_per_axis: int | None = None
    starts: int = 1
    if_rss_below: float = math.inf
    nominal_anchor: bool = False
    coarse: bool = False
    shape_per_axis: int | None = None


def _run_stages(costs: HypothesisCosts, hyp: Hypothesis, start: Point,
                stages: Sequence[Stage], coarse: HypothesisCosts | None = None
                ) -> tuple[float, Point]:
    """The stages from one start: the best (rss, point) reached."""
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
                                                             st.shape_per_axis)))
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
    only evaluates the grids of stages marked ``coarse``)."""
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
        r, p = _run_stages(costs, hyp, s0, stages, rough)
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
                if not _is_block(name) and name in h.fold_points]
        estimates = fold_estimates(
            hyp, best, points, [_events_cost(event_rss, eids, train) for _n, train in lofo],
            [h.fold_points[name] for name, _t in lofo])
        intervals = widest(profile_interval(hyp, points, point_rss, n),
                           jackknife_interval(hyp, best, estimates))
    if not h.sq_lofo + h.sq_block:
        raise ValueError(f"{hyp.key}: no fold has both training and held-out events among "
                         f"{', '.join(eids)}")
    all_sq = np.concatenate(h.sq_lofo + h.sq_block)
    mse = float(all_sq.mean())
    k = len(specs)
    fit = HypothesisFit(
        keys=hyp.keys, nuisance_specs=hyp.nuisance, point=best, k=k, intervals=intervals,
        rss=best_rss, n=n, heldout_rms=math.sqrt(mse),
        heldout_rms_lofo=_rms(h.sq_lofo), heldout_rms_block=_rms(h.sq_block),
        score=aicc(int(all_sq.size), mse, k), heldout=h.held, heldout_sim=h.held_sim,
        fold_values=h.fold_values, predicted_values=h.predicted_values, n_points=len(points),
        n_evals=ev.n_evals - n0 + (coarse[0].n_evals - c0 if coarse is not None else 0),
        rss_start=costs.rss(start), n_heldout=int(all_sq.size),
        top_points=tuple(points[i] for i in np.argsort(point_rss)[:TOP_POINTS]),
        point_rss=dict(zip(points, point_rss.tolist(), strict=True)))
    progress(f"{fit.key}: held-out RMS {fit.heldout_rms:.3f}, score {fit.score:.1f}")
    return fit
