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

import numpy as np

from vadsim.campaigns.synthetic import record_run
from vadsim.compare import CampaignEvaluator, EventSimulation, fine_rate_hz, recorded_features
from vadsim.model.change import ModelChange
from vadsim.model.result import SimulationResult
from vadsim.model.simulate import SolverError
from vadsim.model.steady import steady_run

__all__ = ["BOOTSTRAP_RUNS", "cost_rises"]

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
    if not (isinstance(n_boot, int) and n_boot >= 2):
        raise ValueError(f"n_boot = {n_boot!r} must be an integer >= 2")
    if not (noise_g >= 0 and math.isfinite(noise_g)):
        raise ValueError(f"noise_g = {noise_g!r} must be a finite number >= 0")
    if evaluator.resolution != "sensor":
        raise ValueError("a bootstrap draws recordings: it needs resolution = 'sensor'")
    rng = np.random.default_rng(seed)
    eids = evaluator.event_ids
    runs = {e: _runs(evaluator, change, e, n_runs) for e in eids}
    seconds = {e: _recording_s(evaluator, e) for e in eids}
    rises: dict[str, list[float]] = {g: [] for g in groups}
    for b in range(n_boot):
        z_parts: list[list[np.ndarray]] = [[] for _ in probes]
        for e in eids:
            ev = evaluator.events[e]
            rec = record_run(runs[e][b % len(runs[e])], evaluator.campaign.sensors,
                             event_id=e, flow_gpm=ev.flow_gpm, wob_klbf=ev.wob_klbf,
                             phase=float(rng.uniform()), noise_g=noise_g, rng=rng,
                             duration_s=seconds[e])
            target = recorded_features(evaluator.campaign, rec,
                                       evaluator.settings.f_exc_hz(ev.flow_gpm),
                                       folded=evaluator.folded)
            for i, sims in enumerate(probes):
                z_parts[i].append(evaluator.compared(sims.get(e), e, target))
        costs = np.array([cost(np.concatenate(p)) for p in z_parts])
        for g, idx in groups.items():
            rises[g].append(float(costs[at] - np.min(costs[list(idx)])))
    return {g: np.array(v) for g, v in rises.items()}
