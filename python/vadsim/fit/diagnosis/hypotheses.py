"""The fits a diagnosis makes of one hypothesis: where each starts, and through which stages.

A :class:`Job` is one hypothesis (candidates plus nuisance constants), its start and its
stages (:class:`~vadsim.fit.stages.Stage`: grids and local refinements, on the full or the
coarse engine); :func:`vadsim.fit.diagnosis.parallel.fit_all` runs a list of them. The
stage plans differ by what is fitted: the base model's calibration (:func:`calibrate_base`,
widened where a nuisance constant ends at a bound: :func:`calibrate_widening`; the chosen
model likewise where one of its values does: :func:`refit_widening`),
a candidate on top of the chosen ones (:func:`job`, :func:`candidate_stages`), a screening
probe (:func:`probe_stage`), a chosen model refitted near its optimum (:func:`refit_stages`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Any

from vadsim.compare import CampaignEvaluator
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis.evidence import Context
from vadsim.fit.hypothesis import Hypothesis, HypothesisCosts, Point
from vadsim.fit.hypothesis_fit import HypothesisFit, fit_hypothesis
from vadsim.fit.nuisance import widen
from vadsim.fit.stages import Stage, capped_refine

__all__ = ["ISLAND_MAXFEV_PER_COORD", "JOINT_IF_TRAINING_BELOW", "MAX_GRID_MODEL_SIDE",
           "MAX_JOINT_GRID_PARAMS", "NUISANCE_PROFILE_POINTS", "PAIR_REFINE_PER_PARAM",
           "PROBE_PER_AXIS", "PROBE_PER_AXIS_MEASUREMENT", "WIDEN_ROUNDS", "Job",
           "calibrate_base", "calibrate_widening", "candidate_stages", "densify", "island_hop",
           "job", "model_side", "probe_stage", "refit_stages", "refit_widening", "siblings",
           "without"]

JOINT_IF_TRAINING_BELOW = 0.9
"""A candidate is refined jointly with the nuisance constants only where its own fit already
cuts the training cost below this fraction of the current model's: elsewhere it cannot pass
the selection thresholds, and the joint search would cost the most."""

PROBE_PER_AXIS = 5
"""Grid points per axis of the first step's coarse probe of a model-side candidate."""

PROBE_PER_AXIS_MEASUREMENT = 12
"""The same for a measurement-side candidate (it only re-measures cached runs, and a
resonance's cost minima are narrow)."""

NUISANCE_PROFILE_POINTS = 16
"""Grid points over a non-periodic nuisance constant's range in a chosen model's refit
(:func:`refit_stages`): WOB x0.85-1.15 in steps of 0.02, finer than the width of the
valleys measured along it (about 0.03 on blind-05)."""

MAX_GRID_MODEL_SIDE = 7
"""Grid points per axis for candidates that run the model again (measurement-side ones,
which only re-measure, keep their finer grids: a resonance's cost minima are narrow)."""

PAIR_REFINE_PER_PARAM = 16
"""Evaluations per candidate parameter of a pair's joint refinement
(:func:`candidate_stages`): measured on blind-09, 8 per parameter (24) stopped at cost
1,893, 16 (48) reached 68 from 4,451."""

MAX_JOINT_GRID_PARAMS = 3
"""On top of chosen effects, a joint grid (5 points per axis) over every candidate parameter
when they are at most this many (125 points at 3)."""


@dataclass(frozen=True)
class Job:
    """One hypothesis to fit: picklable, so that it can run in a worker process."""

    hyp: Hypothesis
    start: Point
    stages: tuple[Stage, ...]
    alternatives: tuple[Point, ...] = ()
    probe: bool = False


