"""One event, modelled and recorded: the run, its measurement through the sensors, the
recording's features.

:func:`run_event` runs the model at an event (continued while its window drifts; a periodic
run hands over its orbit); :func:`measure_event` measures a run through each sensor's chain and
at full resolution; :func:`recorded_features` measures a recording the same way.
:class:`EventSimulation` is what the comparison engine keeps of a measured run.
"""

from __future__ import annotations

import contextlib
import functools
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vadsim._checks import number
from vadsim.campaigns.format import CAMPAIGN_FILE, Campaign, Event, excerpt
from vadsim.model.change import Measurement
from vadsim.model.defaults import DEFAULTS
from vadsim.model.result import G, SimulationResult
from vadsim.model.settings import RunSettings
from vadsim.model.steady import steady_run
from vadsim.signals.features import Feature, summary_features
from vadsim.signals.fold_features import (
    noise_floor_g,
    recorded_fold_features,
)
from vadsim.signals.model_folds import model_fold_features
from vadsim.signals.sensor import SIMULATION_OVERSAMPLING, FilteredSignal, sample_count
from vadsim.signals.window_features import event_features, phase_features

__all__ = ["FAILED_RESIDUAL", "FAILED_RUN", "FOLDED", "ORBIT_OVERSAMPLING", "WARM_SETTLE_CYCLES",
           "EventSimulation", "WarmStart", "cached_simulation", "fine_rate_hz", "fine_series",
           "measure_event", "recorded_features", "recorded_noise_g", "run_event",
           "sensor_groups", "simulate_event", "summary_event", "use_folded"]


FAILED_RESIDUAL = 10.0
"""Standardised residual of every compared feature of an event whose run fails, or of a
feature the run lost: large enough that a fit moves away, bounded so one failure does not
swamp a campaign."""

FOLDED: bool = True
"""Default of every ``folded`` argument (None means this): compare folded (or distribution)
features of recorded time series besides the 200 ms window features. Set False for the
comparison of before folding existed; campaigns of summary features only are unaffected."""


def use_folded(folded: bool | None) -> bool:
    return FOLDED if folded is None else bool(folded)


WARM_SETTLE_CYCLES = 30
"""Cycles a warm-started run settles before its analysed window. A warm start sits on the
base model's attractor; a change moves it a little, and its transient dies within a few tens
of cycles (a periodic one is then confirmed and the run stops). A run whose window still
drifts is continued as any other (:func:`vadsim.model.steady.steady_run`)."""

ORBIT_OVERSAMPLING = 8
"""The orbit a periodic run hands over is tabulated at this many times the fine grid's rate,
with its corners (where a contact closes or opens) given exactly: the window rebuilt from it
by linear interpolation (:func:`fine_series`) differs from the core's own samples by at most
0.7 % of the signal's range, and the peaks not at all, measured over x1 and x5 at 7in-cde
200, 300 and 650 gal/min and 7in-rc 200 gal/min (the same at 4x and 64x: what is left is the
orbit's own repeat tolerance, not the table). An impact's acceleration peaks in a corner (a
Kelvin-Voigt force jumps there): a uniform table alone missed it by up to 1.6 % of the range
at 4x and 0.1 % at 64x, and 64x cost about 5 ms more per run."""


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


FAILED_RUN: Any = object()
"""What :func:`cached_simulation` gives for a cached failed run (None is the cache's miss)."""


def cached_simulation(value: Any) -> Any:
    """A cache entry's schema: an :class:`EventSimulation`, or :data:`FAILED_RUN`."""
    sim = EventSimulation.from_json_entry(value)
    return FAILED_RUN if sim is None else sim


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
    return t, r.orbit.at_bodies(t, dofs)


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
    """Each feature's mean over the sampling phases (value, spread and n summed), and the
    standard deviation of its values across them."""
    keys = list(per_phase[0])
    if any(f.keys() != per_phase[0].keys() for f in per_phase[1:]):
        return _phase_average_by_key(per_phase)
    # All phases hold the same keys (the rule): one reduction per row gives the same bits
    # as one per key.
    values = np.array([[f[k].value for f in per_phase] for k in keys])
    spreads = np.array([[f[k].spread for f in per_phase] for k in keys]).mean(axis=1)
    means = values.mean(axis=1)
    sds = values.std(axis=1) if len(per_phase) > 1 else np.zeros(len(keys))
    out = {k: Feature(float(means[i]), float(spreads[i]),
                      int(sum(f[k].n for f in per_phase)))
           for i, k in enumerate(keys)}
    return out, {k: float(sds[i]) for i, k in enumerate(keys)}


