"""The diagnosis from a campaign to a verdict, in the order it runs.

1. calibrate "none": the base model with the nuisance constants
   (:func:`~vadsim.fit.diagnosis.hypotheses.calibrate_base`);
2. locate where it misses (:func:`~vadsim.fit.diagnosis.evidence.located`);
3. select effects (:func:`~vadsim.fit.diagnosis.selection.forward_selection`) and
   review them (:func:`~vadsim.fit.diagnosis.selection.review`);
4. conclude (:func:`~vadsim.fit.diagnosis.policy.verdict`).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

from vadsim._progress import ProgressArg, bar, reporter
from vadsim.campaigns import Campaign, campaign_preset, load_any_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.fit.bootstrap import rms_draws
from vadsim.fit.candidates import keys_for
from vadsim.fit.diagnosis import selection
from vadsim.fit.diagnosis.evidence import (
    PROBE_EVENTS,
    Context,
    located,
    make_folds,
    probe_subset,
    rms_of,
)
from vadsim.fit.diagnosis.hypotheses import (
    calibrate_widening,
    densify,
    island_hop,
    refit_widening,
)
from vadsim.fit.diagnosis.parallel import Tick, bar_tick, on_bar
from vadsim.fit.diagnosis.policy import (
    Policy,
    none_model,
    unexplained,
    verdict,
    within_noise,
)
from vadsim.fit.diagnosis.result import Diagnosis, jsonable
from vadsim.fit.hypothesis import Hypothesis, HypothesisCosts
from vadsim.fit.hypothesis_fit import HypothesisFit, fit_hypothesis, with_searched_intervals
from vadsim.fit.nuisance import DEFAULT_NUISANCE, NuisanceSpec, parse_nuisance, resolve_nuisance
from vadsim.model.cache import ResultCache, default_cache
from vadsim.model.presets import Preset
from vadsim.model.settings import DEFAULTS, RunSettings

__all__ = ["diagnose", "predict"]


def diagnose(
    campaign: str | os.PathLike[str] | Campaign,
    *,
    candidates: Sequence[str] | None = None,
    nuisance: Sequence[NuisanceSpec | str] | None = DEFAULT_NUISANCE,
    preset: Preset | None = None,
    overrides: Mapping[str, float] | None = None,
    cycles: float = DEFAULTS.recording_cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    phases: int = DEFAULTS.diagnosis_phases,
    policy: Policy | None = None,
    min_delta: float | None = None,
    min_reduction: float | None = None,
    max_effects: int | None = None,
    screen_top: int | None = None,
    max_rms: float | None = None,
    noise_rms: float | None = None,
    block_fraction: float = 0.3,
    review: bool = True,
    workers: int | None = DEFAULTS.workers,
    progress: ProgressArg = True,
    cache: ResultCache | str | os.PathLike[str] | bool | None = None,
    scheduler: str | None = DEFAULTS.scheduler,
) -> Diagnosis:
    """Calibrate the base model's nuisance constants, locate the mismatch, select missing
    physics by forward selection on held-out events, and give a verdict.

    Why so many parameters: each mirrors an option of ``vadsim diagnose`` one to one, so
    that a script and a command line say the same; they group into the campaign and its
    candidates, the run (``preset`` to ``phases``), the decision thresholds (``policy``, or
    any of them on their own) and where the work runs (``workers`` to ``scheduler``).

    Parameters
    ----------
    campaign
        A campaign folder or TOML file, a :class:`Campaign`, or ``"thesis:7in-cde"`` etc.
    candidates
        Candidate ids or keys (default: all of :data:`vadsim.fit.candidates.CANDIDATES`).
    nuisance
        Constants fitted with every hypothesis: :class:`~vadsim.fit.nuisance.NuisanceSpec`
        or ``"NAME=LO:HI"`` (default: WOB scale +-15 % and theta0; ``()`` or None: none).
    preset, overrides
        The base model (default: the campaign's tool and bit) and changes to it.
    cycles, analyse_cycles
        Run length and analysed window (excitation cycles).
    phases
        Sampling phases the simulated features are averaged over.
    policy
        Every decision threshold (:class:`~vadsim.fit.diagnosis.policy.Policy`; default its
        defaults). ``min_delta``, ``min_reduction``, ``max_effects``, ``screen_top``,
        ``max_rms`` and ``noise_rms``, where given, replace the policy's (their meaning is
        there).
    block_fraction
        Fraction of the distinct flows (highest first) held out as one block.
    review
        Review the chosen model once selection ends
        (:func:`~vadsim.fit.diagnosis.selection.review`).
    workers
        Worker processes (default: all cores).
    progress
        ``True`` (default): a progress bar on stderr; ``False``: silent; a callable: called
        with one line per finished step.
    cache
        A folder (or :class:`~vadsim.model.cache.ResultCache`) that keeps every measured
        run, so that a second diagnosis, calibration or validation meeting the same runs
        reads them (None: ``$VADSIM_CACHE`` if set; False: none).
    scheduler
        A Dask scheduler's address (``"tcp://HOST:PORT"``): candidate fits, probes and pair
        screens run on that cluster instead of local processes (the base calibration and the
        verdict stay here), with the same result as local. Its workers need vadsim.
    """
    t0 = time.perf_counter()
    pol = _policy(policy, min_delta=min_delta, min_reduction=min_reduction,
                  max_effects=max_effects, screen_top=screen_top, max_rms=max_rms,
                  noise_rms=noise_rms)
    _check_run(block_fraction, phases, scheduler)
    cache_folder = _cache_folder(cache)
    say = reporter(progress)
    camp = load_any_campaign(campaign)
    keys = keys_for(list(candidates) if candidates is not None else None)
    settings = RunSettings(preset or campaign_preset(camp), overrides=overrides or {},
                           cycles=cycles, analyse_cycles=analyse_cycles)
    nuis = resolve_nuisance(tuple(parse_nuisance(s) if isinstance(s, str) else s
                                  for s in (nuisance or ())), settings)
    folds = make_folds(camp, block_fraction)
    eids = [e.id for e in camp.events]
    with CampaignEvaluator(camp, settings, phases=phases,
                           workers=workers or os.cpu_count() or 1, cache=cache_folder) as ev, \
            bar(progress, None, f"diagnose {camp.name}", "fit") as b, \
            contextlib.ExitStack() as stack:
        say = on_bar(say, b)
        plain = fit_hypothesis(ev, Hypothesis(), (), [], folds, eids, say)
        probe_eids, probe_folds = probe_subset(camp, folds, PROBE_EVENTS)
        ctx = Context(camp, settings, phases, tuple(folds), tuple(eids), ev.targets,
                      {e: tuple(k) for e, k in ev.keys.items()}, probe_eids, probe_folds,
                      cache_folder, dict(ev.noise_g), warm=ev.warm_starts(),
                      scheduler=scheduler)
        coarse_ev = stack.enter_context(ctx.evaluator(True, ev.workers))
        base, widened = calibrate_widening(ctx, ev, coarse_ev, Hypothesis((), nuis), say)
        hyp0, nuis = Hypothesis((), base.nuisance_specs), base.nuisance_specs
        b.update(2)
        ctx, base_eval, found, found_events = located(ctx, ev, hyp0, base, say)
        none = none_model(base, plain)
        sel = selection.forward_selection(ctx, ev, coarse_ev, base, none, keys, pol, say,
                                          bar_tick(b))
        chosen, base, reviewed, wider = _reviewed(ctx, ev, coarse_ev, sel, base, keys, pol,
                                                  say, review)
        final = chosen or none_model(base, plain)
        noise = _noise_check(ev, chosen, final, pol, say)
        acted = _remainder(ctx, ev, coarse_ev, sel, base, final, noise, keys, pol, say, bar_tick(b))
        if acted is not None:  # the widenings reported are the reported model's own
            final = chosen = acted[0]
            reviewed, wider, noise = [*reviewed, *acted[1]], acted[2], acted[3]
        baseline_sim = _baseline_sim(ev, base, base_eval, eids)
        return Diagnosis(
            campaign=camp, preset=settings.preset, located=found,
            located_events=found_events, uncalibrated=plain, baseline=base, steps=sel.steps,
            chosen=chosen, verdict=verdict(chosen, final, pol, noise), noise=noise,
            unexplained=unexplained(final, {e.id: e.flow_gpm for e in camp.events}, pol, noise),
            recorded=ev.targets, keys=dict(ev.keys), baseline_sim=baseline_sim, folds=folds,
            settings=_settings_record(settings, phases, block_fraction, review, keys, nuis,
                                      ev.noise_g, pol),
            elapsed_s=time.perf_counter() - t0, n_evals=ev.n_evals + coarse_ev.n_evals,
            pairs=sel.pairs, review=reviewed, widened_nuisance=widened,
            widened_chosen=wider,
        )


def _cache_folder(cache: ResultCache | str | os.PathLike[str] | bool | None) -> str | bool:
    """The result cache's folder for the worker processes (False: no cache)."""
    store = default_cache(cache)
    return str(store.folder) if store is not None else False