def job(current: HypothesisFit, key: str, solo: HypothesisFit | None = None,
         probe: HypothesisFit | None = None) -> Job:
    """``current`` plus candidate ``key``, started at ``current``'s values and the new
    candidate's null (or the middle of its box), or at the best point of its screening
    ``probe``; or, if better, at the new candidate's own fit ``solo`` with the chosen ones at
    their nulls (the chosen ones may have absorbed the new effect: the other order of adding
    them)."""
    hyp = current.hypothesis.extend(key)
    cands, nuis = current.hypothesis.split(current.point)
    new = Hypothesis((key,)).null_point()
    start = hyp.round([v for c in cands.values() for v in c.values()] + list(new)
                      + list(nuis.values()))
    if probe is not None:
        start = probe.point
    alternatives: tuple[Point, ...] = ()
    # with a joint grid over every candidate parameter, the other order (the chosen ones at
    # their nulls, the new one at its own fit) is on that grid already
    if solo is not None and current.keys and hyp.n_physics > MAX_JOINT_GRID_PARAMS:
        own, solo_nuis = solo.hypothesis.split(solo.point)
        chosen_null = Hypothesis(current.keys).null_point()
        alternatives = (hyp.round([*chosen_null, *own[key].values(), *solo_nuis.values()]),)
    return Job(hyp, start, tuple(candidate_stages(hyp, current.rss, probe is not None)),
                alternatives)


def calibrate_base(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
                    hyp: Hypothesis, say: Callable[[str], None],
                    start: Point | None = None) -> HypothesisFit:
    """The calibrated base model: a grid over every nuisance constant (on the coarse engine:
    a subset of events, shorter runs), then Nelder-Mead at the diagnosis' fidelity from the
    three best grid points (theta0's cost has several minima); from ``start`` if given
    (else the nominal constants)."""
    every = tuple(range(len(hyp.specs)))
    stages = ([Stage(grid=every, refine=every, maxfev=10 * len(every), starts=3, coarse=True)]
              if every else [])
    return fit_hypothesis(ev, hyp, hyp.null_point() if start is None else hyp.round(start),
                          stages, ctx.folds, list(ctx.eids), say,
                          coarse=(coarse_ev, list(ctx.probe_eids)))


WIDEN_ROUNDS = 2
"""How many times the base calibration is widened and refitted while a nuisance constant
stays at an end of its range (:func:`calibrate_widening`)."""


def calibrate_widening(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
                       hyp: Hypothesis, say: Callable[[str], None]
                       ) -> tuple[HypothesisFit, list[dict[str, Any]]]:
    """:func:`calibrate_base`, and while a nuisance constant ends at a bound of its range,
    that bound widened (:func:`~vadsim.fit.nuisance.widen`) and the base model refitted from
    where it stopped, at most :data:`WIDEN_ROUNDS` times. Every later hypothesis extends the
    returned fit, so it inherits the widened ranges. Returns the fit and the widenings (for
    the result: a bound hit is reported, never silently kept)."""
    fit = calibrate_base(ctx, ev, coarse_ev, hyp, say)
    widened: list[dict[str, Any]] = []
    for _ in range(WIDEN_ROUNDS):
        specs, changes = widen(fit.hypothesis.nuisance, fit.at_bounds)
        if not changes:
            break
        for c in changes:
            say(f"nuisance {c['name']} at its {c['bound']} bound ({c['value']:.4g}): range "
                f"{c['from'][0]:.4g}-{c['from'][1]:.4g} widened to {c['to'][0]:.4g}-"
                f"{c['to'][1]:.4g}, base model refitted")
        widened += changes
        wider = Hypothesis((), specs)
        refit = calibrate_base(ctx, ev, coarse_ev, wider, say, start=fit.point)
        # a refit that ended worse keeps the earlier point; later fits still search wider
        fit = refit if refit.rss <= fit.rss else dataclasses.replace(fit, nuisance_specs=specs)
    return fit, widened


