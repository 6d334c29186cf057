"""What a diagnosis runs on: the campaign's evidence and the comparison engines built from it.

:class:`Context` is everything a fit needs to rebuild its comparison engine, in this process,
a worker process or on a Dask worker: the recorded features and compared keys, the folds,
the probe events and the warm starts. :func:`make_folds` holds events out by flow;
:func:`probe_subset` chooses the events a cheap probe looks at; :func:`located` says where
the calibrated base model misses.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from vadsim.campaigns import Campaign
from vadsim.compare import CampaignEvaluator, EventEval, WarmStart
from vadsim.fit.hypothesis import Fold, Hypothesis, HypothesisCosts, Point
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.fit.locate import Mismatch, locate
from vadsim.model.settings import RunSettings
from vadsim.signals.features import Feature

__all__ = ["PROBE_CYCLE_FRACTION", "PROBE_EVENTS", "PROBE_WORST", "Context", "located",
           "make_folds", "mismatches", "probe_subset", "restricted", "rms_of"]

PROBE_EVENTS = 6
"""Events a screening probe evaluates: spread evenly over the flows, the lowest and the
highest included (every event when the campaign has no more). A probe only ranks the
candidates for the full fits. Measured on the 10-event hydraulic benchmark: the same top 3
of 23 as probes on every event at full length (the 4th changed: excitation_amplitude for
mass[mwd]), and the same verdict and values."""

PROBE_WORST = 3
"""Of the :data:`PROBE_EVENTS`, how many a screening probe takes from the events the
calibrated base model fits worst (the rest stay spread over the flows, for effects that
grow with flow)."""

PROBE_CYCLE_FRACTION = 2.0 / 3.0
"""A probe's run length and analysed window as a fraction of the diagnosis' (300/200 cycles
-> 200/133): for the same reason, at about half the cost of a run and its measurement."""


@dataclass(frozen=True)
class Context:
    """What a worker needs to rebuild the comparison engine: the recorded features and
    compared keys come along, so that a worker neither re-reads the recordings nor re-runs
    the base model to learn them."""

    campaign: Campaign
    settings: RunSettings
    phases: int
    folds: tuple[Fold, ...]
    eids: tuple[str, ...]
    targets: Mapping[str, Mapping[str, Feature]]
    keys: Mapping[str, Sequence[str]]
    probe_eids: tuple[str, ...]
    probe_folds: tuple[Fold, ...]
    cache: str | bool = False
    """The result cache's folder (False: none); a folder, not the object, crosses to a
    worker process."""
    noise: Mapping[str, float] = field(default_factory=dict)
    """Each sensor's noise (g) the model's measurement adds, estimated once from the
    recordings (:func:`vadsim.compare.recorded_noise_g`)."""
    worst_eids: tuple[str, ...] = ()
    """The events the calibrated base model fits worst, worst first (the pair screen's)."""
    warm: Mapping[str, WarmStart] = field(default_factory=dict)
    """Each event's warm start: the base model's steady state there, computed once by the
    diagnosis' own engine, so that every worker starts changed runs from the same states."""
    scheduler: str | None = None
    """A Dask scheduler's address: fits, probes and pair screens run on that cluster."""

    def evaluator(self, probe: bool, workers: int) -> CampaignEvaluator:
        """A comparison engine at the diagnosis' fidelity or at a probe's."""
        settings = self.settings
        if probe:
            settings = settings.with_changes(
                cycles=settings.cycles * PROBE_CYCLE_FRACTION,
                analyse_cycles=settings.analyse_cycles * PROBE_CYCLE_FRACTION)
        return CampaignEvaluator(self.campaign, settings, targets=self.targets,
                                 keys=self.keys, phases=self.phases, workers=workers,
                                 cache=self.cache, noise=dict(self.noise),
                                 warm_starts=dict(self.warm))


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


def probe_subset(camp: Campaign, folds: Sequence[Fold], n: int,
                  misfit: Mapping[str, float] | None = None
                  ) -> tuple[tuple[str, ...], tuple[Fold, ...]]:
    """``n`` events (all if there are no more) and the folds restricted to them (a fold left
    without training or held-out events is dropped).

    Without ``misfit`` the events are spread evenly over the flows, the lowest and the
    highest included (the base calibration's grids, before any residual is known). With
    ``misfit`` (event id -> the calibrated base model's RMS z) the :data:`PROBE_WORST` worst
    events come first and the rest are spread over the other events' flows: a probe on
    events the base model already fits cannot see the effect (measured on a blind campaign,
    impact-face stiffness x2.5: the flow-spread subset held 24 % of the base cost, and the
    true candidate's probe fell outside the top 4)."""
    if len(camp.events) <= n:
        return tuple(e.id for e in camp.events), tuple(folds)
    worst: set[str] = set()
    if misfit:
        worst = set(sorted(misfit, key=lambda e: -misfit[e])[:min(PROBE_WORST, n)])
    rest = sorted((e for e in camp.events if e.id not in worst), key=lambda e: e.flow_gpm)
    pick = sorted({int(round(i)) for i in np.linspace(0, len(rest) - 1, n - len(worst))})
    chosen = worst | {rest[i].id for i in pick}
    eids = tuple(e.id for e in camp.events if e.id in chosen)
    return eids, restricted(folds, chosen)


def restricted(folds: Sequence[Fold], chosen: set[str]) -> tuple[Fold, ...]:
    """The folds restricted to the ``chosen`` events (one left without training or held-out
    events is dropped)."""
    kept = []
    for name, train, test in folds:
        tr, te = [e for e in train if e in chosen], [e for e in test if e in chosen]
        if tr and te:
            kept.append((name, tr, te))
    return tuple(kept)


def located(ctx: Context, ev: CampaignEvaluator, hyp0: Hypothesis, base: HypothesisFit,
            say: Callable[[str], None]
            ) -> tuple[Context, dict[tuple[Point, str], EventEval], list[Mismatch],
                       list[dict[str, Any]]]:
    """The calibrated base model's evaluation, where it misses (features, events), and the
    context with the probe events chosen by its misfit (the worst ones first)."""
    eids = list(ctx.eids)
    base_eval = HypothesisCosts(ev, hyp0, eids).evaluate([base.point])
    found, found_events = mismatches(ctx.campaign, ev, {e: base_eval[(base.point, e)]
                                                        for e in eids})
    say(f"located: {len(found)} feature(s), {len(found_events)} event(s) with RMS z > 2")
    misfit = {e: float(np.sqrt(np.mean(np.square(base_eval[(base.point, e)].z))))
              for e in eids}
    probe_eids, probe_folds = probe_subset(ctx.campaign, ctx.folds, PROBE_EVENTS, misfit)
    ctx = replace(ctx, probe_eids=probe_eids, probe_folds=probe_folds,
                  worst_eids=tuple(sorted(misfit, key=lambda e: -misfit[e])))
    return ctx, base_eval, found, found_events


def mismatches(camp: Campaign, ev: CampaignEvaluator, base_eval: Mapping[str, EventEval]
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


def rms_of(got: Mapping[tuple[Point, str], EventEval], pt: Point, eids: Sequence[str]
           ) -> tuple[float, dict[str, float]]:
    """Pooled and per-event RMS standardised residual of one point."""
    z = np.concatenate([got[(pt, e)].z for e in eids])
    return (float(np.sqrt(np.mean(z ** 2))),
            {e: float(np.sqrt(np.mean(got[(pt, e)].z ** 2))) for e in eids})