def _reviewed(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
              sel: selection.Selection, base: HypothesisFit, keys: list[str], pol: Policy,
              say: Callable[[str], None], review: bool
              ) -> tuple[HypothesisFit | None, HypothesisFit, list[dict[str, Any]],
                         list[dict[str, Any]]]:
    """The chosen model after the review (:func:`~vadsim.fit.diagnosis.selection.review`,
    if asked) and over the ranges it asks for
    (:func:`~vadsim.fit.diagnosis.hypotheses.refit_widening`), the calibrated base model, the
    review's records and the widenings. The reported model's intervals are searched as the
    policy says (:func:`~vadsim.fit.hypothesis_fit.with_searched_intervals`): the chosen
    model's, or where nothing is chosen the base model's (its constants are reported with
    "none"), each first moved to a better island of its cost where there is one
    (:func:`~vadsim.fit.diagnosis.hypotheses.island_hop`). An effect of two or more whose
    searched intervals hold its null is then dropped
    (:func:`~vadsim.fit.diagnosis.selection.drop_null_effects`)."""
    chosen, reviewed = (selection.review(ctx, ev, coarse_ev, sel, keys, pol, say)
                        if review else (sel.chosen, []))
    if chosen is None:
        hopped = island_hop(ctx, ev, coarse_ev, base, say)
        return (None, with_searched_intervals(ev, hopped, list(ctx.eids), say,
                                              pol.interval_search), reviewed, [])
    chosen, dropped, widened = _settled(ctx, ev, coarse_ev, sel, chosen, say,
                                        pol.interval_search)
    return chosen, base, [*reviewed, *dropped], widened