def refit_widening(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
                   fit: HypothesisFit, say: Callable[[str], None]
                   ) -> tuple[HypothesisFit, list[dict[str, Any]]]:
    """The chosen model, and while one of its values (a candidate's parameter or a nuisance
    constant) ends at an end of its range, that range widened
    (:meth:`~vadsim.fit.hypothesis.Hypothesis.widened`) and the model refitted from where it
    stopped (:func:`refit_stages`), at most :data:`WIDEN_ROUNDS` times; the refit is kept
    where its training cost is not worse. Returns the fit and the widenings (for the
    result: a bound hit is reported, never silently kept); where the model refuses a point
    of the wider range (a value outside what the core accepts), the earlier fit is kept and
    each widening of that round carries the refusal as ``refused``.

    Why: a candidate's range is the library's guess of what is physical, not a fact of the
    campaign; a fit at its end names the right physics with the wrong size, and the verdict
    would call the campaign unexplained for want of range (an onset steeper than exponent 3,
    measured on an independently written campaign)."""
    widened: list[dict[str, Any]] = []
    for _ in range(WIDEN_ROUNDS):
        hyp, changes = fit.hypothesis.widened(fit.at_bounds)
        if not changes:
            break
        for c in changes:
            say(f"{c['of']} {c['name']} at its {c['bound']} bound ({c['value']:.4g}): range "
                f"{c['from'][0]:.4g}-{c['from'][1]:.4g} widened to {c['to'][0]:.4g}-"
                f"{c['to'][1]:.4g}, {fit.key} refitted")
        widened += changes
        try:
            refit = fit_hypothesis(ev, hyp, hyp.round(fit.point), refit_stages(hyp),
                                   ctx.folds, list(ctx.eids), say,
                                   coarse=(coarse_ev, list(ctx.probe_eids)))
        except ValueError as exc:  # the model refuses a value of the wider range
            say(f"{fit.key} over the widened ranges: the model refused a point ({exc}); the "
                "fit over the earlier ranges is kept")
            for c in changes:
                c["refused"] = str(exc)
            break
        fit = refit if refit.rss <= fit.rss else dataclasses.replace(
            fit, nuisance_specs=hyp.nuisance, ranges=hyp.ranges)
    return fit, widened


def model_side(hyp: Hypothesis, keys: Sequence[str] | None = None) -> bool:
    """Whether any candidate of ``hyp`` (or of ``keys``) runs the model again."""
    return any(CANDIDATES[k].side == "model" for k in (hyp.keys if keys is None else keys))


def candidate_stages(hyp: Hypothesis, start_rss: float, probed: bool = False,
                      pair: bool = False) -> list[Stage]:
    """The last candidate of ``hyp``: a grid over its parameters (the others held, at the
    current nuisance values and at the nominal ones: those fitted without the right physics
    absorb part of a real effect) and a local refinement. On top of chosen effects, a
    coordinate pass follows -- a grid over each chosen candidate's parameters, then over the
    new one's again -- because the chosen ones were fitted while absorbing the new effect.
    Last, where the candidate already helps, all coordinates jointly.

    ``probed``: the start is the best point of the candidate's screening probe (a grid on
    a subset of events, around the current and the nominal nuisance values), so the first
    grid is laid around that point only.

    ``pair``: both candidates are new (a pair step's): after the joint grid, a refinement of
    every candidate parameter jointly (:data:`PAIR_REFINE_PER_PARAM` evaluations per
    parameter), since the joint grid's best point can sit a grid step from a narrow basin
    that the coordinate stages do not walk into (blind-09: from the grid point (50, 1.0,
    2.2) at cost 4,451 the stages ended there; this refinement reaches (39.7, 1.52, 1.99)
    at 68, the truth (40, 1.5, 2.0) costing 39)."""
    *chosen, new = hyp.coordinates()
    first = new[0]
    every = tuple(range(len(hyp.specs)))
    new_model = model_side(hyp, hyp.keys[-1:])
    stages = [Stage(grid=new, refine=new, maxfev=8 * len(new),
                    max_per_axis=MAX_GRID_MODEL_SIDE if new_model else None,
                    nominal_anchor=not probed, starts=2, coarse=new_model)]
    if 0 < first and hyp.n_physics <= MAX_JOINT_GRID_PARAMS:
        # a joint grid over every candidate parameter: the chosen ones were fitted while
        # absorbing the new effect, and walking them back one coordinate at a time gets
        # stuck in the valley that absorption makes (measured: hydraulic force at its
        # bound with friction near zero, training cost 13x the truth's). Around the nominal
        # nuisance values too: they absorbed the effects as well (measured on the 10-event
        # pair benchmark: without, the friction fit on top of the hydraulic force ended at
        # held-out RMS 2.73; with, at 0.31, values within 5 % of the truth)
        stages.append(Stage(grid=tuple(range(hyp.n_physics)), refine=(), maxfev=0,
                            max_per_axis=5, coarse=model_side(hyp), nominal_anchor=True))
        if pair:
            physics = tuple(range(hyp.n_physics))
            stages.append(Stage(grid=None, refine=physics,
                                maxfev=PAIR_REFINE_PER_PARAM * len(physics)))
    for own, key in zip(chosen, hyp.keys, strict=False):
        stages.append(Stage(grid=own, refine=(), maxfev=0, max_per_axis=5,
                            nominal_anchor=True, coarse=model_side(hyp, [key])))
    if first > 0:
        stages.append(Stage(grid=new, refine=(), maxfev=0, max_per_axis=5,
                            coarse=new_model))
    if len(every) > len(new):
        stages.append(Stage(grid=None, refine=every, maxfev=10 * len(every),
                            if_rss_below=JOINT_IF_TRAINING_BELOW * start_rss))
    return stages


