"""How a diagnosis searches: cheap probes that rank candidates, and the pairs of effects it
tries when no single one explains the campaign.

A probe fits a candidate on a coarse grid on the coarse engine (a subset of events, shorter
runs); only the most promising earn a full fit (:func:`screened`). Pairs come from the first
step's probes (:func:`pair_prospects`, :func:`pair_step`), or, as a last resort, from a
joint probe of every model-side pair (:func:`screen_all_pairs`). The constants below set how
much of each is done.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from vadsim.compare import CampaignEvaluator
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis.evidence import Context, restricted
from vadsim.fit.diagnosis.hypotheses import (
    PROBE_PER_AXIS,
    Job,
    candidate_stages,
    job,
    probe_stage,
)
from vadsim.fit.diagnosis.parallel import Tick, fit_all
from vadsim.fit.diagnosis.policy import Policy, any_vanishes, at_null
from vadsim.fit.hypothesis import Hypothesis, HypothesisCosts, Point
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.fit.stages import Stage

__all__ = ["PAIR_FULL", "PAIR_MIN_CUT", "PAIR_SCREEN_EVENTS", "PAIR_SCREEN_FULL",
           "PAIR_SCREEN_MIN_GAIN", "PAIR_SCREEN_REPORT", "PAIR_SCREEN_SHAPE_PER_AXIS",
           "PAIR_TOP", "PROBE_MIN_GAIN", "SOLO_FULL", "anchor_key", "current_cost",
           "fitted_prospects", "pair_probes", "pair_prospects", "pair_step",
           "record_pair_probes", "same_point", "screen_all_pairs", "screen_pairs", "screened",
           "single_probe_cost"]

PROBE_MIN_GAIN = 0.03
"""A probe must cut the training cost by this fraction of its start's, and of the current
model's own best cost among the probes (:func:`current_cost`), to earn a full fit (one that
does not cannot pass the selection's 30 % cut in held-out error)."""

SOLO_FULL = 2
"""From the second step on, the candidates that ranked best alone in the first step are
fitted fully whatever their probe: a second effect that the first one absorbed does not
show in a probe on top of it, where the first is held at its absorbing values (measured:
hydraulic force + anvil friction, whose friction probe on top of the hydraulic force ranked
outside the top 4)."""

PAIR_TOP = 4
"""Candidates a pair step combines (:func:`pair_prospects`): the first step's probes that cut
the cost most, relative to the base model at the same nuisance values (6 pairs)."""

PAIR_MIN_CUT = 0.3
"""RMS cut a pair's joint probe must make on the best single probe to earn a full fit
(measured on the 10-event pair benchmark: hydraulic force + friction 659 against 6,898, a
69 % cut in RMS; the next pair did not improve on the best single probe at all)."""

PAIR_FULL = 2
"""Pairs fully fitted in a pair step (:func:`pair_step`): the ones whose joint probes cut the
cost most."""

PAIR_SCREEN_EVENTS = 3
"""Events the screen of every model-side pair (:func:`screen_all_pairs`) evaluates: those the
calibrated base model fits worst (an effect pair that cancels elsewhere shows there)."""

PAIR_SCREEN_SHAPE_PER_AXIS = 3
"""Grid points per axis, in that screen, of a parameter without a null (a flow exponent, a
contact law's shape); the others keep :data:`PROBE_PER_AXIS`. Measured on blind-09 (143
pairs, 7,995 points on 3 events): the true pair second of 143."""

PAIR_SCREEN_MIN_GAIN = 0.3
"""Cut in training cost on the screen's events, against the base model at the same
nuisance values, that a pair's screen probe must make to earn a full fit (blind-09: the true
pair 0.509 of the base cost on a coarse grid whose nearest point is 25 % off in force, where
the truth leaves 0.002)."""

PAIR_SCREEN_FULL = 3
"""Pairs fully fitted after the screen: the ones whose probes cut the cost most."""

