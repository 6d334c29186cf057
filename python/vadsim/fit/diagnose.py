"""Missing-physics diagnosis: locate a mismatch, fit candidate physics, select on held-out data.

Why this module exists: the dissertation could only say in prose what its model probably
misses ("hydraulics at high flow"). A diagnosis here does it with numbers:

1. **Locate.** The base model is compared with the campaign feature by feature
   (:func:`vadsim.validate.measure_event`: the same sensor chain, standardised residuals) and
   :func:`vadsim.locate.locate` says which features of which sensor are offset or trend with
   flow; events whose RMS residual exceeds 2 are listed too.
2. **Fit.** Every candidate of :mod:`vadsim.candidates` is fitted by least squares on the
   standardised residuals of all events: a grid over its parameter box (11 points per
   parameter; 40 and 24 along a resonance frequency, whose cost minima are as narrow as the
   resonance) and a local refinement (bounded Brent in 1-D, Nelder-Mead in 2-D). A 95 %
   interval comes from the cost profile: ``RSS <= RSS_min + 3.84 s^2`` with
   ``s^2 = RSS_min / (n - k)``.
3. **Score on held-out events.** Leave-one-flow-out folds and a block that holds out the
   highest flows (the top 30 %, at least two events). Each fold refits on its training events
   alone: among the parameter values evaluated on every event (the grid and the full fit's
   refinement, so no run is repeated per fold) it takes the one with the lowest *training*
   cost, refined in 1-D by the parabola through it and its neighbours, and predicts the
   held-out events with it. The base model, which has nothing to fit, is scored on the same
   events. The held-out error
   is the RMS standardised residual pooled over all held-out predictions.
4. **Select.** Candidates are ranked by an AICc computed on the held-out residuals,
   ``n ln(MSE) + 2k + 2k(k+1)/(n-k-1)`` (``n`` held-out residuals, ``k`` fitted parameters);
   the base model is the entry ``"none"`` with ``k = 0``. The best candidate is chosen only if
   it beats ``"none"`` by ``min_delta`` (default 10, "very strong" on Burnham and Anderson's
   scale) *and* cuts the held-out RMS by ``min_reduction`` (default 30 %); otherwise the
   answer is ``"none"``. Both thresholds are checked by tests and by the blind benchmark on
   campaigns the true model wrote.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import os
import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import optimize

from vadsim._progress import ProgressArg, bar, reporter
from vadsim.campaigns import Campaign, campaign_preset, load_any_campaign
from vadsim.compare import CampaignEvaluator, EventEval, ModelChange
from vadsim.fit.candidates import CANDIDATES, Candidate, keys_for
from vadsim.fit.locate import Mismatch, locate
from vadsim.model.presets import Preset
from vadsim.model.settings import RunSettings
from vadsim.signals.features import Feature

__all__ = ["CandidateFit", "Diagnosis", "diagnose", "fmt_value", "make_folds", "predict"]

FAILED_RESIDUAL = 10.0
"""Residual of every feature of an event whose run fails or loses a compared feature."""



# ------------------------------------------------------------------------------ evaluation

Point = tuple[float, ...]


class _CandidateCosts:
    """A candidate's evaluations on the comparison engine, by parameter point; remembers the
    points evaluated on every event (for the profile interval and the folds)."""

    def __init__(self, ev: CampaignEvaluator, cand: Candidate | None, eids: list[str]) -> None:
        self.ev, self.cand, self.eids = ev, cand, eids
        self.points: dict[Point, None] = {}

    def _item(self, point: Point) -> tuple[Hashable, ModelChange | None]:
        if self.cand is None:
            return "base", None
        names = [p.name for p in self.cand.params]
        return (self.cand.key, point), self.cand.change(dict(zip(names, point, strict=True)))

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
        got = self.evaluate([point])
        return float(sum(np.sum(got[(point, e)].z ** 2) for e in self.eids))

    def event_rss(self, points: Sequence[Point]) -> np.ndarray:
        """Points x events sums of squared residuals."""
        got = self.evaluate(points)
        return np.array([[np.sum(got[(p, e)].z ** 2) for e in self.eids] for p in points])


# ---------------------------------------------------------------------------------- results

@dataclass
class CandidateFit:
    """One candidate fitted to the campaign and scored on held-out events."""

    key: str
    id: str
    k: int
    values: dict[str, float]
    parameters: dict[str, Any]
    interval: dict[str, tuple[float, float]]
    rss: float
    n: int
    aicc_train: float
    heldout_rms: float
    heldout_rms_lofo: float
    heldout_rms_block: float
    score: float
    heldout: dict[str, dict[str, float]] = field(default_factory=dict, repr=False)
    heldout_sim: dict[str, dict[str, float]] = field(default_factory=dict, repr=False)
    fold_values: dict[str, dict[str, float]] = field(default_factory=dict)
    n_evals: int = 0

    def row(self) -> dict[str, Any]:
        """A JSON-ready ranking entry."""
        return {"candidate": self.id, "key": self.key, "k": self.k,
                "parameters": self.parameters,
                "interval": {k: list(v) for k, v in self.interval.items()},
                "heldout_rms": self.heldout_rms, "heldout_rms_lofo": self.heldout_rms_lofo,
                "heldout_rms_block": self.heldout_rms_block, "score": self.score,
                "aicc_train": self.aicc_train, "rss_train": self.rss, "n_train": self.n}


@dataclass
class Diagnosis:
    """Everything a diagnosis found; :meth:`as_json` is what ``vadsim diagnose --json`` prints."""

    campaign: Campaign
    preset: Preset
    located: list[Mismatch]
    located_events: list[dict[str, Any]]
    baseline: CandidateFit
    ranking: list[CandidateFit]
    chosen: CandidateFit | None
    recorded: dict[str, dict[str, Feature]]
    keys: dict[str, list[str]]
    baseline_sim: dict[str, dict[str, float]]
    folds: list[tuple[str, list[str], list[str]]]
    settings: dict[str, Any]
    elapsed_s: float
    n_evals: int
    prediction: dict[str, Any] | None = None

    @property
    def missing_physics(self) -> str:
        """The chosen candidate's id, or ``"none"``."""
        return self.chosen.id if self.chosen is not None else "none"

    def as_json(self) -> dict[str, Any]:
        """One JSON-ready object (the keys ``vadsim diagnose --json`` promises)."""
        best = self.chosen
        out: dict[str, Any] = {
            "campaign": self.campaign.name,
            "missing_physics": self.missing_physics,
            "parameters": best.parameters if best else {},
            "intervals": {k: list(v) for k, v in best.interval.items()} if best else {},
            "located": [m.as_dict() for m in self.located],
            "located_events": self.located_events,
            "heldout_error_before": self.baseline.heldout_rms,
            "heldout_error_after": best.heldout_rms if best else self.baseline.heldout_rms,
            "ranking": [self.baseline.row()] + [f.row() for f in self.ranking],
            "thresholds": {k: self.settings[k] for k in ("min_delta", "min_reduction")},
            "elapsed_s": self.elapsed_s,
            "evaluations": self.n_evals,
        }
        if self.prediction is not None:
            out["prediction"] = self.prediction
        return _jsonable(out)

    def summary(self) -> str:
        """A few lines for a terminal."""
        lines = [f"{self.campaign.name}: {len(self.campaign.events)} events, "
                 f"{self.n_evals} evaluations in {self.elapsed_s:.0f} s"]
        if self.located:
            lines.append("located: " + "; ".join(m.describe() for m in self.located[:4]))
        else:
            lines.append("located: no feature is offset or trends with flow beyond the threshold")
        lines.append(f"{'candidate':26s} {'k':>2s} {'held-out RMS (LOFO/block)':>26s} "
                     f"{'score':>9s}  parameters")
        for f in [self.baseline, *self.ranking]:
            par = ", ".join(f"{k}={fmt_value(v)}" for k, v in f.parameters.items())
            lines.append(f"{f.key:26s} {f.k:2d} {f.heldout_rms:6.3f} ({f.heldout_rms_lofo:.2f}/"
                         f"{f.heldout_rms_block:.2f}) {f.score:9.1f}  {par}")
        if self.chosen is None:
            lines.append("missing physics: none (no candidate beats the base model by the "
                         "thresholds)")
        else:
            c = self.chosen
            par = ", ".join(f"{k} = {fmt_value(v)}" + _interval_text(c.interval.get(k))
                            for k, v in c.parameters.items())
            lines.append(f"missing physics: {c.id} ({par}); held-out RMS "
                         f"{self.baseline.heldout_rms:.2f} -> {c.heldout_rms:.2f}")
        if self.prediction:
            p = self.prediction
            lines.append(f"prediction of {p['campaign']}: RMS {p['error_before']:.2f} -> "
                         f"{p['error_after']:.2f}")
            if "best_ranked" in p:
                b = p["best_ranked"]
                lines.append(f"  (the best-ranked candidate, {b['key']}, not chosen, would give "
                             f"{b['error']:.2f})")
        return "\n".join(lines)