def _baseline_sim(ev: CampaignEvaluator, base: HypothesisFit, base_eval: Mapping[Any, Any],
                  eids: list[str]) -> dict[str, dict[str, float]]:
    """The calibrated base model's simulated features per event, at its reported point
    (evaluated again where :func:`~vadsim.fit.diagnosis.hypotheses.island_hop` moved it
    from the point the location step evaluated)."""
    if any((base.point, e) not in base_eval for e in eids):
        base_eval = HypothesisCosts(ev, base.hypothesis, eids).evaluate([base.point])
    return {e: dict(zip(ev.keys[e], map(float, base_eval[(base.point, e)].values), strict=True))
            for e in eids}


def _settings_record(settings: RunSettings, phases: int, block_fraction: float, review: bool,
                     keys: list[str], nuis: Sequence[NuisanceSpec],
                     noise_g: Mapping[str, float], pol: Policy) -> dict[str, Any]:
    """What a diagnosis ran with (its result's ``settings``: the report's thresholds too).

    Why so many parameters: each is one setting of :func:`diagnose` the result records."""
    return dict(cycles=settings.cycles, analyse_cycles=settings.analyse_cycles, phases=phases,
                block_fraction=block_fraction, review=review, candidates=keys,
                nuisance=[f"{s.name}={s.lo:g}:{s.hi:g}" for s in nuis],
                overrides=dict(settings.overrides),
                noise_g={k: round(v, 4) for k, v in noise_g.items()}, **pol.as_dict())


