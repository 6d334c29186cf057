"""A change to the base model: what a candidate physics, a nuisance constant or a concealed
truth does to a run and to its measurement.

Why this module exists: a diagnosis combines changes -- a fitted WOB factor and excitation
phase (nuisance constants), one or several candidate physics, a sensor resonance -- and a
synthetic campaign writes recordings with the same changes. One plain description, which
combines with another and applies to a :class:`~vadsim.model.settings.RunSettings` at an
event's flow, keeps them consistent: the model that writes a campaign and the model that fits
it differ only in the values.

A change holds

* ``extras`` and ``law``: extra forces and the impact surfaces' contact law;
* ``overrides``: parameters set to a value;
* ``scales``: parameters multiplied by a factor (``mass:anvil`` x 1.2, ``wob`` x 0.9);
* ``flow_powers``: parameters multiplied by ``(Q / flow_ref_gpm)^p`` at each event's flow
  (an excitation amplitude that grows with flow);
* ``flow_slopes``: added to parameters as ``s (Q / flow_ref_gpm - 1)`` at each event's flow
  (a phase that drifts with flow: a slope on ``theta0`` adds to the phase at rest); applied
  after ``theta0``;
* ``theta0``: the excitation phase at rest (rad), which MODEL.md shows the published lengths
  cannot fix: the core parameter ``theta0``, held whatever the other changes do to the rest
  state;
* ``measurement``: what happens to a sensor's true acceleration before its recorded chain.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vadsim.model import presets as _presets
from vadsim.model.settings import ExtraSpec, RunSettings

__all__ = ["FLOW_REF_GPM", "Measurement", "ModelChange", "rest_phase"]

FLOW_REF_GPM = 400.0
"""Reference flow of flow powers: ``x (Q / 400)^p`` leaves the parameter unchanged at
400 gal/min, mid-range of the field campaigns, so factor and exponent are nearly
uncorrelated in a fit."""

Measurement = Callable[[str, np.ndarray, float], np.ndarray]
"""``measurement(sensor_name, a_g, fine_rate_hz) -> a_g`` on the solver's fine grid."""


def rest_phase(settings: RunSettings) -> float:
    """The excitation phase at rest ``theta0`` of these settings, mod pi (rad): the preset's
    (or an override's) ``theta0``, or ``beta (x2 - x3)_rest + psi`` when it is unset."""
    return float(_presets.rest_phase(settings.params()) % math.pi)


def _compose(first: Measurement | None, second: Measurement | None) -> Measurement | None:
    if first is None or second is None:
        return first or second

    def both(name: str, a: np.ndarray, fs: float) -> np.ndarray:
        return second(name, first(name, a, fs), fs)

    return both