def probe_stage(hyp: Hypothesis) -> Stage:
    new = hyp.coordinates()[-1]
    coarse = (PROBE_PER_AXIS_MEASUREMENT if hyp.candidates[-1].side == "measurement" else
              PROBE_PER_AXIS)
    return Stage(grid=new, refine=(), maxfev=0, max_per_axis=coarse, nominal_anchor=True)


def refit_stages(hyp: Hypothesis, fine: str | None = None) -> list[Stage]:
    """A chosen model's refit from a nearby start: a grid over each candidate's parameters
    (5 per axis; ``fine``, a measurement-side candidate just put in, over its own full grid,
    as its resonance minima are narrow), a fine profile of each non-periodic nuisance
    constant alone (:data:`NUISANCE_PROFILE_POINTS` over its range, on the coarse engine),
    then every coordinate jointly.

    Why the profile: the cost along WOB can hold narrow valleys a local search does not
    cross. Measured on blind-05 of the own-classes blind run (a contact law under WOB x0.9):
    the diagnosis chose the contact law at its written values (2.97, 1.04 for 3, 1) but at
    WOB x1.00, training cost 362 against 56 at x0.90 with the rest held; between them the
    cost climbs to 307 at x0.94, and the calibration's 5-point grid (0.075 apart) and the
    candidate grids (at the current and the nominal WOB) never sat in the valley."""
    stages = [Stage(grid=own, refine=(), maxfev=0,
                    max_per_axis=None if key == fine and not model_side(hyp, [key]) else 5,
                    coarse=model_side(hyp, [key]))
              for own, key in zip(hyp.coordinates(), hyp.keys, strict=True)]
    # on the coarse engine whatever the candidates: a nuisance constant runs the model again
    stages += [Stage(grid=(hyp.n_physics + j,), refine=(), maxfev=0,
                     per_axis=NUISANCE_PROFILE_POINTS, coarse=True)
               for j, spec in enumerate(hyp.nuisance) if not spec.periodic]
    every = tuple(range(len(hyp.specs)))
    stages.append(Stage(grid=None, refine=every, maxfev=10 * len(every)))
    return stages


def densify(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
             fit: HypothesisFit,
             say: Callable[[str], None]) -> HypothesisFit:
    """The chosen model refitted around its optimum with the stages a next step uses (a
    grid over each candidate's parameters, then all coordinates jointly), so that its folds
    choose among as dense a set of points as the next step's hypotheses do: held-out scores
    compared across steps must not differ by how densely each was searched."""
    hyp = fit.hypothesis
    out = fit_hypothesis(ev, hyp, fit.point, refit_stages(hyp), ctx.folds, list(ctx.eids),
                         say, coarse=(coarse_ev, list(ctx.probe_eids)))
    return out if out.rss <= fit.rss else fit


