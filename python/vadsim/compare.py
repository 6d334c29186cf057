"""The comparison engine: from a campaign and run settings to standardised residuals.

Why this module exists: validation, calibration and diagnosis all ask one question -- how far
is the model from the recordings, event by event and feature by feature, in units of the
recording's own spread? They answer it here, the same way, with the same failure handling:

1. **run** an event at its flow and WOB (:func:`run_event`, or :func:`summary_event` when only
   the core's full-resolution summary is needed), continued while its window drifts (a
   recording is steady drilling: :mod:`vadsim.model.steady`). A periodic run stops at its
   orbit (``steady="auto"``) and hands over one orbit instead of its window's fine series
   (:func:`fine_series` rebuilds the window from it). With ``warm_starts``, a model change
   starts each event from the base model's steady state there (:class:`WarmStart`: a fixed,
   stored state) and settles :data:`WARM_SETTLE_CYCLES`;
2. **measure** the run through each sensor's chain, averaged over sampling phases, and at full
   resolution (:func:`measure_event`), optionally after measurement-side physics;
3. compute the **recorded** features (:func:`recorded_features`);

Folded evidence (:data:`FOLDED`, on by default; ``folded=False`` gives the features of before):
a recorded time series is also folded by excitation phase (equivalent-time sampling,
:mod:`vadsim.signals.folding`), which recovers the cycle's waveform -- the 1 ms impact spike
included -- far beyond what 1024 Hz sampling shows, and the simulation gives the matching
features from its fine grid through the sensors' analog chain
(:mod:`vadsim.signals.fold_features`; the recording decides between folded and distribution
features, the simulation computes every kind). They enter ``EventSimulation.sensor`` with a
``phase_sd`` of 0, so residuals and the evaluator compare them like every other feature.
4. **standardise** (:func:`standardised_residual`, the one definition of a residual;
   :func:`event_residuals` for an event, :func:`residual_table` for a campaign).

:class:`CampaignEvaluator` does 1-4 for every event of a campaign and any model change (extra
physics, overrides, a measurement), in parallel threads, caching runs: a measurement-side
change re-measures the base model's runs instead of running the model again. With a
:class:`~vadsim.model.cache.ResultCache` (``cache=`` or ``$VADSIM_CACHE``) each event's
measured simulation is also kept on disk, keyed by its exact inputs and the code's
fingerprint, so another diagnosis, calibration or validation that meets the same run (the same
event under the same model) reads it instead of running it again.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
from collections import OrderedDict
from collections.abc import Hashable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vadsim._interrupt import result, stop_on_interrupt
from vadsim.campaigns.format import CAMPAIGN_FILE, Campaign, Event, excerpt
from vadsim.model.cache import ResultCache, Uncacheable, default_cache
from vadsim.model.change import Measurement, ModelChange
from vadsim.model.settings import RunSettings
from vadsim.model.simulate import G, SimulationResult, SolverError
from vadsim.model.steady import steady_run
from vadsim.signals.features import Feature, event_features, summary_features
from vadsim.signals.fold_features import (
    ALT_MARK,
    fold_periods,
    model_fold_features,
    noise_floor_g,
    recorded_fold_features,
)
from vadsim.signals.sensor import SIMULATION_OVERSAMPLING, FilteredSignal

__all__ = [
    "FAILED_RESIDUAL",
    "FOLDED",
    "ORBIT_OVERSAMPLING",
    "WARM_SETTLE_CYCLES",
    "NOISE_SEED",
    "NOISE_STEP_G",
    "CampaignEvaluator",
    "EventEval",
    "EventSimulation",
    "Measurement",
    "WarmStart",
    "ModelChange",
    "event_residuals",
    "fine_rate_hz",
    "fine_series",
    "measure_event",
    "recorded_features",
    "recorded_noise_g",
    "residual_table",
    "run_event",
    "sensor_groups",
    "simulate_event",
    "standardised_residual",
    "summary_event",
]

FAILED_RESIDUAL = 10.0
"""Standardised residual of every compared feature of an event whose run fails, or of a
feature the run lost: large enough that a fit moves away, bounded so one failure does not
swamp a campaign."""

FOLDED: bool = True
"""Default of every ``folded`` argument (None means this): compare folded (or distribution)
features of recorded time series besides the 200 ms window features. Set False for the
comparison of before folding existed; campaigns of summary features only are unaffected."""


def _use_folded(folded: bool | None) -> bool:
    return FOLDED if folded is None else bool(folded)


WARM_SETTLE_CYCLES = 30
"""Cycles a warm-started run settles before its analysed window. A warm start sits on the
base model's attractor; a change moves it a little, and its transient dies within a few tens
of cycles (a periodic one is then confirmed and the run stops). A run whose window still
drifts is continued as any other (:func:`vadsim.model.steady.steady_run`)."""

ORBIT_OVERSAMPLING = 4
"""The orbit a periodic run hands over is tabulated at this many times the fine grid's rate:
the window rebuilt from it by linear interpolation (:func:`fine_series`) then differs from
the core's own samples by well under the sensor's interpolation error (4x: 7e-4 of a 1 kHz
ring's amplitude)."""


@dataclass(frozen=True)
class WarmStart:
    """Where a changed model's run at one event starts: the base model's final state there,
    as displacements from its static state and velocities (``end_displacement``, at a whole
    number of cycles, so in phase with the excitation at t = 0; a change that moves the
    static state, a WOB or a length, keeps the motion about it), and the base model's impact
    scenario, to tell a warm start that lands on another attractor. ``source`` says what the
    state is a function of (the base model's settings and
    the event's operating point), so that a result cache can key a run on it without running
    the base model first; None keys it on the state's own values."""

    state: np.ndarray
    scenario: int
    source: Any = None

    def key(self) -> Any:
        """The start as exact plain data (for a result cache's key)."""
        if self.source is not None:
            return self.source
        return (tuple(float(v) for v in self.state), int(self.scenario))


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
    start: str = "rest"
    """Where the run started: ``"rest"`` (the static state) or ``"warm"`` (the base model's
    steady state at the event)."""
    multistable: bool = False
    """A warm start reached another impact scenario than a start from rest: two attractors at
    this event; the run from rest (the dissertation's) is the one measured."""
    steady_period: int = 0
    """Cycles of the periodic orbit the run stopped at (0: integrated to its end)."""

    def to_json(self) -> dict[str, Any]:
        """Everything but the event's id and the kept signals, JSON-ready and exact (what a
        :class:`~vadsim.model.cache.ResultCache` stores)."""
        def feats(d: Mapping[str, Feature]) -> dict[str, list[float]]:
            return {k: [f.value, f.spread, f.n] for k, f in d.items()}

        return {"flow_gpm": self.flow_gpm, "wob_klbf": self.wob_klbf, "f_exc_hz": self.f_exc_hz,
                "sensor": feats(self.sensor), "full": feats(self.full), "z": dict(self.z),
                "scenario": self.scenario, "phase_sd": dict(self.phase_sd),
                "rate_hz": self.rate_hz, "error": self.error, "start": self.start,
                "multistable": self.multistable, "steady_period": self.steady_period}

    @classmethod
    def from_json(cls, event_id: str, d: Mapping[str, Any]) -> EventSimulation:
        """The inverse of :meth:`to_json` for event ``event_id``.

        Raises
        ------
        ValueError, TypeError
            If ``d`` is not what :meth:`to_json` writes (the keys, and numbers where numbers
            belong): a cache entry is checked against this schema before it is used.
        """
        if not isinstance(d, Mapping) or set(d) != _SIMULATION_KEYS:
            raise ValueError("not an event simulation: wrong keys")

        def feats(m: Any) -> dict[str, Feature]:
            return {str(k): Feature(_json_number(v), _json_number(sp), int(_json_number(n)))
                    for k, (v, sp, n) in _json_table(m).items()}

        return cls(event_id=event_id, flow_gpm=_json_number(d["flow_gpm"]),
                   wob_klbf=_json_number(d["wob_klbf"]), f_exc_hz=_json_number(d["f_exc_hz"]),
                   sensor=feats(d["sensor"]), full=feats(d["full"]),
                   z={k: _json_number(v) for k, v in _json_table(d["z"]).items()},
                   scenario=int(_json_number(d["scenario"])),
                   phase_sd={k: _json_number(v) for k, v in _json_table(d["phase_sd"]).items()},
                   rate_hz=_json_number(d["rate_hz"]), error=_json_str(d["error"]),
                   start=_json_str(d["start"]), multistable=_json_bool(d["multistable"]),
                   steady_period=int(_json_number(d["steady_period"])))

    @classmethod
    def from_json_entry(cls, value: Any) -> EventSimulation | None:
        """A cache entry's value checked: ``None`` for a run that failed (``{"failed": true}``),
        else the simulation (``event_id`` empty: the caller's event is set on it). Raises
        ValueError or TypeError for anything else, so that the cache rejects the entry."""
        if isinstance(value, Mapping) and set(value) == {"failed"}:
            if value["failed"] is not True:
                raise ValueError("not an event simulation: 'failed' must be true")
            return None
        return cls.from_json("", value)


_SIMULATION_KEYS = frozenset({"flow_gpm", "wob_klbf", "f_exc_hz", "sensor", "full", "z",
                              "scenario", "phase_sd", "rate_hz", "error", "start",
                              "multistable", "steady_period"})


_FAILED_RUN: Any = object()
"""What :func:`_cached_simulation` gives for a cached failed run (None is the cache's miss)."""


def _cached_simulation(value: Any) -> Any:
    """A cache entry's schema: an :class:`EventSimulation`, or :data:`_FAILED_RUN`."""
    sim = EventSimulation.from_json_entry(value)
    return _FAILED_RUN if sim is None else sim


def _json_number(value: Any) -> float:
    """A number of a JSON document (not a bool or a string), as a float."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"expected a number, got {type(value).__name__}")
    return float(value)


def _json_bool(value: Any) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"expected true or false, got {type(value).__name__}")
    return value


def _json_str(value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError(f"expected a string, got {type(value).__name__}")
    return value


def _json_table(value: Any) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise TypeError(f"expected a table, got {type(value).__name__}")
    return value


def sensor_groups(campaign: Campaign) -> dict[float, list[str]]:
    """Sensor names by sampling rate (features of one rate are computed together)."""
    groups: dict[float, list[str]] = {}
    for name, s in campaign.sensors.items():
        groups.setdefault(float(s.rate_hz), []).append(name)
    return groups


def fine_rate_hz(campaign: Campaign) -> float:
    """The rate (Hz) a run is recorded at to feed every sensor of ``campaign``."""
    return SIMULATION_OVERSAMPLING * max(s.rate_hz for s in campaign.sensors.values())


# ------------------------------------------------------------------------------ the model side

def run_event(campaign: Campaign, event: Event, settings: RunSettings, *,
              warm_start: WarmStart | None = None) -> SimulationResult:
    """Run the model at one event's flow and WOB, recording the steady window on a grid fine
    enough for every sensor of the campaign
    (:data:`vadsim.signals.sensor.SIMULATION_OVERSAMPLING` times the fastest sensor's rate).

    A recording is steady drilling: a run whose window still drifts is continued
    (:func:`vadsim.model.steady.steady_run`). Without the core's 20 kHz summary: every feature
    is measured from the stored series, and the summary cost 15 % of such a run. Only the
    accelerations are stored (a sensor measures nothing else): a third of the memory. A run
    that reaches a periodic orbit before its window returns the orbit
    (:data:`ORBIT_OVERSAMPLING` x the fine rate) instead of the window's fine series:
    :func:`fine_series` rebuilds the window from it.

    With ``warm_start`` the run starts from that state and settles
    :data:`WARM_SETTLE_CYCLES` (or the settings' own settling, if shorter) before its window.
    """
    fine = fine_rate_hz(campaign)
    options: dict[str, Any] = dict(record="window", output_rate_hz=fine, summary_rate_hz=0.0,
                                   accelerations_only=True,
                                   orbit_rate_hz=ORBIT_OVERSAMPLING * fine,
                                   orbit_replaces_window=True)
    start: dict[str, Any] = {}
    if warm_start is not None:
        settle = min(float(settings.cycles - settings.analyse_cycles), WARM_SETTLE_CYCLES)
        settings = settings.with_changes(cycles=settings.analyse_cycles + settle)
        start = dict(initial_displacement=warm_start.state)
    with _naming_the_event(campaign, event):
        return steady_run(settings, event.flow_gpm, wob_klbf=event.wob_klbf, **options,
                          **start)


def fine_series(r: SimulationResult, rate_hz: float, dofs: Iterable[int]
                ) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """The run's analysed window on its fine grid: times (s) and the accelerations (g) of
    bodies ``dofs`` (1..7). A run that returned its orbit instead of the window's series (a
    periodic run of :func:`run_event`) is rebuilt from the orbit on the grid the core would
    have stored, ``t0 + k / rate_hz``: the same times, values within the orbit table's
    interpolation (:data:`ORBIT_OVERSAMPLING`)."""
    if r.t.size or r.orbit is None:
        return r.t, {d: r.a[:, d - 1] / G for d in dofs}
    t0, t1 = r.window
    n = math.floor((t1 - t0) * rate_hz * (1 + 1e-12)) + 1
    t = t0 + np.arange(n) * (1.0 / rate_hz)  # as the core forms its grid: the same bits
    return t, {d: r.orbit.at(t, d) for d in dofs}


@contextlib.contextmanager
def _naming_the_event(campaign: Campaign, event: Event) -> Iterator[None]:
    """A ValueError of a run (a flow or WOB the model cannot take) re-raised with the
    campaign's file, the event's key and its id in front: the user edits that file."""
    try:
        yield
    except ValueError as exc:
        index = next((i for i, e in enumerate(campaign.events) if e is event), None)
        text = str(exc)
        field = ("flow_gpm" if text.startswith("flow_gpm") else
                 "wob_klbf" if text.startswith("wob_klbf") else None)
        key = "events" + (f"[{index}]" if index is not None else "") + (
            f".{field}" if field else "")
        where = (Path(campaign.root) / CAMPAIGN_FILE if campaign.root is not None
                 else f"campaign {excerpt(campaign.name)}")
        raise ValueError(f"{where}: key {key} (event {excerpt(event.id)}): {text}") from None


def summary_event(campaign: Campaign, event: Event, settings: RunSettings) -> EventSimulation:
    """Peaks and impacts per cycle at full resolution from the core's own steady-window summary
    (20 kHz): no time series is stored, which makes a 9.5in run 10x cheaper. What a comparison
    with the dissertation's own simulations needs."""
    with _naming_the_event(campaign, event):
        r = steady_run(settings, event.flow_gpm, wob_klbf=event.wob_klbf, record="none")
    full: dict[str, Feature] = {}
    for name, s in campaign.sensors.items():
        peaks = r.window_peaks_g[:, s.dof - 1]
        if peaks.size:
            full[f"{name}_peak_mean_g"] = Feature(float(peaks.mean()), float(peaks.std()),
                                                  int(peaks.size))
            full[f"{name}_peak_std_g"] = Feature(float(peaks.std()), math.nan, int(peaks.size))
    return EventSimulation(event_id=event.id, flow_gpm=event.flow_gpm,
                           wob_klbf=float(event.wob_klbf), f_exc_hz=r.f_exc_hz, sensor={},
                           full=full, z=r.z, scenario=r.scenario)


def _phase_average(per_phase: list[dict[str, Feature]]
                   ) -> tuple[dict[str, Feature], dict[str, float]]:
    out: dict[str, Feature] = {}
    sd: dict[str, float] = {}
    for key in per_phase[0]:
        vals = [f[key] for f in per_phase if key in f]
        values = np.array([v.value for v in vals])
        out[key] = Feature(float(np.mean(values)), float(np.mean([v.spread for v in vals])),
                           int(sum(v.n for v in vals)))
        sd[key] = float(np.std(values)) if len(values) > 1 else 0.0
    return out, sd


def _model_folded(campaign: Campaign, t: np.ndarray, f_exc_hz: float,
                  filtered: Mapping[str, FilteredSignal],
                  periods: Iterable[int] | None = None,
                  noise_g: Mapping[str, float] | None = None) -> dict[str, Feature]:
    """Folded and distribution features of one rate group's fine-grid signals, through each
    sensor's analog chain (its low-pass, done in ``filtered``, and range), folded at the run's
    exact frequency (every period, or ``periods``); the quantiles with each sensor's
    ``noise_g``, as a recording's hold it."""
    analog = {name: f.analog(campaign.sensors[name].range_g)[0]
              for name, f in filtered.items()}
    noise = {name: float((noise_g or {}).get(name, 0.0)) for name in filtered}
    rails = {name: campaign.sensors[name].range_g for name in filtered}
    if periods is None:
        return model_fold_features(t, analog, f_exc_hz, noise_g=noise, range_g=rails)
    return model_fold_features(t, analog, f_exc_hz, periods=periods, noise_g=noise,
                               range_g=rails)


def measure_event(
    campaign: Campaign,
    event: Event,
    r: SimulationResult,
    *,
    phases: int = 8,
    noise_g: float | Mapping[str, float] = 0.0,
    seed: int | None = None,
    keep_signals: bool = False,
    measurement: Measurement | None = None,
    folded: bool | None = None,
    full_features: bool = True,
    fold_periods: Iterable[int] | None = None,
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

    With ``folded`` (default :data:`FOLDED`) the sensor features also hold every folded and
    distribution feature a recording may have (:func:`vadsim.signals.fold_features.
    model_fold_features`: the fine grid through each sensor's low-pass and range, folded at
    the run's exact frequency, for periods 1-4), with a ``phase_sd`` of 0: a fold has no
    sampling phase. The recording's keys select which are compared.

    ``full_features=False`` skips the full-resolution features (``full``): a comparison
    through the sensor chains does not use them, and they cost a third of the measurement.
    ``fold_periods`` folds only those periods (default: 1-4): a comparison with a recording
    needs only the period the recording folded at (:func:`vadsim.signals.fold_features.
    fold_periods` of its keys), and the folds are half of a measurement's cost.

    ``noise_g`` (one value, or one per sensor name) adds each sensor's Gaussian noise to the
    sampled series, drawn from ``seed``: a recording's window features (peaks, quantiles,
    impacts) carry its noise, e.g. a 200 ms peak of a 1 g-noise record is the peak of signal
    plus noise (:func:`recorded_noise_g`). Folds are taken without it (a fold averages noise
    out), the quantiles of ``|a|`` with it (:func:`vadsim.signals.fold_features.
    noisy_quantiles`).
    """
    if not (isinstance(phases, int) and phases >= 1):
        raise ValueError(f"phases = {phases!r} must be an integer >= 1")
    noise = (dict(noise_g) if isinstance(noise_g, Mapping)
             else dict.fromkeys(campaign.sensors, noise_g))
    fine = fine_rate_hz(campaign)
    rng = np.random.default_rng(seed)
    sensor_feats: dict[str, Feature] = {}
    full_feats: dict[str, Feature] = {}
    phase_sd: dict[str, float] = {}
    kept: dict[str, np.ndarray] = {}
    t, a = fine_series(r, fine, {s.dof for s in campaign.sensors.values()})
    for rate, names in sensor_groups(campaign).items():
        full = {name: a[campaign.sensors[name].dof] for name in names}
        if measurement is not None:
            full = {name: np.asarray(measurement(name, a, fine), dtype=float)
                    for name, a in full.items()}
        # checked and low-passed once: every phase and the fold share it
        filtered = {name: FilteredSignal(t, full[name], campaign.sensors[name].lowpass_hz)
                    for name in names}
        per_phase: list[dict[str, Feature]] = []
        for k in range(phases):
            sampled, clipped = {}, {}
            for name in names:
                s = campaign.sensors[name]
                _, a_s, clip = filtered[name].sample(s.rate_hz, s.range_g, k / phases,
                                                     noise.get(name, 0.0), rng)
                sampled[name], clipped[name] = a_s, clip
                if keep_signals and k == 0:
                    kept[name] = a_s
            per_phase.append(event_features(sampled, rate, r.f_exc_hz, clipped=clipped))
        averaged, sd = _phase_average(per_phase)
        sensor_feats.update(averaged)
        phase_sd.update(sd)
        if _use_folded(folded):
            fx = _model_folded(campaign, t, r.f_exc_hz, filtered, fold_periods, noise)
            sensor_feats.update(fx)
            phase_sd.update(dict.fromkeys(fx, 0.0))
        if full_features:
            full_feats.update(event_features(full, fine, r.f_exc_hz))
    return EventSimulation(
        event_id=event.id, flow_gpm=event.flow_gpm, wob_klbf=float(event.wob_klbf),
        f_exc_hz=r.f_exc_hz, sensor=sensor_feats, full=full_feats, z=r.z,
        scenario=r.scenario, phase_sd=phase_sd, signals=kept,
        rate_hz=float(max(s.rate_hz for s in campaign.sensors.values())),
        steady_period=r.steady_info.period if r.steady_info is not None else 0,
    )


def simulate_event(campaign: Campaign, event: Event, settings: RunSettings, *,
                   phases: int = 8, noise_g: float | Mapping[str, float] = 0.0,
                   seed: int | None = None,
                   keep_signals: bool = False, measurement: Measurement | None = None,
                   folded: bool | None = None) -> EventSimulation:
    """:func:`run_event` then :func:`measure_event`."""
    r = run_event(campaign, event, settings)
    return measure_event(campaign, event, r, phases=phases, noise_g=noise_g, seed=seed,
                         keep_signals=keep_signals, measurement=measurement, folded=folded)


# ---------------------------------------------------------------------------- the recorded side

def recorded_features(campaign: Campaign, event: Event, f_exc_hz: float, *,
                      folded: bool | None = None) -> dict[str, Feature]:
    """Features of a recorded event (time series), or its summary-only features.

    With ``folded`` (default :data:`FOLDED`) a time series also gives its folded features
    (the cycle waveform by equivalent-time sampling, with ``f_exc_hz`` refined on the record)
    or, where it does not repeat, its distribution features
    (:func:`vadsim.signals.fold_features.recorded_fold_features`).
    """
    if event.data is None:
        return summary_features(event.features)
    out: dict[str, Feature] = {}
    t0 = float(event.data["time_s"].iloc[0])
    for rate, names in sensor_groups(campaign).items():
        signals = {n: event.data[f"{n}_g"].to_numpy(float) for n in names}
        clipped = {n: event.clipped[n] for n in names if event.clipped.get(n) is not None}
        out.update(event_features(signals, rate, f_exc_hz, clipped=clipped or None))
        if _use_folded(folded):
            out.update(recorded_fold_features(signals, rate, f_exc_hz, t0=t0))
    if event.features:  # summary values given next to a time series win: they are stated
        out.update(summary_features(event.features))
    return out


def recorded_noise_g(campaign: Campaign, settings: RunSettings) -> dict[str, float]:
    """Each sensor's noise in a campaign's recordings, g: the smallest over its events of
    :func:`vadsim.signals.fold_features.noise_floor_g` (noise belongs to the sensor, and an
    event whose response does not repeat only adds to the estimate). Empty for a campaign of
    summary features only: its stated features carry no noise to imitate.

    Why the model needs it: the window features of a noisy record are those of signal plus
    noise. Measured on a written 1 g-noise campaign, the recording's own model left every
    event at RMS z 1.0-1.6 (the x5 200 ms peak 2.7-3.5 spreads off, impacts per cycle 3.9),
    and a diagnosis took the difference for a sensor resonance; measured with the record's
    noise, the same model is at 0.5-0.7.
    """
    best: dict[str, float] = {}
    for ev in campaign.events:
        if ev.data is None or len(ev.data) < 2:
            continue
        t0 = float(ev.data["time_s"].iloc[0])
        for rate, names in sensor_groups(campaign).items():
            signals = {n: ev.data[f"{n}_g"].to_numpy(float) for n in names}
            try:
                got = noise_floor_g(signals, rate, settings.f_exc_hz(ev.flow_gpm), t0=t0)
            except ValueError:  # too short to fold: no estimate from this event
                continue
            for n, v in got.items():
                if math.isfinite(v):
                    best[n] = min(v, best.get(n, math.inf))
    return best


# ------------------------------------------------------------------------------- residuals

def standardised_residual(model: Feature | float, recorded: Feature,
                          model_sd: float = 0.0) -> float | None:
    """``(model - recorded) / spread``, the one definition of a residual in vadsim.

    The spread is the recording's own (window to window), combined with the model's own
    uncertainty ``model_sd`` (its spread over unknown sampling phases) as
    ``sqrt(recorded.spread^2 + model_sd^2)``. None where either value is not finite or the
    spread is not a positive finite number (it cannot standardise).
    """
    value = model.value if isinstance(model, Feature) else float(model)
    if not (math.isfinite(value) and math.isfinite(recorded.value)):
        return None
    sd = math.hypot(recorded.spread, model_sd) if model_sd else recorded.spread
    if not (sd > 0 and math.isfinite(sd)):
        return None
    return (value - recorded.value) / sd


def event_residuals(sim: EventSimulation, rec: Mapping[str, Feature],
                    resolution: str = "sensor") -> dict[str, float]:
    """Standardised residuals of one event for every recorded (or target) feature the model
    has: through the sensor chain (``resolution="sensor"``, with the model's spread over
    sampling phases) or at full resolution (``"full"``, the recording's spread alone). Targets
    named ``z_<surface>`` compare the run's impacts per cycle at that surface."""
    if resolution not in ("sensor", "full"):
        raise ValueError(f"resolution = {resolution!r} must be 'sensor' or 'full'")
    feats = sim.sensor if resolution == "sensor" else sim.full
    out: dict[str, float] = {}
    for key, f in rec.items():
        if key.startswith("z_") and key[2:] in sim.z:
            z = standardised_residual(sim.z[key[2:]], f)
        elif key in feats:
            sd = sim.phase_sd.get(key, 0.0) if resolution == "sensor" else 0.0
            z = standardised_residual(feats[key], f, sd)
        else:
            continue
        if z is not None:
            out[key] = z
    _best_alignment(out, feats, rec, sim.phase_sd if resolution == "sensor" else {})
    return out


def _best_alignment(out: dict[str, float], feats: Mapping[str, Feature],
                    rec: Mapping[str, Feature], phase_sd: Mapping[str, float]) -> None:
    """Where the model's fold of period n > 1 comes under alternative alignments (keys
    ``<key>@cycle<c>``, :mod:`vadsim.signals.fold_features`, "Alignment"), take for each
    period the one whose residuals over every sensor's features of that fold are smallest."""
    alts: dict[str, set[str]] = {}
    for key in feats:
        if ALT_MARK in key:
            base, cycle = key.split(ALT_MARK)
            tag = next((p for p in base.split("_") if p.startswith("fold")), None)
            if tag is not None:
                alts.setdefault(tag, set()).add(cycle)
    for tag, cycles in alts.items():
        group = [k for k in out if f"_{tag}_" in k]
        best = sum(out[k] ** 2 for k in group)
        for cycle in sorted(cycles):
            trial = {}
            for k in group:
                f = feats.get(f"{k}{ALT_MARK}{cycle}", feats[k])
                z = standardised_residual(f, rec[k], phase_sd.get(k, 0.0))
                trial[k] = z if z is not None else out[k]
            cost = sum(v ** 2 for v in trial.values())
            if cost < best:
                best = cost
                out.update(trial)


def residual_table(sim: Mapping[str, Mapping[str, Feature]],
                   rec: Mapping[str, Mapping[str, Feature]],
                   keys: Sequence[str] | None = None) -> pd.DataFrame:
    """Events x features table of :func:`standardised_residual` (the recording's spread).

    ``sim`` and ``rec`` map event ids to features. Rows: the events of ``rec``, then those only
    in ``sim``; columns: ``keys``, or every key some event has on both sides, in the order first
    met in ``rec``. NaN where either side lacks the event or key, or a residual is undefined.
    """
    for name, side in (("sim", sim), ("rec", rec)):
        if not isinstance(side, Mapping) or not all(
                isinstance(f, Mapping) and all(isinstance(v, Feature) for v in f.values())
                for f in side.values()):
            raise ValueError(f"{name} must map event ids to mappings of Feature")
    order = list(dict.fromkeys(k for feats in rec.values() for k in feats))
    if keys is None:
        names = [k for k in order if any(k in f and k in sim.get(e, {}) for e, f in rec.items())]
    else:
        if isinstance(keys, str) or not isinstance(keys, Sequence):
            raise ValueError(f"keys must be a sequence of feature keys, got {keys!r}")
        known = set(order) | {k for f in sim.values() for k in f}
        for k in keys:
            if not isinstance(k, str) or k not in known:
                raise ValueError(f"keys: {k!r} is a feature of no event in sim or rec")
        names = list(keys)
    events = list(rec) + [e for e in sim if e not in rec]
    data = np.full((len(events), len(names)), np.nan)
    for i, eid in enumerate(events):
        s, r = sim.get(eid, {}), rec.get(eid, {})
        for j, k in enumerate(names):
            z = standardised_residual(s[k], r[k]) if k in s and k in r else None
            data[i, j] = np.nan if z is None else z
    return pd.DataFrame(data, index=pd.Index(events, name="event"), columns=names)


# ------------------------------------------------------------------------- the campaign engine

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
                 phases: int = 8, workers: int | None = None,
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
        self.folded = _use_folded(folded)
        self.workers = workers or os.cpu_count() or 1
        self.events = {ev.id: ev for ev in campaign.events}
        self.targets = ({e: dict(t) for e, t in targets.items()} if targets is not None else
                        {ev.id: recorded_features(campaign, ev, settings.f_exc_hz(ev.flow_gpm),
                                                  folded=self.folded)
                         for ev in campaign.events})
        self.keys: dict[str, list[str]] = {e: list(k) for e, k in (keys or {}).items()}
        self.fold_periods = {e: tuple(sorted(fold_periods(t))) for e, t in self.targets.items()}
        """Event -> the fold periods its recording's features use: the model folds no other."""
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
                                  self.noise_g, self.fold_periods.get(ev.id), start)
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
            hit = self.cache.get(key, parse=_cached_simulation)
            if hit is not None:
                return None if hit is _FAILED_RUN else replace(hit, event_id=eid)
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
                                fold_periods=self.fold_periods.get(eid))
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
