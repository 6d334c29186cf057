"""The independent generator's sensor chain and campaign writer.

Why this module exists: a campaign written by the simulator the diagnosis fits, through the
chain the diagnosis applies, shares every convention with it, down to how a sample is taken.
This chain is built apart from :mod:`vadsim.signals`:

1. the simulator's output grid is laid on the sampling instants themselves: 16 points per
   1024 Hz sample, starting at a random sampling phase, so a recorded sample is a solver
   point (no interpolation between grid points);
2. the anti-alias filter is the *analog* 4th-order Butterworth low-pass at the stated corner
   (``lowpass_hz`` in campaign.toml), its state-space form discretised exactly for a signal
   linear between grid points (first-order hold), started at rest on the first value;
3. every 16th filtered point is the record; Gaussian noise is added, then the sensor clips at
   +-``range_g``.

The records start after a settle (at least ``settle_cycles`` excitation cycles from the static
state, more while the motion still drifts, as a driller waits for steady operation) and the
campaign folder (campaign.toml and one CSV per event) is written here in the RECORDINGS.md
format, read back by :func:`vadsim.campaigns.load_campaign` in the tests.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.signal import butter, cont2discrete, lfilter, lfilter_zi, ss2tf, zpk2ss

from vadsim.blind.independent.effects import build_effect
from vadsim.blind.independent.model import (
    PRESETS,
    G,
    IndependentModel,
    preset_params,
    settle,
)

__all__ = ["OVERSAMPLING", "SENSORS", "IndependentSpec", "analog_lowpass", "record_event",
           "write_campaign"]

OVERSAMPLING = 16
"""Solver points per recorded sample (16 kHz for 1024 Hz): the filter's grid."""

SENSORS: dict[str, int] = {"x1": 1, "x5": 5}
"""The field campaigns' accelerometers (RECORDINGS.md): bit sub (dof 1), above the motor
(dof 5)."""

PREROLL_S = 0.25
"""Seconds of filter run-in after the settle, before the first recorded sample."""


@dataclass(frozen=True)
class IndependentSpec:
    """What the independent generator writes: one campaign.

    Attributes
    ----------
    preset
        ``"7in-cde"`` or ``"7in-rc"`` (:data:`~vadsim.blind.independent.model.PRESETS`).
    flows
        One event per flow (gal/min).
    effects
        ``(effect name, values)`` pairs (:data:`~vadsim.blind.independent.effects.EFFECTS`).
    wob_scale
        True WOB over the stated one (the campaign states the preset's WOB).
    noise_g, duration_s
        Sensor noise (g) and seconds per event.
    rate_hz, range_g, lowpass_hz
        The sensors' rate, range and anti-alias corner (stated in campaign.toml).
    settle_cycles
        Excitation cycles from the static state before the record starts.
    """

    preset: str = "7in-cde"
    flows: tuple[float, ...] = (200.0, 400.0, 600.0)
    effects: tuple[tuple[str, Mapping[str, float]], ...] = ()
    wob_scale: float = 1.0
    noise_g: float = 0.3
    duration_s: float = 8.0
    rate_hz: float = 1024.0
    range_g: float = 250.0
    lowpass_hz: float = 400.0
    settle_cycles: float = 100.0


def analog_lowpass(a: np.ndarray, step_s: float, corner_hz: float) -> np.ndarray:
    """The analog 4th-order Butterworth low-pass at ``corner_hz`` applied to ``a`` sampled
    every ``step_s``: its state-space form discretised exactly for an input linear between
    samples (first-order hold), run from the steady state of a constant ``a[0]``.

    Why the analog filter: a sensor's anti-alias filter is an analog circuit in front of the
    converter; discretising it exactly on a fine grid is one honest model of it, and another
    than a bilinear digital design.
    """
    A, B, C, D = zpk2ss(*butter(4, 2.0 * math.pi * corner_hz, analog=True, output="zpk"))
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), step_s, method="foh")
    b, den = ss2tf(Ad, Bd, Cd, Dd)
    b = np.asarray(b).ravel()
    out, _ = lfilter(b, den, a, zi=lfilter_zi(b, den) * a[0])
    return np.asarray(out)


