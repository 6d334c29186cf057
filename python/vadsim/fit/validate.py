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
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import pandas as pd

from vadsim._interrupt import finished, stop_on_interrupt
from vadsim._progress import bar
from vadsim.campaigns import Campaign, Event, campaign_preset, load_any_campaign
from vadsim.compare import (
    FOLDED,
    EventSimulation,
    Measurement,
    event_residuals,
    fine_rate_hz,
    recorded_features,
    simulate_event,
)
from vadsim.model.cache import ResultCache, Uncacheable, default_cache
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import Preset
from vadsim.model.settings import RunSettings
from vadsim.signals.features import Feature

__all__ = ["ValidationResult", "validate"]



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
                                   "scenario": sim.scenario, "z_spring": sim.z["spring"],
                                   "z_impact": sim.z["impact"]}
            for key, f in rec.items():
                if key not in sim.sensor:
                    continue
                row[f"{key} rec"] = f.value
                row[f"{key} spread"] = f.spread
                row[f"{key} sim"] = sim.sensor[key].value
                row[f"{key} sim-full"] = sim.full.get(key, Feature(math.nan, math.nan, 0)).value
                row[f"{key} z"] = (self.residuals.loc[ev.id, key] if key in self.residuals
                                   else math.nan)
            rows.append(row)
        return pd.DataFrame(rows).set_index("event")

    def not_compared(self) -> pd.DataFrame:
        """Recorded features that could not be compared, and why (one row per event and
        feature): a recording whose every window is clipped has no peak to compare, a spread
        of zero cannot standardise, a feature the model lacks has no counterpart."""
        rows = []
        for ev in self.campaign.events:
            sim = self.simulations[ev.id]
            done = self.residuals.loc[ev.id].dropna().index if ev.id in self.residuals.index \
                else []
            for key, f in self.recorded[ev.id].items():
                if key in done or key.startswith("z_"):
                    continue
                rows.append({"event": ev.id, "flow_gpm": ev.flow_gpm, "feature": key,
                             "reason": _why_not_compared(self.campaign, key, f,
                                                         sim.sensor.get(key))})
        return pd.DataFrame(rows, columns=["event", "flow_gpm", "feature", "reason"])


def _why_not_compared(campaign: Campaign, key: str, rec: Feature, model: Feature | None) -> str:
    sensor = campaign.sensors.get(key.split("_", 1)[0])
    if not math.isfinite(rec.value):
        if key.endswith("_ratio"):
            return "a ratio of peaks needs both sensors' peaks, and one has none (clipped)"
        if sensor is not None and "peak" in key:
            return (f"every 200 ms window of {sensor.name} holds a sample clipped at its "
                    f"{sensor.range_g:g} g range: no recorded peak")
        return "the recording gives no value"
    if model is None or not math.isfinite(model.value):
        return "the model gives no value (e.g. every simulated window clipped)"
    return f"the recorded spread ({rec.spread:g}) cannot standardise"


def validate(
    campaign: str | os.PathLike[str] | Campaign,
    *,
    overrides: Mapping[str, float] | None = None,
    extras: Sequence[Any] = (),
    law: str | None = None,
    cycles: float = DEFAULTS.cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    workers: int | None = None,
    preset: Preset | None = None,
    measurement: Measurement | None = None,
    settings: RunSettings | None = None,
    progress: bool = True,
    cache: ResultCache | str | os.PathLike[str] | bool | None = None,
) -> ValidationResult:
    """Simulate every event of a campaign (in parallel threads) and compare features.

    Why so many parameters: the base model is given piece by piece as the command line does
    (``preset``, ``overrides``, ``extras``, ``law``, ``cycles``, ``analyse_cycles``) or whole
    as ``settings``; the rest say what happens to the sensors' signals (``measurement``) and
    how the runs are made (``workers``, ``cache``, ``progress``).

    The base model is ``settings``, or the campaign's preset (or ``preset``) with
    ``overrides``, ``extras``, ``law``, ``cycles`` and ``analyse_cycles``. ``progress``
    shows a progress bar over the events (stderr). ``cache``: a
    :class:`~vadsim.model.cache.ResultCache` or its folder for each event's simulation (None:
    ``$VADSIM_CACHE`` if set, as for calibrate and diagnose; False: none); runs with a
    ``measurement`` are not cached.

    Returns
    -------
    ValidationResult
        ``residuals`` (events x features): (simulated through the sensor chain - recorded) /
        recorded spread; ``residuals_full``: the same with full-resolution simulated features.
    """
    camp = load_any_campaign(campaign)
    if settings is None:
        settings = RunSettings(preset or campaign_preset(camp), overrides=overrides or {},
                               extras=tuple(extras), law=law, cycles=cycles,
                               analyse_cycles=analyse_cycles)
    store = default_cache(cache) if measurement is None else None

    def one(ev: Event) -> EventSimulation:
        return _simulate_cached(store, camp, ev, settings, measurement)

    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool, \
            stop_on_interrupt(pool):
        futures = {ev.id: pool.submit(one, ev) for ev in camp.events}
        with bar(progress, len(futures), f"validate {camp.name}", "event") as b:
            for f in finished(futures.values()):
                f.result()
                b.update()
        sims = {k: f.result() for k, f in futures.items()}
    recorded = {ev.id: recorded_features(camp, ev, sims[ev.id].f_exc_hz) for ev in camp.events}
    order = [ev.id for ev in camp.events]
    res = pd.DataFrame({e: event_residuals(sims[e], recorded[e], "sensor") for e in order}).T
    res_full = pd.DataFrame({e: event_residuals(sims[e], recorded[e], "full") for e in order}).T
    described = settings.as_dict()
    return ValidationResult(
        campaign=camp, preset=settings.preset, overrides=dict(settings.overrides),
        simulations=sims, recorded=recorded, residuals=res.reindex(order),
        residuals_full=res_full.reindex(order),
        settings={k: described[k] for k in ("cycles", "analyse_cycles", "law", "extras")},
    )


def _simulate_cached(store: ResultCache | None, camp: Campaign, ev: Event,
                     settings: RunSettings, measurement: Measurement | None) -> EventSimulation:
    """:func:`~vadsim.compare.simulate_event`, read from and written to ``store`` if any."""
    key = None
    if store is not None:
        try:
            key = store.key("validate-event", settings, ev.flow_gpm, float(ev.wob_klbf),
                            fine_rate_hz(camp), camp.sensors, FOLDED)
        except (Uncacheable, ValueError):
            key = None
    if key is not None:
        assert store is not None
        hit = store.get(key, parse=EventSimulation.from_json_entry)
        if isinstance(hit, EventSimulation):
            return replace(hit, event_id=ev.id)
    sim = simulate_event(camp, ev, settings, measurement=measurement)
    if key is not None:
        assert store is not None
        store.put(key, sim.to_json())
    return sim