def _interval_text(interval: tuple[float, float] | None) -> str:
    return f" [{fmt_value(interval[0])}, {fmt_value(interval[1])}]" if interval else ""


def fmt_value(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    return obj


# ------------------------------------------------------------------------------------ folds

def make_folds(campaign: Campaign, block_fraction: float = 0.3
               ) -> list[tuple[str, list[str], list[str]]]:
    """Leave-one-flow-out folds and one high-flow block: ``(name, train ids, test ids)``."""
    flows = sorted({ev.flow_gpm for ev in campaign.events})
    if len(flows) < 3:
        raise ValueError(f"campaign {campaign.name!r} has {len(flows)} distinct flows; a "
                         "held-out score needs at least 3")
    folds = []
    for q in flows:
        test = [ev.id for ev in campaign.events if ev.flow_gpm == q]
        train = [ev.id for ev in campaign.events if ev.flow_gpm != q]
        folds.append((f"flow {q:g}", train, test))
    n_block = max(2, int(math.ceil(block_fraction * len(flows))))
    n_block = min(n_block, len(flows) - 2)
    top = set(flows[-n_block:])
    test = [ev.id for ev in campaign.events if ev.flow_gpm in top]
    train = [ev.id for ev in campaign.events if ev.flow_gpm not in top]
    folds.append((f"block >= {min(top):g}", train, test))
    return folds


# ------------------------------------------------------------------------------------ fitting

def _grid(cand: Candidate) -> list[tuple[float, ...]]:
    if len(cand.params) > 2:
        raise ValueError(f"{cand.key}: at most 2 parameters are supported")
    axes = [np.linspace(0.0, 1.0, p.grid) for p in cand.params]
    us = [(a,) for a in axes[0]] if len(axes) == 1 else [(a, b) for a in axes[0]
                                                          for b in axes[1]]
    return [_point(cand, u) for u in us]


def _point(cand: Candidate, u: Sequence[float]) -> tuple[float, ...]:
    return tuple(float(f"{p.from_unit(x):.6g}") for p, x in zip(cand.params, u, strict=True))


def _unit(cand: Candidate, point: tuple[float, ...]) -> np.ndarray:
    return np.array([p.to_unit(v) for p, v in zip(cand.params, point, strict=True)])


def _parabola_min(u: np.ndarray, c: np.ndarray) -> float:
    """Minimum of the parabola through the best point and its neighbours (1-D grid)."""
    i = int(np.argmin(c))
    if i == 0 or i == len(u) - 1:
        return float(u[i])
    x0, x1, x2 = u[i - 1], u[i], u[i + 1]
    y0, y1, y2 = c[i - 1], c[i], c[i + 1]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
    if a <= 0:
        return float(x1)
    return float(min(max(-b / (2 * a), x0), x2))


def _interval(cand: Candidate, pts: list[tuple[float, ...]], rss: np.ndarray, n: int
              ) -> dict[str, tuple[float, float]]:
    """95 % profile interval per parameter from the evaluated points."""
    k = len(cand.params)
    best = float(rss.min())
    s2 = best / max(n - k, 1)
    limit = best + 3.84 * s2
    out: dict[str, tuple[float, float]] = {}
    for j, p in enumerate(cand.params):
        vals = np.array([pt[j] for pt in pts])
        uniq = np.unique(vals)
        prof = np.array([rss[vals == v].min() for v in uniq])
        inside = uniq[prof <= limit]
        lo, hi = float(inside.min()), float(inside.max())
        # widen to the neighbouring evaluated values outside: the interval lies between them
        below = uniq[uniq < lo]
        above = uniq[uniq > hi]
        lo = float(below.max()) if below.size else p.lo
        hi = float(above.min()) if above.size else p.hi
        out[p.name] = (lo, hi)
    return out


def _aicc(n: int, mse: float, k: int) -> float:
    mse = max(mse, 1e-12)
    pen = 2 * k + (2 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else math.inf)
    return n * math.log(mse) + pen


def _refine(costs: _CandidateCosts, cand: Candidate, grid: list[Point], total: np.ndarray
            ) -> tuple[float, Point]:
    """Refine the best grid point: bounded Brent in 1-D, Nelder-Mead in 2-D."""
    i = int(np.argmin(total))
    u0 = _unit(cand, grid[i])

    def cost(u: np.ndarray) -> float:
        return costs.rss(_point(cand, np.clip(u, 0, 1)))

    if len(cand.params) == 1:
        du = 1.0 / (cand.params[0].grid - 1)
        lo, hi = max(0.0, u0[0] - du), min(1.0, u0[0] + du)
        r = optimize.minimize_scalar(lambda x: cost(np.array([x])), bounds=(lo, hi),
                                     method="bounded", options={"xatol": du / 40, "maxiter": 10})
        found = (float(r.fun), _point(cand, [r.x]))
    else:
        step = np.array([1.0 / (p.grid - 1) for p in cand.params])
        simplex = np.clip(np.array([u0, u0 + [step[0] / 2, 0], u0 + [0, step[1] / 2]]), 0, 1)
        r = optimize.minimize(cost, u0, method="Nelder-Mead",
                              options={"initial_simplex": simplex, "maxfev": 24,
                                       "xatol": 1e-3, "fatol": 1e-3})
        found = (float(r.fun), _point(cand, np.clip(r.x, 0, 1)))
    return min([found, (float(total[i]), grid[i])])


def _fold_point(cand: Candidate | None, points: list[Point], train_cost: np.ndarray) -> Point:
    """The fold's parameter: among the points evaluated on every event, the one with the lowest
    training cost, refined in 1-D by the parabola through it and its neighbours."""
    if cand is None:
        return ()
    if len(cand.params) == 1:
        us = np.array([_unit(cand, p)[0] for p in points])
        o = np.argsort(us)
        return _point(cand, [_parabola_min(us[o], train_cost[o])])
    return points[int(np.argmin(train_cost))]


@dataclass
class _Heldout:
    held: dict[str, dict[str, float]] = field(default_factory=dict)
    held_sim: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_values: dict[str, dict[str, float]] = field(default_factory=dict)
    sq_lofo: list[np.ndarray] = field(default_factory=list)
    sq_block: list[np.ndarray] = field(default_factory=list)


def _score_folds(costs: _CandidateCosts, folds, points: list[Point],
                 event_rss: np.ndarray) -> _Heldout:
    """Refit on each fold's training events (choosing among evaluated points) and predict its
    held-out events."""
    cand, eids, ev = costs.cand, costs.eids, costs.ev
    out = _Heldout()
    for name, train, test in folds:
        tc = (event_rss[:, [eids.index(e) for e in train]].sum(axis=1) if cand is not None
              else np.empty(0))
        pt = _fold_point(cand, points, tc)
        if cand is not None:
            out.fold_values[name] = dict(zip((p.name for p in cand.params), pt, strict=True))
        res = costs.evaluate([pt], test)
        for e in test:
            z = res[(pt, e)].z
            (out.sq_block if name.startswith("block") else out.sq_lofo).append(z ** 2)
            if not name.startswith("block"):
                out.held[e] = dict(zip(ev.keys[e], map(float, z), strict=True))
                out.held_sim[e] = dict(zip(ev.keys[e], map(float, res[(pt, e)].values),
                                           strict=True))
    return out


def _fit_candidate(ev: CampaignEvaluator, cand: Candidate | None, folds, eids: list[str],
                   progress: Callable[[str], None]) -> CandidateFit:
    t0 = time.perf_counter()
    ev.base(eids)
    n = sum(len(ev.keys[e]) for e in eids)
    costs = _CandidateCosts(ev, cand, eids)
    interval: dict[str, tuple[float, float]] = {}
    if cand is None:
        best: Point = ()
        points: list[Point] = [()]
        event_rss = costs.event_rss(points)
        rss = float(event_rss.sum())
    else:
        grid = _grid(cand)
        total = costs.event_rss(grid).sum(axis=1)
        rss, best = _refine(costs, cand, grid, total)
        points = list(costs.points)  # every point evaluated on all events
        event_rss = costs.event_rss(points)
        interval = _interval(cand, points, event_rss.sum(axis=1), n)
    h = _score_folds(costs, folds, points, event_rss)
    all_sq = np.concatenate(h.sq_lofo + h.sq_block)
    mse = float(all_sq.mean())
    k = len(cand.params) if cand is not None else 0
    values = dict(zip((p.name for p in cand.params), best, strict=True)) if cand else {}
    fit = CandidateFit(
        key=cand.key if cand is not None else "none",
        id=cand.id if cand is not None else "none", k=k, values=values,
        parameters=cand.public_parameters(values) if cand else {},
        interval=interval, rss=rss, n=n, aicc_train=_aicc(n, rss / n, k),
        heldout_rms=math.sqrt(mse),
        heldout_rms_lofo=math.sqrt(float(np.concatenate(h.sq_lofo).mean())),
        heldout_rms_block=math.sqrt(float(np.concatenate(h.sq_block).mean())),
        score=_aicc(int(all_sq.size), mse, k), heldout=h.held, heldout_sim=h.held_sim,
        fold_values=h.fold_values,
    )
    progress(f"{fit.key}: held-out RMS {fit.heldout_rms:.3f}, score {fit.score:.1f} "
             f"({time.perf_counter() - t0:.1f} s)")
    return fit


def _fit_task(camp: Campaign, settings: RunSettings, phases: int, key: str, folds,
              eids: list[str]) -> CandidateFit:
    """One candidate's fit in its own process (the feature code holds the GIL)."""
    with CampaignEvaluator(camp, settings, phases=phases, workers=1) as ev:
        fit = _fit_candidate(ev, CANDIDATES[key], folds, eids, lambda _m: None)
        fit.n_evals = ev.n_evals
        return fit


def _fit_all(camp: Campaign, settings: RunSettings, phases: int, keys: list[str], folds,
             eids: list[str], ev: CampaignEvaluator, say: Callable[[str], None],
             tick: Callable[[], None] = lambda: None) -> list[CandidateFit]:
    """Fit every candidate: in worker processes when there are several workers."""
    if ev.workers <= 1 or len(keys) <= 1:
        fits = []
        for k in keys:
            n0 = ev.n_evals
            f = _fit_candidate(ev, CANDIDATES[k], folds, eids, say)
            f.n_evals = ev.n_evals - n0
            fits.append(f)
            tick()
        return fits
    # model-side candidates first: they take longest
    order = sorted(keys, key=lambda k: CANDIDATES[k].side != "model")
    # fork: the workers inherit the imported modules and need no importable __main__ (a
    # user's script without a main guard works); the parent's threads are idle here
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    with ProcessPoolExecutor(max_workers=min(ev.workers, len(keys)), mp_context=ctx) as pool:
        futures = {k: pool.submit(_fit_task, camp, settings, phases, k, folds, eids)
                   for k in order}
        out: dict[str, CandidateFit] = {}
        for fut in as_completed(futures.values()):
            f = fut.result()
            out[f.key] = f
            ev.n_evals += f.n_evals
            tick()
            say(f"{f.key}: held-out RMS {f.heldout_rms:.3f}, score {f.score:.1f}")
    return [out[k] for k in keys]


# ------------------------------------------------------------------------------------- public

def diagnose(
    campaign: str | os.PathLike[str] | Campaign,
    *,
    candidates: Sequence[str] | None = None,
    preset: Preset | None = None,
    overrides: Mapping[str, float] | None = None,
    cycles: float = 300,
    analyse_cycles: float = 200,
    phases: int = 4,
    min_delta: float = 10.0,
    min_reduction: float = 0.3,
    block_fraction: float = 0.3,
    workers: int | None = None,
    progress: ProgressArg = True,
) -> Diagnosis:
    """Locate the mismatch, fit every candidate, rank on held-out events and choose.

    Parameters
    ----------
    campaign
        A campaign folder or TOML file, a :class:`Campaign`, or ``"thesis:7in-cde"`` etc.
    candidates
        Candidate ids or keys (default: all of :data:`vadsim.candidates.CANDIDATES`).
    preset, overrides
        The base model (default: the campaign's tool and bit) and changes to it.
    cycles, analyse_cycles
        Run length and analysed window (excitation cycles); campaigns with recorded time
        series are compared over the same number of windows the recording has.
    phases
        Sampling phases the simulated features are averaged over.
    min_delta, min_reduction
        A candidate is chosen only if its held-out AICc is ``min_delta`` below the base
        model's and its held-out RMS is ``min_reduction`` (fraction) below the base model's.
    block_fraction
        Fraction of the distinct flows (highest first) held out as one block.
    workers
        Threads (default: all cores).
    progress
        ``True`` (default): a progress bar over the candidates on stderr; ``False``: silent;
        a callable: called with one line per finished step.

    Returns
    -------
    Diagnosis
    """
    t0 = time.perf_counter()
    say = reporter(progress)
    camp = load_any_campaign(campaign)
    _check_thresholds(min_delta, min_reduction, block_fraction, phases)
    keys = keys_for(list(candidates) if candidates is not None else None)
    settings = RunSettings(preset or campaign_preset(camp), overrides=overrides or {},
                           cycles=cycles, analyse_cycles=analyse_cycles)
    folds = make_folds(camp, block_fraction)
    eids = [e.id for e in camp.events]
    with CampaignEvaluator(camp, settings, phases=phases,
                           workers=workers or os.cpu_count() or 1) as ev, \
            bar(progress, len(keys) + 1, f"diagnose {camp.name}", "candidate") as b:
        base = _fit_candidate(ev, None, folds, eids, say)
        b.update()
        base_eval = ev.base(eids)
        located, located_events = _locate(camp, ev, base_eval)
        say(f"located: {len(located)} feature(s), {len(located_events)} event(s) with RMS z > 2")
        fits = _fit_all(camp, settings, phases, keys, folds, eids, ev, say, b.update)
        ranking = sorted(fits, key=lambda f: f.score)
        best = ranking[0] if ranking else None
        chosen = None
        if (best is not None and best.score <= base.score - min_delta
                and best.heldout_rms <= (1.0 - min_reduction) * base.heldout_rms):
            chosen = best
        baseline_sim = {e: dict(zip(ev.keys[e], map(float, base_eval[e].values), strict=True))
                        for e in eids}
        return Diagnosis(
            campaign=camp, preset=settings.preset, located=located,
            located_events=located_events, baseline=base, ranking=ranking, chosen=chosen,
            recorded=ev.targets, keys=dict(ev.keys), baseline_sim=baseline_sim, folds=folds,
            settings=dict(cycles=cycles, analyse_cycles=analyse_cycles, phases=phases,
                          min_delta=min_delta, min_reduction=min_reduction,
                          block_fraction=block_fraction, candidates=keys,
                          overrides=dict(settings.overrides)),
            elapsed_s=time.perf_counter() - t0, n_evals=ev.n_evals,
        )


def _check_thresholds(min_delta: float, min_reduction: float, block_fraction: float,
                      phases: int) -> None:
    if not (min_delta >= 0 and math.isfinite(min_delta)):
        raise ValueError(f"min_delta = {min_delta!r} must be a finite number >= 0")
    if not (0.0 <= min_reduction < 1.0):
        raise ValueError(f"min_reduction = {min_reduction!r} must be in [0, 1)")
    if not (0.0 < block_fraction < 1.0):
        raise ValueError(f"block_fraction = {block_fraction!r} must be in (0, 1)")
    if not (isinstance(phases, int) and phases >= 1):
        raise ValueError(f"phases = {phases!r} must be an integer >= 1")


def _locate(camp: Campaign, ev: CampaignEvaluator, base_eval: Mapping[str, EventEval]
            ) -> tuple[list[Mismatch], list[dict[str, Any]]]:
    """Where the base model disagrees: features offset or trending with flow, and the events
    whose RMS standardised residual exceeds 2 (with their three worst features)."""
    eids = list(base_eval)
    residuals = pd.DataFrame({e: dict(zip(ev.keys[e], base_eval[e].z, strict=True))
                              for e in eids}).T.reindex(eids)
    flows = {e.id: e.flow_gpm for e in camp.events}
    located_events = []
    for e in eids:
        z = base_eval[e].z
        rms = float(np.sqrt(np.mean(z ** 2)))
        if rms > 2.0:
            worst = np.argsort(-np.abs(z))[:3]
            located_events.append({"event": e, "flow_gpm": flows[e], "rms_z": rms,
                                   "worst": {ev.keys[e][j]: float(z[j]) for j in worst}})
    return locate(residuals, flows), located_events


def _rms_of(got: Mapping[tuple[Point, str], EventEval], pt: Point, eids: Sequence[str]
            ) -> tuple[float, dict[str, float]]:
    """Pooled and per-event RMS standardised residual of one point."""
    z = np.concatenate([got[(pt, e)].z for e in eids])
    return (float(np.sqrt(np.mean(z ** 2))),
            {e: float(np.sqrt(np.mean(got[(pt, e)].z ** 2))) for e in eids})


def predict(diag: Diagnosis, campaign: str | os.PathLike[str] | Campaign, *,
            preset: Preset | None = None, workers: int | None = None) -> dict[str, Any]:
    """Predict another campaign with the base model and with the diagnosis' chosen physics
    (fitted values, nothing refitted), e.g. the 7in RC test from a fit on the CDE test.

    Returns a JSON-ready dict (also stored as ``diag.prediction``): RMS standardised
    residual before/after and per event.
    """
    camp = load_any_campaign(campaign)
    s = diag.settings
    settings = RunSettings(preset or campaign_preset(camp), overrides=s["overrides"],
                           cycles=s["cycles"], analyse_cycles=s["analyse_cycles"])
    eids = [e.id for e in camp.events]
    with CampaignEvaluator(camp, settings, phases=s["phases"],
                           workers=workers or os.cpu_count() or 1) as ev:
        base = _CandidateCosts(ev, None, eids).evaluate([()])
        before, per_before = _rms_of(base, (), eids)
        out: dict[str, Any] = {"campaign": camp.name, "physics": diag.missing_physics,
                               "error_before": before, "error_after": before}
        per_event = {e: {"flow_gpm": ev.events[e].flow_gpm, "rms_before": per_before[e]}
                     for e in eids}
        # the chosen physics, and what the best-ranked candidate would predict even though it
        # was not chosen: evidence for the next campaign, not a verdict
        top = diag.ranking[0] if diag.ranking and diag.ranking[0] is not diag.chosen else None
        for fit, label in ((diag.chosen, "after"), (top, "best_ranked")):
            if fit is None:
                continue
            cand = CANDIDATES[fit.key]
            pt = tuple(fit.values[p.name] for p in cand.params)
            got = _CandidateCosts(ev, cand, eids).evaluate([pt])
            err, per = _rms_of(got, pt, eids)
            if label == "after":
                out["error_after"] = err
            else:
                out["best_ranked"] = {"key": fit.key, "parameters": fit.parameters,
                                      "error": err}
            for e in eids:
                per_event[e][f"rms_{label}"] = per[e]
        out["events"] = per_event
    diag.prediction = _jsonable(out)
    return diag.prediction


def __getattr__(name: str) -> Any:
    # vadsim 0.1 kept the report writer here; it now lives in vadsim.report
    if name == "write_diagnosis_report":
        from vadsim.report.diagnosis import write_diagnosis_report

        return write_diagnosis_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
