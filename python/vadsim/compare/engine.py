"""The comparison engine: every event of a campaign under any model change, cached.

:class:`CampaignEvaluator` runs, measures and standardises each event (:mod:`.events`,
:mod:`.residuals`) in parallel threads; a measurement-side change re-measures the base model's
runs, and a result cache keeps measured runs on disk.
"""

from __future__ import annotations

import math
import os
import threading
from collections import OrderedDict
from collections.abc import Hashable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from vadsim._interrupt import result, stop_on_interrupt
from vadsim.campaigns.format import Campaign, Event
from vadsim.compare.events import (
    FAILED_RESIDUAL,
    FAILED_RUN,
    EventSimulation,
    WarmStart,
    cached_simulation,
    fine_rate_hz,
    measure_event,
    recorded_features,
    recorded_noise_g,
    run_event,
    summary_event,
    use_folded,
)
from vadsim.compare.residuals import event_residuals
from vadsim.model.cache import ResultCache, Uncacheable, default_cache
from vadsim.model.change import ModelChange
from vadsim.model.defaults import DEFAULTS
from vadsim.model.result import SimulationResult
from vadsim.model.settings import RunSettings
from vadsim.model.simulation import SolverError
from vadsim.signals.features import Feature
from vadsim.signals.fold_features import (
    fold_periods,
    has_quantiles,
)

__all__ = ["NOISE_SEED", "NOISE_STEP_G", "CampaignEvaluator", "EventEval"]


NOISE_SEED = 20260
"""Seed of the noise a :class:`CampaignEvaluator` adds to the model's sampled series: one
seed for every run (common random numbers), so two models differ by their physics."""


NOISE_STEP_G = 0.05
"""An estimated noise is rounded to this step (g): the estimate is good to a few per cent
(0.29-0.33 g for 0.3 g), which is all a window feature needs, and campaigns of the same
sensors then share their runs in a result cache."""