PAIR_SCREEN_REPORT = 10
"""Screen probes kept in the report (``pairs_probed``), best first."""


def screened(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
              current: HypothesisFit, pool: list[str],
              top: int, say: Callable[[str], None], tick: Tick,
              solo: Mapping[str, HypothesisFit],
              probes_out: list[HypothesisFit] | None = None) -> list[HypothesisFit]:
    """Every candidate on a coarse probe (a grid of at most ``PROBE_PER_AXIS`` points per
    axis, at the calibrated and at the nominal nuisance values, on the coarse engine), then
    the full fit of the ``top`` whose probe cut the training cost most (by at least
    :data:`PROBE_MIN_GAIN`) and of the :data:`SOLO_FULL` best first-step candidates
    (``solo``, best first); the others keep their probe's fit. ``probes_out`` receives every
    probe (with its cost at each grid point).

    Why so many parameters: this is one step of
    :func:`~vadsim.fit.diagnosis.selection.forward_selection` and takes that loop's state as
    it is: the context and both engines, the model extended, the candidates left and how many
    to fit fully, the first step's fits (``solo``), the progress callbacks (``say``,
    ``tick``) and where to collect the probes."""
    probes = [Job(current.hypothesis.extend(k), job(current, k).start,
                   (probe_stage(current.hypothesis.extend(k)),), probe=True) for k in pool]
    fits = fit_all(ctx, probes, ev, coarse_ev, say)
    if probes_out is not None:
        probes_out.extend(fits)
    ranked = sorted(range(len(pool)), key=lambda i: fits[i].rss)
    own = current_cost(fits)
    best = [i for i in ranked
            if fits[i].rss <= (1 - PROBE_MIN_GAIN) * min(fits[i].rss_start, own)][:top]
    chosen_ids = set(current.ids)
    for k in [k for k in solo if CANDIDATES[k].id not in chosen_ids][:SOLO_FULL]:
        if k in pool and pool.index(k) not in best:
            best.append(pool.index(k))
    best = best or ranked[:1]
    say(f"screened {len(pool)} candidates; fitting {', '.join(pool[i] for i in best)} fully")
    full = fit_all(ctx, [job(current, pool[i], solo.get(pool[i]), fits[i]) for i in best],
                    ev, coarse_ev, say)
    for i, f in zip(best, full, strict=True):
        fits[i] = f
    for _ in pool:
        tick()
    return fits


def current_cost(probes: Sequence[HypothesisFit]) -> float:
    """The lowest cost the probes found for the model they extend: at the points where
    their new candidate sits at its null, at either anchor (the current nuisance values or
    the nominal ones); inf where no probe's candidate has a null.

    Why: a probe's grid is laid at both anchors, and where the current model itself costs
    less at the nominal ones (on the probe's events and shorter runs), every probe beats its
    start there whatever its candidate. Measured on the 10-event hydraulic benchmark
    (``bench/bench_diagnose.py``): in the second step every probe cut its start's cost (held
    out 0.18 on the probe events, vanishing candidates included), so the ranking sent four
    candidates to full fits on top of the two first-step ones, none of which passed. Against
    the current model's own cost one probe still earns a full fit: 3 full fits instead of 6,
    the same diagnosis, 21,150 evaluations and 546 s instead of 32,206 and 675 s."""
    best = math.inf
    for f in probes:
        key = f.keys[-1]
        name = CANDIDATES[key].key
        for pt, cost in f.point_rss.items():
            if cost < best and at_null(key, f.hypothesis.split(pt)[0][name]):
                best = cost
    return best


