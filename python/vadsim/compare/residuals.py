"""Standardised residuals: the one definition of how far the model is from a recording.

:func:`standardised_residual` is ``(model - recorded) / spread``; :func:`event_residuals` takes
it over an event's compared features, :func:`residual_table` over a campaign's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from vadsim.compare.events import EventSimulation
from vadsim.signals.features import Feature
from vadsim.signals.model_folds import ALT_MARK

__all__ = ["event_residuals", "residual_table", "standardised_residual"]


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
    ``<key>@cycle<c>``, :mod:`vadsim.signals.model_folds`, "Alternative alignments"), take for
    each period the one whose residuals over every sensor's features of that fold are
    smallest."""
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