def _remainder(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
               sel: selection.Selection, base: HypothesisFit, final: HypothesisFit,
               noise: Mapping[str, Any] | None, keys: list[str], pol: Policy,
               say: Callable[[str], None], tick: Tick
               ) -> tuple[HypothesisFit, list[dict[str, Any]], list[dict[str, Any]],
                          dict[str, Any] | None] | None:
    """Where ``final`` holds out above ``max_rms``, or above ``noise_rms`` and beyond the
    noise (``noise``, :func:`_noise_check`): the model that replaces it
    (:func:`~vadsim.fit.diagnosis.selection.remainder_search`), refitted densely and settled
    (:func:`_settled`), with the review's records of it, its widenings and its own noise
    check; None where ``final`` lies within the noise or no candidate passes against it.

    Why not below ``noise_rms``: forward selection adds nothing to a model that holds out
    there (a further gain would be fitted noise), and no candidate can cut such a model's
    held-out RMS by ``min_reduction``. Measured on blind-13 (an independent null beyond its
    band at held-out RMS 0.13): 25 full fits, 564 s, none passing.

    Why so many parameters: this is the diagnosis' last search and takes its state as it is:
    the context and both engines, the selection, the calibrated base model, the final
    model and its noise check, the candidates, the thresholds and the progress callbacks."""
    if final.heldout_rms <= pol.max_rms and (noise is None or noise["within"]
                                              or final.heldout_rms <= pol.noise_rms):
        return None
    better = selection.remainder_search(ctx, ev, coarse_ev, sel, base, final, keys, pol, say,
                                        tick)
    if better is None:
        return None
    chosen, dropped, wider = _settled(ctx, ev, coarse_ev, sel,
                                      densify(ctx, ev, coarse_ev, better, say), say,
                                      pol.interval_search)
    return (chosen, [_replacement(final, chosen), *dropped], wider,
            _noise_check(ev, chosen, chosen, pol, say))


def _settled(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator,
             sel: selection.Selection, chosen: HypothesisFit, say: Callable[[str], None],
             interval_search: str
             ) -> tuple[HypothesisFit, list[dict[str, Any]], list[dict[str, Any]]]:
    """A model to report: refitted over the ranges it asks for
    (:func:`~vadsim.fit.diagnosis.hypotheses.refit_widening`), moved to a better island of
    its cost where there is one (:func:`~vadsim.fit.diagnosis.hypotheses.island_hop`), its
    intervals searched as ``interval_search`` says
    (:func:`~vadsim.fit.hypothesis_fit.with_searched_intervals`) and the
    effects pinned at their null dropped
    (:func:`~vadsim.fit.diagnosis.selection.drop_null_effects`); with the drops and the
    widenings."""
    chosen, widened = refit_widening(ctx, ev, coarse_ev, chosen, say)
    chosen = island_hop(ctx, ev, coarse_ev, chosen, say)
    chosen, dropped = selection.drop_null_effects(
        ctx, ev, coarse_ev, with_searched_intervals(ev, chosen, list(ctx.eids), say,
                                                    interval_search), sel, say, interval_search)
    return chosen, dropped, widened


def _replacement(final: HypothesisFit, chosen: HypothesisFit) -> dict[str, Any]:
    """The review's record of a model that replaced the final one for its remainder
    beyond the noise (:func:`~vadsim.fit.diagnosis.selection.remainder_search`)."""
    return {"action": "swap", "from": final.key if final.keys else "none", "to": chosen.key,
            "model": chosen.key, "score": chosen.score, "heldout_rms": chosen.heldout_rms,
            "against": final.score, "accepted": True,
            "why": "a remainder beyond the noise; fitted fully, it passes"}


