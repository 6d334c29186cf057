"""How far a calibration's cost may rise inside a 95 % interval, measured by simulation.

Why this module exists: a profile interval accepts the values whose cost stays within a
threshold of the minimum. The textbook threshold, ``chi2(1, 0.95) = 3.84`` times the residual
variance, assumes independent residuals; a recording's features are not (the 200 ms peaks,
the folded spike, its width and the band levels of one event all move together, and one
sampling phase or one stretch of a chaotic response shifts them together). On the README's
example it gave ``Fo`` in [394.6, 396.2] for a true 380.

A parametric bootstrap measures the threshold instead (a likelihood-ratio test calibrated by
simulation): the fitted model writes ``n_boot`` new campaigns -- each event run again from a
slightly longer settling (another stretch of the response), recorded through each sensor's
chain at a random sampling phase with noise (:func:`vadsim.campaigns.synthetic.record_run`),
for as long as the real recording. Each is compared with the model at the same probe points
the interval is drawn on. For such a campaign the estimate *is* the truth, so the rise of its
cost at the estimate above its best probe is what the truth's rise looks like; the 95 %
quantile of those rises is the threshold.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

from vadsim._interrupt import result, stop_on_interrupt
from vadsim.campaigns.synthetic import record_run
from vadsim.compare import (
    NOISE_SEED,
    CampaignEvaluator,
    EventSimulation,
    event_residuals,
    fine_rate_hz,
    measure_event,
    recorded_features,
    run_event,
)
from vadsim.model.change import Measurement, ModelChange
from vadsim.model.result import G, SimulationResult
from vadsim.model.simulation import SolverError
from vadsim.model.steady import steady_run
from vadsim.signals.features import Feature
from vadsim.signals.fold_features import fold_periods

__all__ = ["BOOTSTRAP_RUNS", "cost_rises", "rms_draws"]

BOOTSTRAP_RUNS = 8
"""Distinct runs per event the bootstrap draws recordings from (settling 0, 3, 6... cycles
longer than the calibration's runs): each a different stretch of a chaotic response."""


def _recording_s(evaluator: CampaignEvaluator, eid: str) -> float:
    ev = evaluator.events[eid]
    if ev.data is None or len(ev.data) < 2:
        raise ValueError(f"event {eid} has no time series: a bootstrap needs recordings")
    t = ev.data["time_s"].to_numpy(float)
    return float(t[-1] - t[0]) + float(t[1] - t[0])


def _runs(evaluator: CampaignEvaluator, change: ModelChange, eid: str, n_runs: int
          ) -> list[SimulationResult]:
    """Runs of the fitted model at one event, as long as its recording, settling longer by
    3 cycles each."""
    ev = evaluator.events[eid]
    settings = change.apply(evaluator.settings, ev.flow_gpm)
    n_an = math.ceil(_recording_s(evaluator, eid) * settings.f_exc_hz(ev.flow_gpm))
    settle = settings.cycles - settings.analyse_cycles
    fine = fine_rate_hz(evaluator.campaign)
    out = []
    for k in range(n_runs):
        try:
            out.append(steady_run(
                settings.with_changes(cycles=settle + 3 * k + n_an, analyse_cycles=n_an),
                ev.flow_gpm, wob_klbf=ev.wob_klbf, record="window", output_rate_hz=fine))
        except (SolverError, ValueError):
            continue
    if not out:
        raise ValueError(f"event {eid}: the fitted model's runs failed; no bootstrap")
    return out


def cost_rises(evaluator: CampaignEvaluator, change: ModelChange,
               probes: Sequence[Mapping[str, EventSimulation | None]],
               groups: Mapping[str, Sequence[int]], at: int,
               cost: Callable[[np.ndarray], float], *, n_boot: int = 50,
               noise_g: float = 0.3, seed: int = 1,
               n_runs: int = BOOTSTRAP_RUNS) -> dict[str, np.ndarray]:
    """Per group of probes, the cost rise at the estimate above the group's best probe, for
    each of ``n_boot`` campaigns the fitted model writes.

    Why so many parameters: the bootstrap reuses a calibration's work instead of redoing it,
    so it takes that work as it is (the engine, the estimate, the probes already simulated,
    their grouping and the cost), plus its own size, noise, seed and runs per event.

    Parameters
    ----------
    evaluator
        The calibration's comparison engine (its campaign, settings and compared keys).
    change
        The fitted model (the estimate) as a change to the evaluator's settings.
    probes
        Each probe point's simulation of every event (``{event: EventSimulation or None}``).
    groups
        Probe indices per fitted parameter (the points its interval is drawn on).
    at
        The index of the estimate among ``probes``.
    cost
        The calibration's cost of a residual vector.
    n_boot, noise_g, seed, n_runs
        Campaigns drawn; the sensors' noise (g RMS); the random seed; distinct runs per event.
    """
    _check_draws(evaluator, n_boot)
    if not (noise_g >= 0 and math.isfinite(noise_g)):
        raise ValueError(f"noise_g = {noise_g!r} must be a finite number >= 0")
    rng = np.random.default_rng(seed)
    eids = evaluator.event_ids
    runs = {e: _runs(evaluator, change, e, n_runs) for e in eids}
    seconds = {e: _recording_s(evaluator, e) for e in eids}
    rises: dict[str, list[float]] = {g: [] for g in groups}
    for b in range(n_boot):
        z_parts: list[list[np.ndarray]] = [[] for _ in probes]
        for e in eids:
            target = _drawn_features(evaluator, runs[e][b % len(runs[e])], e, rng, noise_g,
                                     seconds[e])
            for i, sims in enumerate(probes):
                z_parts[i].append(evaluator.compared(sims.get(e), e, target))
        costs = np.array([cost(np.concatenate(p)) for p in z_parts])
        for g, idx in groups.items():
            rises[g].append(float(costs[at] - np.min(costs[list(idx)])))
    return {g: np.array(v) for g, v in rises.items()}


def _check_draws(evaluator: CampaignEvaluator, n_boot: int) -> None:
    if isinstance(n_boot, bool) or not isinstance(n_boot, int) or n_boot < 2:
        raise ValueError(f"n_boot = {n_boot!r} must be an integer >= 2")
    if evaluator.resolution != "sensor":
        raise ValueError("a bootstrap draws recordings: it needs resolution = 'sensor'")


def _drawn_features(evaluator: CampaignEvaluator, run: SimulationResult, eid: str,
                    rng: np.random.Generator, noise_g: float | Mapping[str, float],
                    seconds: float, *, measurement: Measurement | None = None,
                    fine_rate_hz: float | None = None) -> dict[str, Feature]:
    """One drawn recording of event ``eid`` from ``run`` (a random sampling phase, then
    noise, both from ``rng``; ``seconds`` long), as the evaluator reads a recording."""
    ev = evaluator.events[eid]
    rec = record_run(run, evaluator.campaign.sensors, event_id=eid, flow_gpm=ev.flow_gpm,
                     wob_klbf=ev.wob_klbf, phase=float(rng.uniform()), noise_g=noise_g,
                     rng=rng, duration_s=seconds, measurement=measurement,
                     fine_rate_hz=fine_rate_hz)
    return recorded_features(evaluator.campaign, rec, evaluator.settings.f_exc_hz(ev.flow_gpm),
                             folded=evaluator.folded)


STRETCHES = 4
"""An aperiodic event's draws are cut from a run :data:`STRETCHES` recordings long: each
draw another stretch of the same response."""


def _own_run(evaluator: CampaignEvaluator, change: ModelChange, eid: str
             ) -> tuple[SimulationResult, SimulationResult] | None:
    """The run the evaluator measures the model ``change`` from at event ``eid`` (as the
    core returned it), and the accelerations that event's draws are recorded from, on the fine
    grid: a periodic orbit repeated for as long as the recording; for an aperiodic response,
    the same run from rest continued to :data:`STRETCHES` recordings after its settling.
    None if a run fails."""
    ev = evaluator.events[eid]
    settings = change.apply(evaluator.settings, ev.flow_gpm)
    sensors = evaluator.campaign.sensors.values()
    fine = fine_rate_hz(evaluator.campaign)
    # one sample more than the recording, so every sampling phase fills it
    seconds = _recording_s(evaluator, eid) + 1.0 / min(s.rate_hz for s in sensors)
    try:
        r = run_event(evaluator.campaign, ev, settings)
        if r.t.size == 0 and r.orbit is not None:
            t = r.window[0] + np.arange(math.ceil(seconds * fine) + 1) / fine
            a = np.zeros((t.size, 7))
            for d in {s.dof for s in sensors}:
                a[:, d - 1] = r.orbit.at(t, d) * G
            return r, replace(r, t=t, a=a)
        n_long = max(settings.analyse_cycles,
                     STRETCHES * math.ceil(seconds * settings.f_exc_hz(ev.flow_gpm)))
        settle = settings.cycles - settings.analyse_cycles
        long = steady_run(settings.with_changes(cycles=settle + n_long, analyse_cycles=n_long),
                          ev.flow_gpm, wob_klbf=ev.wob_klbf, record="window",
                          output_rate_hz=fine, summary_rate_hz=0.0, accelerations_only=True)
        return r, long
    except (SolverError, ValueError):
        return None


def _stretch(r: SimulationResult, seconds: float, rng: np.random.Generator
             ) -> SimulationResult:
    """A random stretch of ``seconds`` of the run's stored window (all of it if shorter)."""
    n = r.t.size - math.ceil(seconds / float(r.t[1] - r.t[0])) - 1
    if n <= 0:
        return r
    i = int(rng.integers(0, n + 1))
    return replace(r, t=r.t[i:], a=r.a[i:])


def rms_draws(evaluator: CampaignEvaluator, change: ModelChange, *, n_boot: int = 20,
              seed: int = 1) -> np.ndarray:
    """The RMS standardised residual of the model ``change`` against each of ``n_boot``
    campaigns it writes itself (the campaign's events, sensors, recording lengths and each
    sensor's noise as the evaluator measured it on the recordings).

    Why: how far a model that is *right* lies from a campaign, with these events, features
    and noise -- the yardstick for "within the noise" (a diagnosis' verdict "none" is only
    given where the calibrated base model lies inside the band of these draws). Each draw is
    recorded from the very run the evaluator measures the model from (at a random sampling
    phase, with fresh noise; an aperiodic response at a random stretch of that run
    continued), not from runs that settle longer as :func:`cost_rises` draws: at a
    multistable event a longer settling can land on another response, and every draw would
    then sit far from the model it stands for (measured: 8.5 RMS z at one event of a blind
    null). What varies between draws is what varies between two recordings of the same
    steady response. The model is measured with the folds each draw's record asks for (as
    the evaluator measures it with the campaign's), so a draw is compared on the features a
    recording of it would give.

    Parameters
    ----------
    evaluator
        The diagnosis' comparison engine (resolution ``"sensor"``).
    change
        The model as a change to the evaluator's settings.
    n_boot, seed
        Campaigns drawn (>= 2); the random seed.
    """
    _check_draws(evaluator, n_boot)
    eids = evaluator.event_ids
    # one generator per event, seeded by its place: the draws do not depend on which thread
    # ran which event first
    with ThreadPoolExecutor(max_workers=max(1, evaluator.workers)) as pool, \
            stop_on_interrupt(pool):
        futures = [pool.submit(_event_draws, evaluator, change, e, n_boot,
                               np.random.default_rng([seed, i])) for i, e in enumerate(eids)]
        parts = [result(f) for f in futures]
    squares = np.sum([p[0] for p in parts], axis=0)
    counts = np.sum([p[1] for p in parts], axis=0)
    return np.sqrt(squares / np.maximum(counts, 1))


def _event_draws(evaluator: CampaignEvaluator, change: ModelChange, eid: str, n_boot: int,
                 rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """One event's part of :func:`rms_draws`: per draw, the sum of its squared residuals
    and their number."""
    camp, ev = evaluator.campaign, evaluator.events[eid]
    squares, counts = np.zeros(n_boot), np.zeros(n_boot)
    got = _own_run(evaluator, change, eid)
    if got is None:
        failed = evaluator.compared(None, eid, {})
        return np.full(n_boot, float(np.sum(failed ** 2))), np.full(n_boot, failed.size)
    seconds = _recording_s(evaluator, eid)
    measured: dict[tuple[int, ...], EventSimulation] = {}
    for b in range(n_boot):
        target = _drawn_features(evaluator, _stretch(got[1], seconds, rng), eid, rng,
                                 evaluator.noise_g, seconds, measurement=change.measurement,
                                 fine_rate_hz=fine_rate_hz(camp))
        periods = tuple(sorted(fold_periods(target)))
        if periods not in measured:
            measured[periods] = measure_event(
                camp, ev, got[0], phases=evaluator.phases, noise_g=evaluator.noise_g,
                seed=NOISE_SEED, measurement=change.measurement, folded=evaluator.folded,
                full_features=False, fold_periods=periods)
        z = np.fromiter(event_residuals(measured[periods], target).values(), dtype=float)
        squares[b], counts[b] = float(np.sum(z ** 2)), z.size
    return squares, counts