@dataclass
class ModelChange:
    """A change to the base model: to the run and to the measurement. The empty change is the
    base model itself."""

    extras: list[ExtraSpec | Any] = field(default_factory=list)
    law: str | None = None
    overrides: dict[str, float] = field(default_factory=dict)
    scales: dict[str, float] = field(default_factory=dict)
    flow_powers: dict[str, float] = field(default_factory=dict)
    flow_slopes: dict[str, float] = field(default_factory=dict)
    theta0: float | None = None
    measurement: Measurement | None = None
    flow_ref_gpm: float = FLOW_REF_GPM

    @property
    def changes_run(self) -> bool:
        """Whether the model must run again (else the base runs are re-measured)."""
        return bool(self.extras or self.law or self.overrides or self.theta0 is not None
                    or any(v != 1.0 for v in self.scales.values())
                    or any(v != 0.0 for v in self.flow_powers.values())
                    or any(v != 0.0 for v in self.flow_slopes.values()))

    def run_key(self) -> tuple[Any, ...]:
        """A hashable description of the run side alone: two changes with equal keys run the
        same model and differ at most in their measurement (whose runs can be shared)."""
        def nonzero(d: Mapping[str, float], neutral: float) -> tuple[tuple[str, float], ...]:
            return tuple(sorted((k, v) for k, v in d.items() if v != neutral))

        return (tuple(e if isinstance(e, ExtraSpec) else id(e) for e in self.extras), self.law,
                tuple(sorted(self.overrides.items())), nonzero(self.scales, 1.0),
                nonzero(self.flow_powers, 0.0), nonzero(self.flow_slopes, 0.0), self.theta0,
                self.flow_ref_gpm)

    def combine(self, other: ModelChange | None) -> ModelChange:
        """Both changes at once: extras appended, overrides merged, scales multiplied, flow
        powers added, measurements applied in turn. Two contact laws, two values of one
        override or two ``theta0`` conflict (ValueError)."""
        if other is None:
            return self
        if self.law and other.law and self.law != other.law:
            raise ValueError(f"changes conflict: contact law {self.law!r} and {other.law!r}")
        same = {k for k in set(self.overrides) & set(other.overrides)
                if self.overrides[k] != other.overrides[k]}
        if same:
            raise ValueError(f"changes conflict: both override {', '.join(sorted(same))}")
        if self.theta0 is not None and other.theta0 is not None:
            raise ValueError("changes conflict: both set the excitation phase at rest theta0")
        if ((self.flow_powers or self.flow_slopes) and (other.flow_powers or other.flow_slopes)
                and self.flow_ref_gpm != other.flow_ref_gpm):
            raise ValueError("changes conflict: flow powers with different reference flows")
        scales = dict(self.scales)
        for k, v in other.scales.items():
            scales[k] = scales.get(k, 1.0) * v
        powers = dict(self.flow_powers)
        for k, v in other.flow_powers.items():
            powers[k] = powers.get(k, 0.0) + v
        slopes = dict(self.flow_slopes)
        for k, v in other.flow_slopes.items():
            slopes[k] = slopes.get(k, 0.0) + v
        return ModelChange(
            extras=[*self.extras, *other.extras], law=self.law or other.law,
            overrides={**self.overrides, **other.overrides}, scales=scales, flow_powers=powers,
            flow_slopes=slopes, theta0=self.theta0 if self.theta0 is not None else other.theta0,
            measurement=_compose(self.measurement, other.measurement),
            flow_ref_gpm=(self.flow_ref_gpm if self.flow_powers or self.flow_slopes
                          else other.flow_ref_gpm))

    def apply(self, settings: RunSettings, flow_gpm: float | None = None) -> RunSettings:
        """The run settings with this change, at ``flow_gpm`` (needed by flow powers)."""
        if not self.changes_run:
            return settings
        out = settings
        changes: dict[str, Any] = {"overrides": dict(self.overrides), "extras": tuple(self.extras)}
        if self.law is not None:
            changes["law"] = self.law
        out = out.with_changes(**changes)
        values = {k: out.param(k) * v for k, v in self.scales.items() if v != 1.0}
        per_flow = (any(v != 0.0 for v in self.flow_powers.values())
                    or any(v != 0.0 for v in self.flow_slopes.values()))
        if per_flow and (flow_gpm is None or not flow_gpm > 0):
            raise ValueError(f"a change with flow powers or slopes needs the event's flow, "
                             f"got {flow_gpm!r}")
        if per_flow:
            assert flow_gpm is not None
            for k, p in self.flow_powers.items():
                values[k] = values.get(k, out.param(k)) * (flow_gpm / self.flow_ref_gpm) ** p
        if values:
            out = out.with_changes(overrides=values)
        if self.theta0 is not None:
            out = out.with_changes(overrides={"theta0": float(self.theta0)})
        if per_flow and self.flow_slopes:
            assert flow_gpm is not None
            x = flow_gpm / self.flow_ref_gpm - 1.0
            out = out.with_changes(overrides={k: _current(out, k) + v * x
                                              for k, v in self.flow_slopes.items() if v})
        return out

    def describe(self) -> dict[str, Any]:
        """JSON-ready description (what a report prints of a change)."""
        out: dict[str, Any] = {}
        if self.extras:
            out["extras"] = [e.as_dict() if isinstance(e, ExtraSpec) else str(e)
                             for e in self.extras]
        for name in ("law", "theta0"):
            if getattr(self, name) is not None:
                out[name] = getattr(self, name)
        for name in ("overrides", "scales", "flow_powers", "flow_slopes"):
            if getattr(self, name):
                out[name] = dict(getattr(self, name))
        if self.measurement is not None:
            out["measurement"] = True
        return out


def _current(settings: RunSettings, name: str) -> float:
    """A parameter's value, with an unset phase at rest read as the one ``psi`` gives (a
    slope on it must move the phase, not nan)."""
    value = settings.param(name)
    if name == "theta0" and math.isnan(value):
        value = _presets.rest_phase(settings.params())
    return value


def change_from(mapping: Mapping[str, Any] | None) -> ModelChange:
    """A change from keyword fields (``{"scales": {...}, "theta0": 2.3}``); None: no change."""
    return ModelChange(**dict(mapping or {}))