def pair_probes(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
                base: HypothesisFit, probes: Sequence[HypothesisFit],
                say: Callable[[str], None], tick: Tick = lambda *_status: None
                ) -> tuple[list[HypothesisFit], float]:
    """The joint probes of :func:`pair_step` (a grid over both candidates' parameters of each
    pair of :func:`pair_prospects`, at the nuisance values where they showed most, on the
    coarse engine) and the best single's cost they are measured against, on the probes'
    own events and engine (:func:`single_probe_cost`); no probes (and inf) where no pair is
    a prospect."""
    probed = any(f.probe for f in probes)
    prospects = (pair_prospects(probes, PAIR_TOP) if probed
                 else fitted_prospects(probes, PAIR_TOP, base.score))
    if not prospects:
        return [], math.inf
    say(f"pairs: joint probes of {len(prospects)} pair(s) of "
        + ", ".join(dict.fromkeys(k for a, b, _ in prospects for k in (a, b))))
    jobs = []
    for a, b, nuis in prospects:
        hyp = Hypothesis((a, b), base.hypothesis.nuisance)
        start = hyp.round([*Hypothesis((a, b)).null_point(), *nuis])
        jobs.append(Job(hyp, start, (Stage(grid=tuple(range(hyp.n_physics)), refine=(),
                                            maxfev=0, max_per_axis=PROBE_PER_AXIS),),
                         probe=True))
    single = (min(f.rss for f in probes) if probed
              else single_probe_cost(coarse_ev, ctx.probe_eids, probes))
    return fit_all(ctx, jobs, ev, coarse_ev, say, tick), single


def single_probe_cost(coarse_ev: CampaignEvaluator, eids: Sequence[str],
                      fits: Sequence[HypothesisFit]) -> float:
    """The lowest cost of the single-candidate ``fits`` (fitted fully) at their own points,
    on the coarse engine and the probe events ``eids``: the cost a joint probe is measured
    against where the pair step's prospects come from full fits
    (:func:`fitted_prospects`).

    Why: a full fit's own cost sums every event on the full engine, a joint probe's only
    the probe events on the shorter runs; on a campaign of more events than the probes
    hold, the joint probes would clear :data:`PAIR_MIN_CUT` against a cost they were never
    measured on."""
    return min((HypothesisCosts(coarse_ev, f.hypothesis, list(eids)).rss(f.point)
                for f in fits if len(f.keys) == 1), default=math.inf)


def pair_step(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
               base: HypothesisFit, probes: Sequence[HypothesisFit],
               policy: Policy, say: Callable[[str], None],
               tried: list[dict[str, Any]] | None = None,
               tick: Tick = lambda *_status: None,
               joint: tuple[list[HypothesisFit], float] | None = None) -> list[HypothesisFit]:
    """Pairs of the first step's most promising candidates (:func:`pair_prospects`): a joint
    probe of each pair (:func:`pair_probes`; ``joint``, where they were probed already),
    then full fits of the :data:`PAIR_FULL` best whose probe cuts the best single probe's
    cost by :data:`PAIR_MIN_CUT` in RMS; best first, or none. Whether the best is chosen is
    :func:`passes`' question, against "none", with the diagnosis' own thresholds.
    ``tried`` receives each joint probe's outcome.

    Why so many parameters: this is one step of
    :func:`~vadsim.fit.diagnosis.selection.forward_selection` and takes that loop's state as
    it is: the context and both engines, the model the pairs extend, the first step's probes,
    the thresholds, the progress callbacks (``say``, ``tick``) and where to record each
    probe's outcome."""
    probed, single = (pair_probes(ctx, ev, coarse_ev, base, probes, say, tick)
                      if joint is None else joint)
    if not probed:
        return []
    promising = sorted((f for f in probed if f.rss <= (1.0 - PAIR_MIN_CUT) ** 2 * single),
                       key=lambda f: f.rss)
    say("pairs: " + ("; ".join(f"{f.key} probe RSS {f.rss:.1f}" for f in promising[:PAIR_FULL])
                     or "none") + f" against {single:.1f} for the best single probe")
    if tried is not None:
        record_pair_probes(tried, probed, single, {f.key for f in promising[:PAIR_FULL]})
    if not promising:
        return []
    full = fit_all(ctx, [Job(f.hypothesis, f.point,
                               tuple(candidate_stages(f.hypothesis, base.rss, probed=True,
                                                     pair=True)))
                          for f in promising[:PAIR_FULL]], ev, coarse_ev, say, tick)
    return sorted(full, key=lambda f: (any_vanishes(f), f.score))


