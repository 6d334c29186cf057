"""Validation of the model against a campaign of recordings (dissertation chapter 3).

Why this module exists: a field campaign is a set of steady operating points recorded by
accelerometers. To say whether the model is right, every event is simulated at its flow and
WOB, the simulated acceleration at each sensor's degree of freedom is passed through that
sensor's chain (low-pass, sampling, clipping: RECORDINGS.md), the same features are computed
on both sides, and the differences are standardised by the recording's own spread. The report
shows a table per event, the dissertation-style figures (peaks vs flow, field vs model) and a
heat map of standardised residuals (event x feature x sensor).

Features are computed twice for simulations: through the sensor chain (what the comparison
uses, as RECORDINGS.md requires) and at the solver's full resolution (what the dissertation
compared with the field, and what MODEL.md's reference table reports).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vadsim.model.presets import Preset, get_preset, load_preset_file
from vadsim.model.simulate import G, SimulationResult, simulate
from vadsim.campaigns import Campaign, Event, load_campaign, thesis_campaigns
from vadsim.signals.features import Feature, event_features, summary_features
from vadsim.signals.sensor import SIMULATION_OVERSAMPLING, sensor_chain

__all__ = [
    "EventSimulation",
    "ValidationResult",
    "campaign_preset",
    "event_residuals",
    "findings",
    "Measurement",
    "load_any_campaign",
    "measure_event",
    "recorded_features",
    "run_event",
    "simulate_event",
    "validate",
]



def load_any_campaign(source: str | os.PathLike[str] | Campaign) -> Campaign:
    """A campaign from a folder or TOML file, or a shipped one: ``"thesis:7in-cde"``,
    ``"thesis:7in-rc"``, ``"thesis:9.5in-pdc"`` (the dissertation's field tables)."""
    if isinstance(source, Campaign):
        return source
    text = str(source)
    if text.startswith("thesis:"):
        key = text.split(":", 1)[1]
        shipped = thesis_campaigns()
        if key not in shipped:
            raise ValueError(f"unknown shipped campaign {text!r}: choose thesis:"
                             + ", thesis:".join(shipped))
        return shipped[key]
    return load_campaign(text)


def campaign_preset(campaign: Campaign) -> Preset:
    """The preset a campaign's ``tool`` and ``bit`` name (or its preset file)."""
    tool = campaign.tool
    if campaign.root is not None and (Path(campaign.root) / tool).is_file():
        return load_preset_file(Path(campaign.root) / tool)
    if Path(tool).is_file():
        return load_preset_file(tool)
    return get_preset(tool, campaign.bit)


@dataclass
class EventSimulation:
    """One simulated event: features through the sensor chain and at full resolution."""

    event_id: str
    flow_gpm: float
    wob_klbf: float
    f_exc_hz: float
    sensor: dict[str, Feature]
    full: dict[str, Feature]
    z: dict[str, float]
    scenario: int
    phase_sd: dict[str, float] = field(default_factory=dict)
    signals: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    rate_hz: float = 0.0
    error: str = ""


def _sensor_groups(campaign: Campaign) -> dict[float, list[str]]:
    groups: dict[float, list[str]] = {}
    for name, s in campaign.sensors.items():
        groups.setdefault(float(s.rate_hz), []).append(name)
    return groups


Measurement = Callable[[str, np.ndarray, float], np.ndarray]
"""What happens to a sensor's true acceleration before its recorded chain:
``measurement(sensor_name, a_g, fine_rate_hz) -> a_g`` on the solver's fine grid (e.g. a mount
resonance or an axial-lateral coupling, :mod:`vadsim.candidates`). ``None``: nothing."""


def run_event(
    campaign: Campaign,
    event: Event,
    *,
    preset: Preset | None = None,
    overrides: Mapping[str, float] | None = None,
    extras: Sequence[Any] = (),
    law: str | None = None,
    cycles: float = 400,
    analyse_cycles: float = 200,
) -> SimulationResult:
    """Run the model at one event's flow and WOB, recording the steady window on a grid fine
    enough for every sensor of the campaign (:data:`vadsim.sensor.SIMULATION_OVERSAMPLING`)."""
    preset = preset or campaign_preset(campaign)
    fine = SIMULATION_OVERSAMPLING * max(s.rate_hz for s in campaign.sensors.values())
    return simulate(
        preset, event.flow_gpm, cycles=cycles, analyse_cycles=analyse_cycles,
        overrides=overrides, wob_klbf=event.wob_klbf, law=law, extras=list(extras),
        record="window", output_rate_hz=fine,
    )


def simulate_event(
    campaign: Campaign,
    event: Event,
    *,
    preset: Preset | None = None,
    overrides: Mapping[str, float] | None = None,
    extras: Sequence[Any] = (),
    law: str | None = None,
    cycles: float = 400,
    analyse_cycles: float = 200,
    phases: int = 8,
    noise_g: float = 0.0,
    seed: int | None = None,
    keep_signals: bool = False,
    measurement: Measurement | None = None,
) -> EventSimulation:
    """Simulate one event and compute its features through each sensor's chain and at full
    resolution (:func:`run_event` then :func:`measure_event`)."""
    r = run_event(campaign, event, preset=preset, overrides=overrides, extras=extras, law=law,
                  cycles=cycles, analyse_cycles=analyse_cycles)
    return measure_event(campaign, event, r, phases=phases, noise_g=noise_g, seed=seed,
                         keep_signals=keep_signals, measurement=measurement)


def measure_event(
    campaign: Campaign,
    event: Event,
    r: SimulationResult,
    *,
    phases: int = 8,
    noise_g: float = 0.0,
    seed: int | None = None,
    keep_signals: bool = False,
    measurement: Measurement | None = None,
) -> EventSimulation:
    """Features of a run through each sensor's chain and at full resolution.

    A recording's sampling phase is unknown, and a 1 ms impact spike sampled at 1024 Hz shows
    a peak that depends on it (33-40 g at 400 gal/min for the 7in tool). The features through
    the chain are therefore averaged over ``phases`` sampling phases (0, 1/phases, ...) of
    the same run: the model's expectation, not one draw; ``phase_sd`` keeps their standard
    deviation, the model's own uncertainty about a recording's features. It matters most
    where the excitation is nearly commensurate with the sampling (64 Hz at 1024 Hz: 16.0
    samples per cycle), where a recording keeps one phase for its whole length.

    Kept apart from the run so that measurement-side physics (``measurement``) can be varied
    without running the model again.
    """
    if not (isinstance(phases, int) and phases >= 1):
        raise ValueError(f"phases = {phases!r} must be an integer >= 1")
    rates = [s.rate_hz for s in campaign.sensors.values()]
    fine = SIMULATION_OVERSAMPLING * max(rates)
    rng = np.random.default_rng(seed)
    sensor_feats: dict[str, Feature] = {}
    full_feats: dict[str, Feature] = {}
    phase_sd: dict[str, float] = {}
    kept: dict[str, np.ndarray] = {}
    for rate, names in _sensor_groups(campaign).items():
        full = {name: r.a[:, campaign.sensors[name].dof - 1] / G for name in names}
        if measurement is not None:
            full = {name: np.asarray(measurement(name, a, fine), dtype=float)
                    for name, a in full.items()}
        per_phase: list[dict[str, Feature]] = []
        for k in range(phases):
            sampled, clipped = {}, {}
            for name in names:
                s = campaign.sensors[name]
                _, a_s, clip = sensor_chain(r.t, full[name], rate_hz=s.rate_hz,
                                            range_g=s.range_g, lowpass_hz=s.lowpass_hz,
                                            phase=k / phases, noise_g=noise_g, rng=rng)
                sampled[name], clipped[name] = a_s, clip
                if keep_signals and k == 0:
                    kept[name] = a_s
            per_phase.append(event_features(sampled, rate, r.f_exc_hz, clipped=clipped))
        for key in per_phase[0]:
            vals = [f[key] for f in per_phase if key in f]
            values = np.array([v.value for v in vals])
            sensor_feats[key] = Feature(float(np.mean(values)),
                                        float(np.mean([v.spread for v in vals])),
                                        int(sum(v.n for v in vals)))
            phase_sd[key] = float(np.std(values)) if len(values) > 1 else 0.0
        full_feats.update(event_features(full, fine, r.f_exc_hz))
    return EventSimulation(
        event_id=event.id, flow_gpm=event.flow_gpm, wob_klbf=float(event.wob_klbf),
        f_exc_hz=r.f_exc_hz, sensor=sensor_feats, full=full_feats, z=r.z,
        scenario=r.scenario, phase_sd=phase_sd, signals=kept, rate_hz=float(max(rates)),
    )


def event_residuals(sim: EventSimulation, rec: Mapping[str, Feature],
                    resolution: str = "sensor") -> dict[str, float]:
    """Standardised residuals of one event: (model - recorded) / spread.

    Through the sensor chain the spread combines the recording's own (window to window) and
    the model's over unknown sampling phases, ``sqrt(rec.spread^2 + phase_sd^2)``; at full
    resolution it is the recording's alone.
    """
    feats = sim.sensor if resolution == "sensor" else sim.full
    out: dict[str, float] = {}
    for key, f in rec.items():
        m = feats.get(key)
        if m is None or not (math.isfinite(m.value) and math.isfinite(f.value)):
            continue
        sd = f.spread
        if resolution == "sensor":
            sd = math.hypot(sd, sim.phase_sd.get(key, 0.0))
        if sd > 0 and math.isfinite(sd):
            out[key] = (m.value - f.value) / sd
    return out


def recorded_features(campaign: Campaign, event: Event, f_exc_hz: float) -> dict[str, Feature]:
    """Features of a recorded event (time series), or its summary-only features."""
    if event.data is None:
        return summary_features(event.features)
    out: dict[str, Feature] = {}
    for rate, names in _sensor_groups(campaign).items():
        signals = {n: event.data[f"{n}_g"].to_numpy(float) for n in names}
        clipped = {n: event.clipped.get(n) for n in names if event.clipped.get(n) is not None}
        out.update(event_features(signals, rate, f_exc_hz, clipped=clipped or None))
    if event.features:  # summary values given next to a time series win: they are stated
        out.update(summary_features(event.features))
    return out


@dataclass
class ValidationResult:
    """Everything a validation computed, ready for a report or a diagnosis."""

    campaign: Campaign
    preset: Preset
    overrides: dict[str, float]
    simulations: dict[str, EventSimulation]
    recorded: dict[str, dict[str, Feature]]
    residuals: pd.DataFrame
    residuals_full: pd.DataFrame
    settings: dict[str, Any]

    def events_table(self) -> pd.DataFrame:
        """One row per event: operating point, regime, and each compared feature recorded,
        simulated (sensor chain and full resolution) and standardised residual."""
        rows = []
        for ev in self.campaign.events:
            sim = self.simulations[ev.id]
            rec = self.recorded[ev.id]
            row: dict[str, Any] = {"event": ev.id, "flow_gpm": ev.flow_gpm,
                                   "wob_klbf": ev.wob_klbf, "f_exc_hz": sim.f_exc_hz,
                                   "scenario": sim.scenario, "Z_spring": sim.z["spring"],
                                   "Z_impact": sim.z["impact"]}
            for key, f in rec.items():
                if key not in sim.sensor:
                    continue
                row[f"{key} rec"] = f.value
                row[f"{key} spread"] = f.spread
                row[f"{key} sim"] = sim.sensor[key].value
                row[f"{key} sim-full"] = sim.full.get(key, Feature(math.nan, math.nan, 0)).value
                row[f"{key} z"] = self.residuals.loc[ev.id, key]
            rows.append(row)
        return pd.DataFrame(rows).set_index("event")


def validate(
    campaign: str | os.PathLike[str] | Campaign,
    *,
    overrides: Mapping[str, float] | None = None,
    extras: Sequence[Any] = (),
    law: str | None = None,
    cycles: float = 400,
    analyse_cycles: float = 200,
    workers: int | None = None,
    preset: Preset | None = None,
    measurement: Measurement | None = None,
) -> ValidationResult:
    """Simulate every event of a campaign (in parallel threads) and compare features.

    Returns
    -------
    ValidationResult
        ``residuals`` (events x features): (simulated through the sensor chain - recorded) /
        recorded spread; ``residuals_full``: the same with full-resolution simulated features.
    """
    camp = load_any_campaign(campaign)
    preset = preset or campaign_preset(camp)
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        futures = {ev.id: pool.submit(simulate_event, camp, ev, preset=preset,
                                      overrides=overrides, extras=extras, law=law,
                                      cycles=cycles, analyse_cycles=analyse_cycles,
                                      measurement=measurement)
                   for ev in camp.events}
        sims = {k: f.result() for k, f in futures.items()}
    recorded = {ev.id: recorded_features(camp, ev, sims[ev.id].f_exc_hz) for ev in camp.events}
    order = [ev.id for ev in camp.events]
    res = pd.DataFrame({e: event_residuals(sims[e], recorded[e], "sensor") for e in order}).T
    res_full = pd.DataFrame({e: event_residuals(sims[e], recorded[e], "full") for e in order}).T
    return ValidationResult(
        campaign=camp, preset=preset, overrides=dict(overrides or {}), simulations=sims,
        recorded=recorded, residuals=res.reindex(order), residuals_full=res_full.reindex(order),
        settings=dict(cycles=cycles, analyse_cycles=analyse_cycles, law=law,
                      extras=[getattr(e, "name", str(e)) for e in extras]),
    )


def findings(result: ValidationResult, threshold: float = 1.0) -> list[str]:
    """Plain-language statements of where the model matches and where it does not: for each
    compared feature (through the sensor chain and at full resolution), the mean
    standardised residual over the lower and the upper half of the campaign's flows."""
    flows = pd.Series({ev.id: ev.flow_gpm for ev in result.campaign.events})
    median = float(flows.median())
    low = flows.index[flows <= median]
    high = flows.index[flows > median]
    out = []
    for label, res in (("through the sensor chain", result.residuals),
                       ("at full resolution", result.residuals_full)):
        for key in res.columns:
            col = res[key].dropna()
            if col.empty:
                continue
            parts = []
            for name, ids in ((f"flows <= {median:g} gal/min", low),
                              (f"flows > {median:g} gal/min", high)):
                z = col.reindex(ids).dropna()
                if z.empty:
                    continue
                m = float(z.mean())
                verdict = ("over-predicts" if m > threshold else
                           "under-predicts" if m < -threshold else "matches")
                parts.append(f"{verdict} at {name} (mean z {m:+.1f}, {len(z)} events)")
            if parts:
                out.append(f"{key} {label}: the model " + "; ".join(parts) + ".")
    return out


def __getattr__(name: str) -> Any:
    # vadsim 0.1 kept the report writer here; it now lives in vadsim.report
    if name == "write_report":
        from vadsim.report.validation import write_validation_report

        return write_validation_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