def _phase_average_by_key(per_phase: list[dict[str, Feature]]
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
                  noise_g: Mapping[str, float] | None = None,
                  quantiles: bool = True) -> dict[str, Feature]:
    """Folded and distribution features of one rate group's fine-grid signals, through each
    sensor's analog chain (its low-pass, done in ``filtered``, and range), folded at the run's
    exact frequency (every period, or ``periods``); the quantiles (unless not
    ``quantiles``) with each sensor's ``noise_g``, as a recording's hold it."""
    analog = {name: f.analog(campaign.sensors[name].range_g)[0]
              for name, f in filtered.items()}
    noise = {name: float((noise_g or {}).get(name, 0.0)) for name in filtered}
    rails = {name: campaign.sensors[name].range_g for name in filtered}
    if periods is None:
        return model_fold_features(t, analog, f_exc_hz, noise_g=noise, range_g=rails,
                                   quantiles=quantiles)
    return model_fold_features(t, analog, f_exc_hz, periods=periods, noise_g=noise,
                               range_g=rails, quantiles=quantiles)


def _phase_noise(campaign: Campaign, t: np.ndarray, phases: int,
                 noise: Mapping[str, float], seed: int | None
                 ) -> dict[str, list[np.ndarray | None]]:
    """Each sensor's noise at each sampling phase over the fine grid ``t``, drawn from
    ``seed`` rate group by rate group, phase by phase and sensor by sensor, as the measurement
    always drew them (a sensor without noise draws nothing).

    The same seed and sample counts give the same draws: a diagnosis measures every run of an
    event with one seed, so they are drawn once per event (read-only, shared)."""
    sigmas = {name: number(f"noise_g[{name!r}]", noise.get(name, 0.0))
              for name in campaign.sensors}
    for name, sigma in sigmas.items():
        if not math.isfinite(sigma) or sigma < 0.0:
            raise ValueError(f"noise_g[{name!r}] must be a finite number >= 0, got {sigma!r}")
    plan: list[tuple[str, float, int]] = []
    for names in sensor_groups(campaign).values():
        for k in range(phases):
            for name in names:
                size = (sample_count(t, campaign.sensors[name].rate_hz, k / phases)
                        if sigmas[name] > 0.0 else 0)
                plan.append((name, sigmas[name], size))
    if isinstance(seed, int) and not isinstance(seed, bool):
        return _drawn_noise(seed, tuple(plan))
    return _draw_noise(seed, plan)


def _draw_noise(seed: int | None, plan: Iterable[tuple[str, float, int]]
                ) -> dict[str, list[np.ndarray | None]]:
    rng = np.random.default_rng(seed)
    draws: dict[str, list[np.ndarray | None]] = {}
    for name, sigma, size in plan:
        draw = rng.normal(0.0, sigma, size=size) if sigma > 0.0 else None
        if draw is not None:
            draw.flags.writeable = False
        draws.setdefault(name, []).append(draw)
    return draws


@functools.lru_cache(maxsize=32)
def _drawn_noise(seed: int, plan: tuple[tuple[str, float, int], ...]
                 ) -> dict[str, list[np.ndarray | None]]:
    return _draw_noise(seed, plan)