def _noise_check(ev: CampaignEvaluator, chosen: HypothesisFit | None, final: HypothesisFit,
                 pol: Policy, say: Callable[[str], None]) -> dict[str, Any] | None:
    """Whether the final model lies within the noise (:func:`within_noise`) where it holds
    out within ``max_rms``: "none" is only given inside the band, and a chosen model above it
    leaves a remainder the verdict names; None where that is not asked."""
    if final.heldout_rms > pol.max_rms or not pol.noise_draws:
        return None
    which = "+".join(chosen.keys) if chosen is not None else "'none'"
    say(f"{which} against {pol.noise_draws} campaigns it writes itself")
    return within_noise(final, rms_draws(ev, final.hypothesis.change(final.point),
                                         n_boot=pol.noise_draws), pol)


def _policy(policy: Policy | None, **given: Any) -> Policy:
    """``policy`` (default :class:`Policy`'s) with the thresholds given on their own."""
    if policy is not None and not isinstance(policy, Policy):
        raise ValueError(f"policy = {policy!r} must be a Policy")
    return replace(policy or Policy(), **{k: v for k, v in given.items() if v is not None})


def _check_run(block_fraction: float, phases: int, scheduler: str | None) -> None:
    if not (isinstance(block_fraction, (int, float)) and 0.0 < block_fraction < 1.0):
        raise ValueError(f"block_fraction = {block_fraction!r} must be in (0, 1)")
    if isinstance(phases, bool) or not (isinstance(phases, int) and phases >= 1):
        raise ValueError(f"phases = {phases!r} must be an integer >= 1")
    if scheduler is not None and not (isinstance(scheduler, str) and scheduler.strip()):
        raise ValueError(f"scheduler = {scheduler!r} must be a Dask scheduler's address, "
                         "e.g. 'tcp://10.0.0.5:8786'")


def predict(diag: Diagnosis, campaign: str | os.PathLike[str] | Campaign, *,
            preset: Preset | None = None, workers: int | None = None,
            cache: ResultCache | str | os.PathLike[str] | bool | None = None) -> dict[str, Any]:
    """Predict another campaign with the calibrated base model and with the diagnosis' final
    model (fitted values and nuisance constants, nothing refitted), e.g. the 7in RC test from
    a fit on the CDE test. ``cache`` as in :func:`diagnose`.

    Returns a JSON-ready dict (also stored as ``diag.prediction``): RMS standardised
    residual before/after and per event.
    """
    camp = load_any_campaign(campaign)
    s = diag.settings
    settings = RunSettings(preset or campaign_preset(camp), overrides=s["overrides"],
                           cycles=s["cycles"], analyse_cycles=s["analyse_cycles"])
    eids = [e.id for e in camp.events]
    with CampaignEvaluator(camp, settings, phases=s["phases"],
                           workers=workers or os.cpu_count() or 1, cache=cache) as ev:
        base = diag.none_fit
        got = HypothesisCosts(ev, base.hypothesis, eids).evaluate([base.point])
        before, per_before = rms_of(got, base.point, eids)
        out: dict[str, Any] = {"campaign": camp.name, "physics": diag.missing_physics,
                               "error_before": before, "error_after": before}
        per_event = {e: {"flow_gpm": ev.events[e].flow_gpm, "rms_before": per_before[e]}
                     for e in eids}
        # the chosen physics, and what the best-ranked candidate would predict even though it
        # was not chosen: evidence for the next campaign, not a verdict
        top = diag.ranking[0] if diag.ranking and diag.chosen is None else None
        for fit, label in ((diag.chosen, "after"), (top, "best_ranked")):
            if fit is None:
                continue
            got = HypothesisCosts(ev, fit.hypothesis, eids).evaluate([fit.point])
            err, per = rms_of(got, fit.point, eids)
            if label == "after":
                out["error_after"] = err
            else:
                out["best_ranked"] = {"key": fit.key, "parameters": fit.parameters,
                                      "error": err}
            for e in eids:
                per_event[e][f"rms_{label}"] = per[e]
        out["events"] = per_event
    diag.prediction = jsonable(out)
    return diag.prediction