def _noise_option(noise: Mapping[str, float] | bool | None, campaign: Campaign,
                  settings: RunSettings) -> dict[str, float]:
    if noise is None or noise is True:
        return {k: round(v / NOISE_STEP_G) * NOISE_STEP_G
                for k, v in recorded_noise_g(campaign, settings).items()}
    if noise is False:
        return {}
    if not isinstance(noise, Mapping):
        raise ValueError(f"noise = {noise!r} must be None, True, False or a mapping of "
                         "sensor name to g")
    out = {}
    for name, v in noise.items():
        if name not in campaign.sensors:
            raise ValueError(f"noise: {name!r} is none of the campaign's sensors "
                             f"{list(campaign.sensors)}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or v < 0:
            raise ValueError(f"noise[{name!r}] = {v!r} must be a finite number >= 0 (g)")
        out[name] = float(v)
    return out


@dataclass(frozen=True)
class _ChangedRun:
    """A run under a change, where it started, and whether the start mattered."""

    result: SimulationResult
    start: str
    multistable: bool


@dataclass
class EventEval:
    """One event under one model: its simulation (None if the run failed), the standardised
    residuals and simulated values of the compared keys, in the evaluator's key order."""

    sim: EventSimulation | None
    z: np.ndarray
    values: np.ndarray


class CampaignEvaluator:
    """Standardised residuals of every event of a campaign under model changes, cached.

    Parameters
    ----------
    campaign, settings
        The recordings and the base model.
    targets
        ``{event: {key: Feature}}`` to compare with (default: the recorded features).
    keys
        Compared keys per event (default: those the base model's run yields a residual for).
    resolution
        ``"sensor"`` (through each sensor chain, averaged over ``phases``) or ``"full"``
        (the core's full-resolution summary, no time series).
    workers
        Threads (the core releases the GIL).
    folded
        Compare folded (or distribution) features of recorded time series too (default
        :data:`FOLDED`); they join the keys both for the default targets and the simulations.
    cache
        A :class:`~vadsim.model.cache.ResultCache` or its folder for the measured
        simulations (None: ``$VADSIM_CACHE`` if set; False: none). Changes with a
        measurement-side part and core extra-force objects are never cached.
    noise
        Each sensor's noise (g) added to the model's sampled series
        (:func:`measure_event`): None (default) estimates it from the recordings
        (:func:`recorded_noise_g`, rounded to :data:`NOISE_STEP_G`), False adds none, a
        mapping gives it per sensor name. The draws come from a fixed seed, so a model change
        moves a feature, not the noise. Unused (and not estimated) at ``resolution="full"``.
    warm_starts
        Where a changed model's run at each event starts (:class:`WarmStart`). False
        (default): every run from rest, as the dissertation's runs and the campaigns vadsim
        writes start. True: from the base model's own run there (computed once, when first
        needed; only where it settled on a periodic orbit, see :meth:`warm_start`). A
        mapping gives them per event id, an event it leaves out starting from rest (e.g.
        another evaluator's :meth:`warm_starts`, so that worker processes need not run the
        base model again). A warm start that reaches another impact scenario than the base
        model's is checked against a run from rest, and the run from rest is measured
        (``EventSimulation.multistable`` says when the two differ). Either way a result
        depends on its inputs only, never on which runs came before. Off by default:
        measured on the 10-event benchmark campaign, an evaluation took 0.97x as long warm
        (periodic runs from rest already stop at their orbit within tens of cycles), and a
        warm start can keep a changed model on the base model's branch where the run from rest
        (and the recording it is compared with) settles on another attractor of the same
        scenario: at one event of a calibration campaign, cost 9,232 warm against 656 from rest.
    """

    def __init__(self, campaign: Campaign, settings: RunSettings, *,
                 targets: Mapping[str, Mapping[str, Feature]] | None = None,
                 keys: Mapping[str, Sequence[str]] | None = None, resolution: str = "sensor",
                 phases: int = DEFAULTS.phases, workers: int | None = None,
                 folded: bool | None = None,
                 cache: ResultCache | str | os.PathLike[str] | bool | None = None,
                 noise: Mapping[str, float] | bool | None = None,
                 warm_starts: Mapping[str, WarmStart] | bool = False) -> None:
        if resolution not in ("sensor", "full"):
            raise ValueError(f"resolution = {resolution!r} must be 'sensor' or 'full'")
        if not (isinstance(phases, int) and phases >= 1):
            raise ValueError(f"phases = {phases!r} must be an integer >= 1")
        self.campaign, self.settings = campaign, settings
        self.resolution, self.phases = resolution, phases
        self.folded = use_folded(folded)
        self.workers = workers or os.cpu_count() or 1
        self.events = {ev.id: ev for ev in campaign.events}
        self.targets = ({e: dict(t) for e, t in targets.items()} if targets is not None else
                        {ev.id: recorded_features(campaign, ev, settings.f_exc_hz(ev.flow_gpm),
                                                  folded=self.folded)
                         for ev in campaign.events})
        self.keys: dict[str, list[str]] = {e: list(k) for e, k in (keys or {}).items()}
        self.fold_periods = {e: tuple(sorted(fold_periods(t))) for e, t in self.targets.items()}
        """Event -> the fold periods its recording's features use: the model folds no other."""
        self.quantiles = {e: has_quantiles(t) for e, t in self.targets.items()}
        """Event -> whether its recording's features hold quantiles: else the model takes
        none."""
        # a full-resolution comparison measures no sensor: no noise to estimate
        self.noise_g = (_noise_option(noise, campaign, settings) if resolution == "sensor"
                        else {})
        self.n_evals = 0
        self.cache = default_cache(cache)
        self._runs: dict[str, SimulationResult | None] = {}
        if not isinstance(warm_starts, (bool, Mapping)):
            raise ValueError(f"warm_starts = {warm_starts!r} must be True, False or a "
                             "mapping of event id to WarmStart")
        self._warm_enabled = warm_starts is not False
        # Given starts are all there is: an event they leave out starts from rest.
        self._warm: dict[str, WarmStart | None] = (
            {eid: warm_starts.get(eid) for eid in self.events}
            if isinstance(warm_starts, Mapping) else {})
        self._shared: OrderedDict[tuple[Any, str], _ChangedRun] = OrderedDict()
        self._shared_lock = threading.Lock()
        self._cache: dict[tuple[Hashable, str], EventEval] = {}
        self._pool = ThreadPoolExecutor(max_workers=self.workers)

    def close(self) -> None:
        """Stop the worker threads."""
        self._pool.shutdown()

    def __enter__(self) -> CampaignEvaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def event_ids(self) -> list[str]:
        """Events in campaign order."""
        return list(self.events)

    def _base_run(self, eid: str) -> SimulationResult | None:
        if eid not in self._runs:
            try:
                self._runs[eid] = run_event(self.campaign, self.events[eid], self.settings)
            except (SolverError, ValueError):
                self._runs[eid] = None
        return self._runs[eid]

    def warm_start(self, eid: str) -> WarmStart | None:
        """Where a changed model's run at event ``eid`` starts (None: from rest, as when warm
        starts are off, or the base model's run failed or settled on no periodic orbit).

        Only a periodic base run gives a warm start: there a changed run starts on the orbit
        the base model settled on and stops at its own within a few cycles. An intermittent
        (chaotic) base run would save only its settling (its 200 analysed cycles are integrated
        anyway), and its state is one point of a chaotic attractor: measured on a calibration
        campaign, a changed model started there settled into another attractor of the same
        impact scenario than from rest (cost 9,232 against 656 at one event)."""
        if not self._warm_enabled:
            return None
        if eid not in self._warm:
            base = self._base_run(eid)
            periodic = (base is not None and base.steady_info is not None
                        and base.steady_info.periodic)
            self._warm[eid] = (WarmStart(base.end_displacement, base.scenario,
                                         self._warm_source(eid))
                               if base is not None and periodic else None)
        return self._warm[eid]

    def _warm_source(self, eid: str) -> tuple[Any, ...]:
        """What this evaluator's own warm start at ``eid`` is a function of."""
        ev = self.events[eid]
        return ("base-steady-state", self.settings, ev.flow_gpm, float(ev.wob_klbf))

    def _warm_key(self, eid: str) -> Any:
        """A changed run's start as a cache key part, without running the base model."""
        if not self._warm_enabled:
            return None
        if eid in self._warm:
            w = self._warm[eid]
            return None if w is None else w.key()
        return self._warm_source(eid)

    def warm_starts(self) -> dict[str, WarmStart]:
        """Every event's :meth:`warm_start` (running the base model where not yet run)."""
        out = {}
        for eid in self.events:
            w = self.warm_start(eid)
            if w is not None:
                out[eid] = w
        return out

    def _changed_run(self, change: ModelChange, eid: str) -> _ChangedRun:
        """A run under a change. Runs of changes with a measurement are kept (the last
        ``2 x events``) by the run side of the change: a measurement-side candidate fitted at
        fitted nuisance constants re-measures the same runs at every grid point."""
        if change.measurement is None:
            return self._run_changed(change, eid)
        key = (change.run_key(), eid)
        with self._shared_lock:
            got = self._shared.get(key)
            if got is not None:
                self._shared.move_to_end(key)
                return got
        got = self._run_changed(change, eid)
        with self._shared_lock:
            self._shared[key] = got
            while len(self._shared) > 2 * len(self.events):
                self._shared.popitem(last=False)
        return got

    def _run_changed(self, change: ModelChange, eid: str) -> _ChangedRun:
        """The run from the event's warm start; where it reaches another impact scenario
        than the base model's there, the run from rest decides (and says whether the two
        differ)."""
        ev = self.events[eid]
        settings = change.apply(self.settings, ev.flow_gpm)
        warm = self.warm_start(eid)
        if warm is None:
            return _ChangedRun(run_event(self.campaign, ev, settings), "rest", False)
        r = run_event(self.campaign, ev, settings, warm_start=warm)
        if r.scenario == warm.scenario:
            return _ChangedRun(r, "warm", False)
        rest = run_event(self.campaign, ev, settings)
        return _ChangedRun(rest, "rest", rest.scenario != r.scenario)

    def _cache_key(self, change: ModelChange, ev: Event) -> str | None:
        """The key of an event's measured simulation under a change (None: not cacheable).
        The event's id is not part of it: another campaign's event at the same operating
        point, with the same sensors, shares the result."""
        if self.cache is None or change.measurement is not None:
            return None
        try:
            settings = change.apply(self.settings, ev.flow_gpm)
            start = self._warm_key(ev.id) if change.changes_run else None
            return self.cache.key("event-simulation", self.resolution, settings, ev.flow_gpm,
                                  float(ev.wob_klbf), fine_rate_hz(self.campaign),
                                  self.campaign.sensors, self.phases, self.folded,
                                  self.noise_g, self.fold_periods.get(ev.id),
                                  self.quantiles.get(ev.id, True), start)
        except (Uncacheable, ValueError):
            return None

    def simulate(self, change: ModelChange | None, eid: str) -> EventSimulation | None:
        """One event under a change (None: the base model); None if its run fails. Read
        from and written to the cache where there is one."""
        ev = self.events[eid]
        change = change or ModelChange()
        key = self._cache_key(change, ev)
        if key is not None:
            assert self.cache is not None
            hit = self.cache.get(key, parse=cached_simulation)
            if hit is not None:
                return None if hit is FAILED_RUN else replace(hit, event_id=eid)
        sim = self._simulate(change, eid)
        if key is not None:
            assert self.cache is not None
            self.cache.put(key, {"failed": True} if sim is None else sim.to_json())
        return sim

    def _simulate(self, change: ModelChange, eid: str) -> EventSimulation | None:
        ev = self.events[eid]
        try:
            if self.resolution == "full":
                return summary_event(self.campaign, ev, change.apply(self.settings, ev.flow_gpm))
            if change.changes_run:
                run = self._changed_run(change, eid)
            else:
                base = self._base_run(eid)
                if base is None:
                    return None
                run = _ChangedRun(base, "rest", False)
            sim = measure_event(self.campaign, ev, run.result, phases=self.phases,
                                measurement=change.measurement, folded=self.folded,
                                full_features=False, noise_g=self.noise_g, seed=NOISE_SEED,
                                fold_periods=self.fold_periods.get(eid),
                                quantiles=self.quantiles.get(eid, True))
            sim.start, sim.multistable = run.start, run.multistable
            return sim
        except (SolverError, ValueError):
            return None

    def _one(self, change: ModelChange | None, eid: str) -> EventEval:
        sim = self.simulate(change, eid)
        tgt = self.targets.get(eid, {})
        if eid not in self.keys:  # the base model defines which features are compared
            if sim is None:
                raise RuntimeError(f"event {eid}: the base model's run failed; its compared "
                                   "features are unknown")
            self.keys[eid] = sorted(event_residuals(sim, tgt, self.resolution))
        keys = self.keys[eid]
        if sim is None:
            return EventEval(None, self.compared(None, eid, tgt), np.full(len(keys), np.nan))
        feats = sim.sensor if self.resolution == "sensor" else sim.full
        z = self.compared(sim, eid, tgt)
        values = np.array([sim.z[k[2:]] if k.startswith("z_") and k[2:] in sim.z
                           else feats.get(k, Feature(math.nan, math.nan, 0)).value
                           for k in keys])
        return EventEval(sim, z, values)

    def compared(self, sim: EventSimulation | None, eid: str,
                 targets: Mapping[str, Feature]) -> np.ndarray:
        """The compared residuals of one event's simulation against ``targets`` (the
        recorded features, or another draw of them), in the evaluator's key order; a failed
        run or a lost feature gives :data:`FAILED_RESIDUAL`."""
        keys = self.keys[eid]
        if sim is None:
            return np.full(len(keys), FAILED_RESIDUAL)
        zd = event_residuals(sim, targets, self.resolution)
        return np.array([zd.get(k, FAILED_RESIDUAL) for k in keys])

    def evaluate(self, items: Sequence[tuple[Hashable, ModelChange | None]],
                 eids: Sequence[str] | None = None) -> dict[tuple[Hashable, str], EventEval]:
        """Every (item, event): ``items`` are ``(cache key, change)`` pairs (the base model's
        key is ``"base"``). Runs not cached run in parallel; the base model's first, since they
        define the compared keys."""
        eids = list(eids) if eids is not None else self.event_ids
        missing = [e for e in eids if e not in self.keys]
        with stop_on_interrupt(self._pool):  # Ctrl-C stops the runs in the threads too
            for e, fut in [(e, self._pool.submit(self._one, None, e)) for e in missing]:
                self._cache[("base", e)] = result(fut)
                self.n_evals += 1
            todo = {(k, e): ch for k, ch in items for e in eids if (k, e) not in self._cache}
            futures = {ke: self._pool.submit(self._one, ch, ke[1]) for ke, ch in todo.items()}
            for ke, fut in futures.items():
                self._cache[ke] = result(fut)
                self.n_evals += 1
        return {(k, e): self._cache[(k, e)] for k, _ in items for e in eids}

    def base(self, eids: Sequence[str] | None = None) -> dict[str, EventEval]:
        """The base model's evaluation of each event."""
        got = self.evaluate([("base", None)], eids)
        return {e: v for (_, e), v in got.items()}

    def residuals(self, key: Hashable, change: ModelChange | None,
                  eids: Sequence[str] | None = None) -> np.ndarray:
        """The compared residuals of ``eids`` under a change, concatenated in event order."""
        eids = list(eids) if eids is not None else self.event_ids
        got = self.evaluate([(key, change)], eids)
        return np.concatenate([got[(key, e)].z for e in eids]) if eids else np.empty(0)

    def rss(self, key: Hashable, change: ModelChange | None, eids: Sequence[str]) -> float:
        """Sum of squared residuals of ``eids`` under a change."""
        return float(np.sum(self.residuals(key, change, eids) ** 2))

    def table(self, z: np.ndarray, eids: Sequence[str] | None = None) -> pd.DataFrame:
        """Events x keys table of concatenated residuals (as :meth:`residuals` returns them)."""
        eids = list(eids) if eids is not None else self.event_ids
        rows: dict[str, dict[str, float]] = {}
        i = 0
        for e in eids:  # built at once: a cell at a time fragments the frame (~70 keys/event)
            rows[e] = {k: float(z[i + j]) for j, k in enumerate(self.keys[e])}
            i += len(self.keys[e])
        columns = list(dict.fromkeys(k for e in eids for k in self.keys[e]))
        return pd.DataFrame.from_dict(rows, orient="index", columns=columns,
                                      dtype=float).reindex(eids)