def record_pair_probes(tried: list[dict[str, Any]], probed: Sequence[HypothesisFit],
                       single: float, fitted: Collection[str] = ()) -> None:
    """Each joint probe's outcome, best first, as the report's ``pairs_probed`` lists it:
    the pair, its probe's cost, the best single probe's, and whether it was fitted fully."""
    tried.extend({"pair": f.key, "probe_rss": f.rss, "single_rss": single,
                  "fitted": f.key in fitted} for f in sorted(probed, key=lambda f: f.rss))


def screen_pairs(keys: Sequence[str]) -> list[tuple[str, str]]:
    """Every pair of model-side candidates of different ids among ``keys`` (143 of the
    default list): what :func:`screen_all_pairs` probes jointly. Measurement-side ones are left
    out: they only re-measure the model's runs, so each shows alone in the first step's
    finer probes (12 points per axis)."""
    model = [k for k in keys if CANDIDATES[k].side == "model"]
    return [(a, b) for i, a in enumerate(model) for b in model[i + 1:]
            if CANDIDATES[a].id != CANDIDATES[b].id]


def screen_all_pairs(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
                  base: HypothesisFit, keys: Sequence[str], say: Callable[[str], None],
                  tried: list[dict[str, Any]] | None = None,
                  skip: Collection[frozenset[str]] = (),
                  tick: Tick = lambda *_status: None) -> list[HypothesisFit]:
    """The last resort for two effects that cancel: a joint probe of every model-side pair
    (:func:`screen_pairs`, except the ``skip`` ones, fitted already) on the
    :data:`PAIR_SCREEN_EVENTS` events the calibrated base model fits worst, then full fits of
    the :data:`PAIR_SCREEN_FULL` best whose probes cut the base cost there by
    :data:`PAIR_SCREEN_MIN_GAIN`; best first, or none.

    Why every pair: where each effect alone moves the response the wrong way, no
    single-candidate probe shows either (blind-09, a hydraulic force on the anvil with a
    stiffer impact face: the force alone at its true value costs 23,251, the stiffness alone
    29,980, the base model 15,701 and the two together 31), and no sum of their single probes
    does either (measured: that pair 185th of 222 by the best sum of probe residuals). Only a
    joint probe sees them. The probes run at the nuisance values (calibrated or nominal) where
    the base model fits these events better: the calibration absorbs what it can of the
    effects.

    Why so many parameters: this is one step of
    :func:`~vadsim.fit.diagnosis.selection.forward_selection` and takes that loop's state as
    it is: the context and both engines, the model the pairs extend, the candidates paired,
    the pairs fitted already (``skip``), the progress callbacks (``say``, ``tick``) and where
    to record each probe's outcome."""
    eids = [e for e in ctx.worst_eids[:PAIR_SCREEN_EVENTS]]
    pairs = [(a, b) for a, b in screen_pairs(keys) if frozenset((a, b)) not in skip]
    if len(eids) < 2 or not pairs:
        return []
    hyp0 = base.hypothesis
    anchors = list(dict.fromkeys([base.point, hyp0.null_point()]))
    base_rss = HypothesisCosts(coarse_ev, hyp0, eids).event_rss(anchors).sum(axis=1)
    at = int(np.argmin(base_rss))
    anchor, base_cost = anchors[at], float(base_rss[at])
    say(f"pair screen: joint probes of {len(pairs)} model-side pairs on "
        f"{', '.join(eids)} at {'the calibrated' if at == 0 else 'the nominal'} nuisance "
        f"values (base cost {base_cost:.1f})")
    jobs = []
    for a, b in pairs:
        hyp = Hypothesis((a, b), hyp0.nuisance)
        jobs.append(Job(hyp, hyp.round([*Hypothesis((a, b)).null_point(), *anchor]),
                         (Stage(grid=tuple(range(hyp.n_physics)), refine=(), maxfev=0,
                                max_per_axis=PROBE_PER_AXIS,
                                shape_per_axis=PAIR_SCREEN_SHAPE_PER_AXIS),),
                         probe=True))
    sctx = replace(ctx, probe_eids=tuple(eids),
                   probe_folds=restricted(ctx.folds, set(eids)))
    done = [0]

    def probed(*_status: str) -> None:  # the screen can take an hour: say how far it is
        done[0] += 1
        tick(f"pair screen: {done[0]} of {len(jobs)} pairs probed")

    probes = sorted(fit_all(sctx, jobs, ev, coarse_ev, lambda _m: None, probed),
                    key=lambda f: f.rss)
    promising = [f for f in probes
                 if f.rss <= (1.0 - PAIR_SCREEN_MIN_GAIN) * base_cost][:PAIR_SCREEN_FULL]
    say("pair screen: " + ("; ".join(f"{f.key} probe RSS {f.rss:.1f}" for f in promising)
                           or "none") + f" against {base_cost:.1f} for the base model")
    if tried is not None:
        fitted = {f.key for f in promising}
        tried.extend({"pair": f.key, "probe_rss": f.rss, "single_rss": base_cost,
                      "fitted": f.key in fitted, "screen": True}
                     for f in probes[:PAIR_SCREEN_REPORT])
    if not promising:
        return []
    full = fit_all(ctx, [Job(f.hypothesis, f.point,
                               tuple(candidate_stages(f.hypothesis, base.rss, probed=True,
                                                     pair=True)))
                          for f in promising], ev, coarse_ev, say, tick)
    return sorted(full, key=lambda f: (any_vanishes(f), f.score))