def record_event(spec: IndependentSpec, flow_gpm: float, rng: np.random.Generator
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """One event: the record's times (from 0) and each sensor's samples in g.

    The run starts from the static state at t = 0; the record starts once it is steady
    (:func:`~vadsim.blind.independent.model.settle`: at least ``spec.settle_cycles``
    cycles) at a sampling phase drawn from ``rng`` (uniform over one sample), which then
    draws the noise.
    """
    params = preset_params(spec.preset)
    effects = [build_effect(n, v, params) for n, v in spec.effects]
    model = IndependentModel(params, flow_gpm, effects, wob_scale=spec.wob_scale)
    n = int(round(spec.duration_s * spec.rate_hz))
    step = 1.0 / (spec.rate_hz * OVERSAMPLING)
    phase = float(rng.uniform(0.0, 1.0))
    t_settled, y_settled, _ = settle(model, spec.settle_cycles)
    n_pre = int(round(PREROLL_S / step))
    t_rec0 = t_settled + (n_pre + 1) * step + phase / spec.rate_hz
    t = t_rec0 + (np.arange(-n_pre, n * OVERSAMPLING) * step)
    y = model.integrate(np.r_[t_settled, t], y_settled)[1:]
    acc = model.accelerations(t, y) / G
    out: dict[str, np.ndarray] = {}
    for name, dof in SENSORS.items():
        filt = analog_lowpass(acc[:, dof - 1], step, spec.lowpass_hz)
        rec = filt[n_pre::OVERSAMPLING][:n]
        rec = rec + rng.normal(0.0, spec.noise_g, rec.size) if spec.noise_g > 0 else rec
        out[name] = np.clip(rec, -spec.range_g, spec.range_g)
    return np.arange(n) / spec.rate_hz, out


def _toml(spec: IndependentSpec, name: str, files: Sequence[tuple[str, float]]) -> str:
    pr = PRESETS[spec.preset]
    # a neutral header: nothing in a blind campaign's files names its generator
    lines = ["# Field-test campaign, format of RECORDINGS.md.", f"name = {json.dumps(name)}",
             f'tool = "{pr.tool}"', f'bit = "{pr.bit}"', f"wob_klbf = {pr.wob_klbf!r}",
             'description = "blind benchmark campaign"', ""]
    for sname, dof in SENSORS.items():
        lines += [f"[sensors.{sname}]", f"dof = {dof}", f"rate_hz = {spec.rate_hz!r}",
                  f"range_g = {spec.range_g!r}", f"lowpass_hz = {spec.lowpass_hz!r}", ""]
    for eid, q in files:
        lines += ["[[events]]", f'id = "{eid}"', f"flow_gpm = {float(q)!r}",
                  f'file = "{eid}.csv"', ""]
    return "\n".join(lines)


def write_campaign(folder: str | Path, spec: IndependentSpec, *, seed: int,
                   name: str = "independent campaign") -> Path:
    """Simulate every event of ``spec`` and write the campaign folder (RECORDINGS.md).

    Deterministic from ``seed`` (sampling phases and noise). Returns the folder.
    """
    if spec.preset not in PRESETS:
        preset_params(spec.preset)  # the error that lists the presets
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    events = []
    for i, q in enumerate(spec.flows):
        eid = f"e{i + 1:02d}"
        t, rec = record_event(spec, q, rng)
        cols = np.column_stack([t, *(rec[s] for s in SENSORS)])
        header = ",".join(["time_s", *(f"{s}_g" for s in SENSORS)])
        np.savetxt(root / f"{eid}.csv", cols, fmt=["%.9f"] + ["%.4f"] * len(SENSORS),
                   delimiter=",", header=header, comments="")
        events.append((eid, q))
    (root / "campaign.toml").write_text(_toml(spec, name, events))
    return root