ISLAND_MAXFEV_PER_COORD = 40
"""Evaluations per coordinate of each Nelder-Mead round of :func:`island_hop`'s walk on the
capped cost (measured on blind-11: 150 for its 3 coordinates reached the truth's island)."""


ISLAND_MIN_GAIN = 0.05
"""Fraction of the training cost the walk of :func:`island_hop` must save before the model is
refitted from its end. The benchmark's regret noise is ``2 sqrt(2 / n)`` of a right model's
cost at ``n`` residuals (0.12-0.28 at 100-600 residuals), and the islands it crossed to
were 40-60 % lower (blind-05 32.4 -> 17.8, blind-11 45.3 -> 17.0); a walk that saves a few
per cent (measured: 6.2 -> 6.2 and 4.6 -> 4.4 on the test suite's campaigns) only moved
within the island, and its refit cost 6-10 s for nothing."""


def island_hop(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
               fit: HypothesisFit, say: Callable[[str], None]) -> HypothesisFit:
    """The model to report, moved to a better island of its cost where there is one: a walk
    on the cost with each event capped (:func:`~vadsim.fit.stages.capped_refine`) from its
    optimum, and, where the true cost there is at least :data:`ISLAND_MIN_GAIN` lower, the
    model refitted from that point (:func:`refit_stages`) and kept where its training cost
    is lower than ``fit``'s; else ``fit`` as it was.

    Why not only where the model lies beyond its own noise band: the band bounds the cost's
    level, the regret its difference to the truth's, which is far smaller. Measured on the
    README's campaign: the chosen model at RMS z 0.13 against a band edge of 3.1; blind-11's
    wrong island cost RMS z 0.28 (45.3 at 585 residuals), the truth's 0.17."""
    hyp = fit.hypothesis
    if not hyp.specs:
        return fit
    costs = HypothesisCosts(ev, hyp, list(ctx.eids))
    rss, point = capped_refine(costs, fit.point, ISLAND_MAXFEV_PER_COORD * len(hyp.specs))
    if not rss < (1.0 - ISLAND_MIN_GAIN) * fit.rss:
        say(f"{fit.key}: no better island across the events' ridges ({rss:.1f} against "
            f"{fit.rss:.1f})")
        return fit
    say(f"{fit.key}: a better island across the events' ridges (training cost {rss:.1f} < "
        f"{fit.rss:.1f}); refitted from there")
    out = fit_hypothesis(ev, hyp, point, refit_stages(hyp), ctx.folds, list(ctx.eids), say,
                         coarse=(coarse_ev, list(ctx.probe_eids)))
    return out if out.rss < fit.rss else fit


def without(fit: HypothesisFit, drop: str, put: str | None = None) -> tuple[Hypothesis, Point]:
    """``fit``'s hypothesis with candidate ``drop`` removed (or replaced by ``put``, a
    variant with the same parameters) and ``fit``'s point for it."""
    cands, nuis = fit.hypothesis.split(fit.point)
    kept = [k for k in fit.keys if k != drop or put is not None]
    keys = [put if k == drop and put is not None else k for k in kept]
    hyp = Hypothesis(tuple(keys), fit.hypothesis.nuisance)
    values = [v for k in kept for v in cands[CANDIDATES[k].key].values()]
    return hyp, hyp.round([*values, *nuis.values()])


def siblings(key: str, keys: Sequence[str], chosen: Collection[str],
              fitted: Collection[str]) -> list[str]:
    """Variants of candidate ``key`` with the same parameters (e.g. ``sensor_chain[both]``
    for ``sensor_chain[x1]``) worth a refit in its place: the measurement-side ones (they
    only re-measure) and those ``fitted`` fully when ``key`` was chosen."""
    cand = CANDIDATES[key]
    names = [p.name for p in cand.params]
    return [s for s in keys if s != key and s not in chosen and CANDIDATES[s].id == cand.id
            and [p.name for p in CANDIDATES[s].params] == names
            and (CANDIDATES[s].side == "measurement" or s in fitted)]