def measure_event(
    campaign: Campaign,
    event: Event,
    r: SimulationResult,
    *,
    phases: int = DEFAULTS.phases,
    noise_g: float | Mapping[str, float] = 0.0,
    seed: int | None = None,
    keep_signals: bool = False,
    measurement: Measurement | None = None,
    folded: bool | None = None,
    full_features: bool = True,
    fold_periods: Iterable[int] | None = None,
    quantiles: bool = True,
) -> EventSimulation:
    """Features of a run through each sensor's chain and at full resolution.

    Why so many parameters: a measurement is the event's recording conditions (sensors, rate,
    range, low-pass, noise, phases) applied to one run; the comparison engine passes each from
    the campaign.

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
    distribution feature a recording may have (:func:`vadsim.signals.model_folds.
    model_fold_features`: the fine grid through each sensor's low-pass and range, folded at
    the run's exact frequency, for periods 1-4), with a ``phase_sd`` of 0: a fold has no
    sampling phase. The recording's keys select which are compared.

    ``full_features=False`` skips the full-resolution features (``full``): a comparison
    through the sensor chains does not use them, and they cost a third of the measurement.
    ``fold_periods`` folds only those periods (default: 1-4): a comparison with a recording
    needs only the period the recording folded at (:func:`vadsim.signals.fold_features.
    fold_periods` of its keys), and the folds are half of a measurement's cost.
    ``quantiles=False`` skips the distribution features likewise (a recording that folded
    has none: :func:`vadsim.signals.fold_features.has_quantiles`).

    ``noise_g`` (one value, or one per sensor name) adds each sensor's Gaussian noise to the
    sampled series, drawn from ``seed``: a recording's window features (peaks, quantiles,
    impacts) carry its noise, e.g. a 200 ms peak of a 1 g-noise record is the peak of signal
    plus noise (:func:`recorded_noise_g`). Folds are taken without it (a fold averages noise
    out), the quantiles of ``|a|`` with it (:func:`vadsim.signals.model_folds.
    noisy_quantiles`).
    """
    if not (isinstance(phases, int) and phases >= 1):
        raise ValueError(f"phases = {phases!r} must be an integer >= 1")
    noise = (dict(noise_g) if isinstance(noise_g, Mapping)
             else dict.fromkeys(campaign.sensors, noise_g))
    fine = fine_rate_hz(campaign)
    sensor_feats: dict[str, Feature] = {}
    full_feats: dict[str, Feature] = {}
    phase_sd: dict[str, float] = {}
    kept: dict[str, np.ndarray] = {}
    t, a = fine_series(r, fine, {s.dof for s in campaign.sensors.values()})
    draws = _phase_noise(campaign, t, phases, noise, seed)
    for rate, names in sensor_groups(campaign).items():
        full = {name: a[campaign.sensors[name].dof] for name in names}
        if measurement is not None:
            full = {name: np.asarray(measurement(name, a, fine), dtype=float)
                    for name, a in full.items()}
        # checked and low-passed once: every phase and the fold share it
        filtered = {name: FilteredSignal(t, full[name], campaign.sensors[name].lowpass_hz)
                    for name in names}
        # each sensor's samples at every phase, reduced together (phase_features)
        sampled: dict[str, list[np.ndarray]] = {}
        clipped: dict[str, list[np.ndarray]] = {}
        for name in names:
            s = campaign.sensors[name]
            got = filtered[name].sample_phases(s.rate_hz, s.range_g,
                                               [k / phases for k in range(phases)],
                                               draws[name])
            sampled[name] = [a_s for a_s, _ in got]
            clipped[name] = [clip for _, clip in got]
            if keep_signals:
                kept[name] = sampled[name][0]
        averaged, sd = _phase_average(phase_features(sampled, rate, r.f_exc_hz, clipped))
        sensor_feats.update(averaged)
        phase_sd.update(sd)
        if use_folded(folded):
            fx = _model_folded(campaign, t, r.f_exc_hz, filtered, fold_periods, noise,
                               quantiles)
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
                   phases: int = DEFAULTS.phases, noise_g: float | Mapping[str, float] = 0.0,
                   seed: int | None = None,
                   keep_signals: bool = False, measurement: Measurement | None = None,
                   folded: bool | None = None) -> EventSimulation:
    """:func:`run_event` then :func:`measure_event`.

    Why so many parameters: one event's run is the run settings plus the event's operating point
    and what the measurement needs stored; the comparison engine passes each.
    """
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
        if use_folded(folded):
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