def pair_prospects(probes: Sequence[HypothesisFit], top: int
                   ) -> list[tuple[str, str, Point]]:
    """The pairs among the ``top`` candidates (of different ids) whose first-step probes cut
    the cost most, relative to the base model at the same nuisance values (the current and
    the nominal ones, whichever shows the candidate more), with the nuisance values where
    the pair's candidates showed most.

    Why relative to each anchor: two effects that need each other are absorbed by the
    calibrated nuisance values. On the 10-event pair benchmark (a hydraulic force and anvil
    friction) no probe cut the calibrated base model's cost by more than 12 %, while at the
    nominal WOB and theta0 the force cut it by 74 % and friction by 38 % (3rd of 23). Their
    effects do not add: the force's and the friction's probe residuals added gave a cost
    twice the base model's where the two together leave almost nothing, so a pair must be
    run to be judged."""
    # the base model's cost at each anchor: where a candidate with a null vanishes (a
    # resonance or a contact law has no such point; its gain is taken against this)
    costs: dict[str, dict[tuple[float, ...], list[tuple[Point, float]]]] = {}
    base: dict[tuple[float, ...], float] = {}
    for f in probes:
        if not f.point_rss or len(f.keys) != 1:
            continue
        key, nphys = f.keys[0], f.hypothesis.n_physics
        by_anchor = costs.setdefault(key, {})
        for pt, c in f.point_rss.items():
            by_anchor.setdefault(anchor_key(pt[nphys:]), []).append((pt, c))
        if any(p.null is not None for p in CANDIDATES[key].params):
            null = Hypothesis((key,)).null_point()
            for anchor, items in by_anchor.items():
                at_null = [c for pt, c in items if same_point(pt[:nphys], null)]
                if at_null and at_null[0] > 0:
                    base.setdefault(anchor, at_null[0])
    gains: dict[str, tuple[float, tuple[float, ...]]] = {}
    for key, by_anchor in costs.items():
        nphys = len(CANDIDATES[key].params)
        for anchor, items in by_anchor.items():
            if anchor not in base:
                continue
            gain = 1.0 - min(c for _pt, c in items) / base[anchor]
            if key not in gains or gain > gains[key][0]:
                gains[key] = (gain, tuple(items[0][0][nphys:]))
    scores = {f.keys[0]: f.score for f in probes if len(f.keys) == 1}
    ranked = sorted(_one_variant_per_id(gains, scores), key=lambda k: -gains[k][0])
    chosen = [k for k in ranked if gains[k][0] > 0][:top]
    out = []
    for i, a in enumerate(chosen):
        for b in chosen[i + 1:]:
            nuis = gains[a][1] if gains[a][0] >= gains[b][0] else gains[b][1]
            out.append((a, b, nuis))
    return out


