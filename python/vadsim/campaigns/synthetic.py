"""Synthetic campaigns: recordings written by the model itself.

Why this module exists: a calibration or a diagnosis is only trustworthy if it recovers what
was put in. This module simulates a campaign's events (optionally with extra physics or
changed parameters), passes each sensor's acceleration through its chain (low-pass, sampling
at a random phase, noise, clipping) and returns a :class:`~vadsim.campaigns.Campaign` in the
RECORDINGS.md format, ready to save with :func:`~vadsim.campaigns.save_campaign`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from vadsim.campaigns import Campaign, Event, Sensor
from vadsim.model.change import ModelChange
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import Preset, get_preset
from vadsim.model.result import G, SimulationResult
from vadsim.model.settings import RunSettings
from vadsim.model.steady import steady_run
from vadsim.signals.sensor import SIMULATION_OVERSAMPLING, sensor_chain

__all__ = ["DEFAULT_SENSORS", "record_run", "synthetic_campaign"]

DEFAULT_SENSORS: dict[str, Sensor] = {
    "x1": Sensor("x1", 1, 1024.0, 250.0),
    "x5": Sensor("x5", 5, 1024.0, 250.0),
}
"""The field campaigns' sensors: bit sub (dof 1) and above the motor (dof 5), 1024 Hz, 250 g."""



def synthetic_campaign(
    preset: str | Preset = "7in-cde",
    flows: Sequence[float] = (200.0, 300.0, 400.0, 500.0, 600.0),
    *,
    overrides: Mapping[str, float] | None = None,
    extras: Sequence[Any] = (),
    law: str | None = None,
    measurement: Callable[[str, np.ndarray, float], np.ndarray] | None = None,
    change: ModelChange | None = None,
    wob_klbf: float | Sequence[float] | None = None,
    sensors: Mapping[str, Sensor] | None = None,
    duration_s: float | None = None,
    cycles: float = DEFAULTS.cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    noise_g: float = 0.3,
    seed: int = 0,
    name: str = "synthetic campaign",
) -> Campaign:
    """Simulate one event per flow and record it as a campaign.

    Why so many parameters: a synthetic campaign is a model run (preset, overrides, change, WOB)
    through a sensor chain (rate, range, low-pass, noise, phase) at given flows; each is one of
    those, keyword-only with defaults.

    Parameters
    ----------
    preset
        The model that writes the recordings.
    flows
        One event per flow rate (gal/min).
    overrides, extras, law
        Changes to the model (the "truth" a calibration or diagnosis should recover).
    measurement
        What happens to each sensor's true acceleration before its chain,
        ``measurement(sensor_name, a_g, fine_rate_hz) -> a_g`` (see
        :data:`vadsim.fit.validate.Measurement`); e.g. a mount resonance.
    change
        A :class:`~vadsim.model.change.ModelChange` applied on top, at each event's flow
        (scales, flow powers, theta0, extras, measurement): how a concealed truth is written
        with exactly the change a diagnosis fits.
    wob_klbf
        One WOB for all events or one per event (default: the preset's).
    sensors
        Default :data:`DEFAULT_SENSORS`.
    duration_s
        Recording length per event; the run then analyses ``ceil(duration * f)`` cycles
        after ``cycles - analyse_cycles`` settling cycles. Default: the analysed window.
    noise_g
        Standard deviation of the sensor's Gaussian noise (g).
    seed
        Seeds the sampling phase and the noise of every event (reproducible campaigns).
    """
    p = get_preset(preset) if isinstance(preset, str) else preset
    sensors = dict(sensors or DEFAULT_SENSORS)
    if not flows:
        raise ValueError("flows is empty")
    if wob_klbf is None:
        wobs = [p.wob_klbf] * len(flows)
    elif np.isscalar(wob_klbf):
        wobs = [float(wob_klbf)] * len(flows)  # type: ignore[arg-type]
    else:
        wobs = [float(w) for w in wob_klbf]  # type: ignore[union-attr]
    if len(wobs) != len(flows):
        raise ValueError(f"wob_klbf has {len(wobs)} values for {len(flows)} flows")
    rng = np.random.default_rng(seed)
    settle = cycles - analyse_cycles
    fine = SIMULATION_OVERSAMPLING * max(s.rate_hz for s in sensors.values())
    base = RunSettings(p, overrides=overrides or {}, extras=tuple(extras), law=law)
    if change is not None and change.measurement is not None:
        measurement = (change.measurement if measurement is None else
                       ModelChange(measurement=measurement).combine(
                           ModelChange(measurement=change.measurement)).measurement)
    events: list[Event] = []
    for i, (q, wob) in enumerate(zip(flows, wobs, strict=True)):
        n_an = math.ceil(duration_s * base.f_exc_hz(q)) if duration_s else analyse_cycles
        run = change.apply(base, q) if change is not None else base
        r = steady_run(run.with_changes(cycles=settle + n_an, analyse_cycles=n_an),
                       q, wob_klbf=wob, record="window", output_rate_hz=fine)
        events.append(record_run(r, sensors, event_id=f"e{i + 1:02d}", flow_gpm=float(q),
                                 wob_klbf=float(wob), phase=float(rng.uniform(0.0, 1.0)),
                                 noise_g=noise_g, rng=rng, duration_s=duration_s,
                                 measurement=measurement, fine_rate_hz=fine))
    return Campaign(name=name, tool=p.tool, bit=p.bit, wob_klbf=float(wobs[0]),
                    sensors=sensors, events=events,
                    description=f"written by vadsim from preset {p.name}")