def fitted_prospects(fits: Sequence[HypothesisFit], top: int, base_score: float = math.inf
                     ) -> list[tuple[str, str, Point]]:
    """The pairs among the ``top`` best-scored single candidates (one variant per id) of a
    first step that fitted every candidate fully, each at the nuisance values of its
    better-scored candidate's fit; only singles that score better than the model they
    extend (``base_score``, held-out AICc) are prospects, as only probes that cut its cost
    are in :func:`pair_prospects`.

    Why: a pool no larger than the screen is fitted in full, not probed, and
    :func:`pair_prospects` reads probes' grids (the base model's cost at each candidate's
    null, at the same nuisance values), which full fits do not hold. Measured on the 6-event
    two-effect test campaign (a hydraulic force and anvil friction, 4 candidates): the force
    alone ended at both ends of its ranges and the pair step found no prospect. A single
    that scores no better than the base model carries no evidence of its effect: there the
    contact law (score 1,015.6 against the base model's 973.3) entered two of the three
    joint probes, 73 of the pair step's 99 s of probes, and neither pair came near the one
    of the force and the friction (RSS 453 and 1,268 against 13)."""
    chosen: list[HypothesisFit] = []
    ids: set[str] = set()
    for f in sorted((f for f in fits if len(f.keys) == 1 and f.score < base_score),
                    key=lambda f: f.score):
        if len(chosen) < top and CANDIDATES[f.keys[0]].id not in ids:
            chosen.append(f)
            ids.add(CANDIDATES[f.keys[0]].id)
    return [(a.keys[0], b.keys[0], tuple(a.point[a.hypothesis.n_physics:]))
            for i, a in enumerate(chosen) for b in chosen[i + 1:]]


def _one_variant_per_id(gains: Mapping[str, tuple[float, Any]],
                        scores: Mapping[str, float]) -> list[str]:
    """Each id's variant for the pair step: the one whose probe cut the cost most, except that
    a variant with more parameters takes the place of one with fewer only where its probe
    also scores better (held-out AICc, the first step's own ranking).

    Why: a family that extends another (Stribeck friction, force x peak at rest, contains
    Coulomb friction at peak 1) cuts at least as much on its larger grid, so it won every
    comparison of cuts, and its grid multiplies every joint probe it enters: on the pair
    benchmark (Coulomb friction written) the joint probes took 518 s with the Stribeck
    variant against 131 s with Coulomb's, for the same probe cost (663.6), while its probe
    held out worse (RMS 5.15 against 4.33)."""
    best: dict[str, str] = {}
    for k in sorted(gains, key=lambda k: len(CANDIDATES[k].params)):
        cid = CANDIDATES[k].id
        held = best.setdefault(cid, k)
        if held == k:
            continue
        if len(CANDIDATES[k].params) > len(CANDIDATES[held].params):
            wins = scores.get(k, math.inf) < scores.get(held, math.inf)
        else:
            wins = gains[k][0] > gains[held][0]
        if wins:
            best[cid] = k
    return list(best.values())


def anchor_key(values: Sequence[float]) -> tuple[float, ...]:
    return tuple(float(f"{v:.4g}") for v in values)


def same_point(a: Sequence[float], b: Sequence[float]) -> bool:
    return all(math.isclose(x, y, rel_tol=1e-5, abs_tol=1e-12) for x, y in zip(a, b, strict=True))