def record_run(r: SimulationResult, sensors: Mapping[str, Sensor], *, event_id: str,
               flow_gpm: float, wob_klbf: float, phase: float,
               noise_g: float | Mapping[str, float], rng: np.random.Generator,
               duration_s: float | None = None,
               measurement: Callable[[str, np.ndarray, float], np.ndarray] | None = None,
               fine_rate_hz: float | None = None) -> Event:
    """One event recorded from a run on a fine grid: each sensor's chain at sampling
    ``phase`` (fraction of a sample) with Gaussian noise (``noise_g``: one value in g RMS,
    or one per sensor name, 0 for a sensor not named), cut to ``duration_s``.

    Why so many parameters: a recording is a run through a sensor chain, each of whose settings
    (rate, range, low-pass, noise, phase, seed) a campaign states.

    What a campaign's recording of that run would be; also how a calibration draws the
    recordings its parametric bootstrap needs. ``fine_rate_hz`` is the run's output rate
    (what ``measurement`` is told; default from the time step).
    """
    fine = (fine_rate_hz if fine_rate_hz is not None
            else 1.0 / float(r.t[1] - r.t[0]) if r.t.size > 1 else math.nan)
    columns: dict[str, np.ndarray] = {}
    clipped: dict[str, np.ndarray] = {}
    t_s = None
    for sname, s in sensors.items():
        a_true = r.a[:, s.dof - 1] / G
        if measurement is not None:
            a_true = np.asarray(measurement(sname, a_true, fine), dtype=float)
        t_s, a_s, clip = sensor_chain(r.t, a_true, rate_hz=s.rate_hz, range_g=s.range_g,
                                      lowpass_hz=s.lowpass_hz, phase=phase,
                                      noise_g=(float(noise_g.get(sname, 0.0))
                                               if isinstance(noise_g, Mapping) else noise_g),
                                      rng=rng)
        columns[f"{sname}_g"] = a_s
        clipped[sname] = clip
    n = min(len(c) for c in columns.values())
    if duration_s:
        n = min(n, int(round(duration_s * max(s.rate_hz for s in sensors.values()))))
    if t_s is None:
        raise ValueError("sensors is empty")
    data = pd.DataFrame({"time_s": np.round(t_s[:n] - t_s[0], 7),
                         **{k: v[:n] for k, v in columns.items()}})
    return Event(id=event_id, flow_gpm=float(flow_gpm), wob_klbf=float(wob_klbf),
                 file=f"{event_id}.csv", data=data,
                 clipped={k: v[:n] for k, v in clipped.items()})
