"""Candidate physics: extensions of the dissertation's model that a diagnosis can add and fit.

Why this module exists: when recordings disagree with the model, the useful answer is not
"the model is wrong" but "this physics is missing, with this size". Each candidate here is a
physically parameterised extension with bounds, a value at which it vanishes (so that "none"
is a special case of it where possible), and a short statement of its physical signature:
where in the operating range and in which sensor it should show.

Model-side candidates act through the core's extra-force hook or contact law, so a fit runs
at the core's speed (no Python callbacks inside the integrator). Measurement-side candidates
(``axial_lateral``, ``sensor_chain``) do not feed back into the axial dynamics: they act on a
sensor's acceleration on the solver's fine grid before the recorded chain, so a fit reuses the
runs of the base model and only re-measures.

Candidates
----------
``hydraulic_force``
    ``c * Q^2`` (N/kg per (gal/min)^2) on the anvil or on the bit, towards the rock. Mud
    pressure drop across the tool grows with the square of flow: negligible at low flow,
    large at high flow, so it bends the high-flow end of every feature-vs-flow curve.
``contact_law``
    Hunt-Crossley ``k d (1 + alpha d')`` in place of Kelvin-Voigt at the four impact
    surfaces: the dissipation grows with indentation and the contact never pulls. Changes
    the impact peaks and restitution at every flow, most where impacts are hard.
``anvil_friction``
    Coulomb friction (N/kg) between anvil and housing (seals, splines). Dissipates in
    proportion to sliding distance: it damps the anvil's travel and may stop weak strokes,
    so it changes regimes and peaks where the stroke is short.
``string_radiation``
    A dashpot (N s/m per kg) from the MWD to the ground: the impedance of the drill string
    above, into which waves leave instead of reflecting at the top spring. Damps the upper
    string's modes, so it shows in the sensor above the motor more than at the bit.
``axial_lateral``
    The sensor above the motor also sees a lateral bending mode of the housing, excited by
    the axial motion (e.g. through a bent housing): measured = axial + ``gain`` x a band-pass
    response at ``f_lat_hz`` (damping ratio 0.05). Only the x5 sensor, only near the mode.
``sensor_chain``
    The accelerometers' mounting resonance: a second-order low-pass with unit static gain at
    ``f_res_hz`` and quality factor ``q`` in front of both sensors' recorded chains.
    Amplifies the impact content near the resonance (aliased into the recorded band when it
    lies above Nyquist) at both sensors alike.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal

from vadsim.compare import ModelChange
from vadsim.model.settings import ExtraSpec

__all__ = ["CANDIDATES", "Candidate", "ModelChange", "ParamSpec", "candidate", "candidate_ids"]


@dataclass(frozen=True)
class ParamSpec:
    """One fitted parameter of a candidate.

    ``scale`` is how the search spaces it ("linear" from ``lo``; "log" for parameters whose
    effect spans decades); ``null`` is the value at which the physics vanishes (None when
    no value of it gives the base model); ``grid`` is the number of grid points of the
    diagnosis' global stage along it (fine for a resonance frequency, whose cost has minima
    as narrow as the resonance).
    """

    name: str
    lo: float
    hi: float
    unit: str
    scale: str = "linear"
    null: float | None = None
    grid: int = 11

    def to_unit(self, x: float) -> float:
        """Parameter value -> position in [0, 1] of the search box."""
        if self.scale == "log":
            return (math.log(x) - math.log(self.lo)) / (math.log(self.hi) - math.log(self.lo))
        return (x - self.lo) / (self.hi - self.lo)

    def from_unit(self, u: float) -> float:
        """Position in [0, 1] of the search box -> parameter value."""
        u = min(max(float(u), 0.0), 1.0)
        if self.scale == "log":
            return float(math.exp(math.log(self.lo) + u * (math.log(self.hi) - math.log(self.lo))))
        return float(self.lo + u * (self.hi - self.lo))


@dataclass(frozen=True)
class Candidate:
    """One physically parameterised extension of the model.

    ``id`` is what a diagnosis reports; ``variant`` a fixed choice inside it (which body the
    hydraulic force acts on), reported among the parameters; ``side`` is ``"model"`` (runs the
    model again) or ``"measurement"`` (re-measures the base runs).
    """

    id: str
    variant: str
    params: tuple[ParamSpec, ...]
    side: str
    signature: str
    build: Callable[[Mapping[str, float]], ModelChange] = field(repr=False)
    fixed: Mapping[str, Any] = field(default_factory=dict)

    @property
    def key(self) -> str:
        """Unique name of this variant, e.g. ``"hydraulic_force[anvil]"``."""
        return f"{self.id}[{self.variant}]" if self.variant else self.id

    def check(self, values: Mapping[str, float]) -> dict[str, float]:
        """Values by name, each inside its bounds (errors name the parameter and bounds)."""
        out: dict[str, float] = {}
        for p in self.params:
            if p.name not in values:
                raise ValueError(f"{self.key}: missing parameter {p.name!r}")
            v = float(values[p.name])
            if not (math.isfinite(v) and p.lo - 1e-12 * abs(p.lo) <= v
                    <= p.hi + 1e-12 * abs(p.hi)):
                raise ValueError(f"{self.key}: {p.name} = {values[p.name]!r} outside "
                                 f"[{p.lo:g}, {p.hi:g}] {p.unit}")
            out[p.name] = v
        unknown = set(values) - {p.name for p in self.params}
        if unknown:
            raise ValueError(f"{self.key}: unknown parameter(s) {', '.join(sorted(unknown))}; "
                             f"it has {', '.join(p.name for p in self.params)}")
        return out

    def change(self, values: Mapping[str, float]) -> ModelChange:
        """The model change for these values (checked)."""
        return self.build(self.check(values))

    def public_parameters(self, values: Mapping[str, float]) -> dict[str, Any]:
        """Values plus the fixed choices (what a report prints)."""
        return {**dict(self.fixed), **{k: float(v) for k, v in values.items()}}


# --------------------------------------------------------------------------- measurement filters

def _prewarped(f_hz: float, fs: float) -> float:
    return 2.0 * fs * math.tan(math.pi * f_hz / fs)


def mount_resonance(f_res_hz: float, q: float) -> Callable[[str, np.ndarray, float], np.ndarray]:
    """A measurement that passes every sensor through ``w^2 / (s^2 + w s / q + w^2)``."""
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def apply(name: str, a: np.ndarray, fs: float) -> np.ndarray:
        if fs not in cache:
            if f_res_hz >= 0.45 * fs:
                raise ValueError(f"sensor_chain f_res_hz = {f_res_hz:g} Hz needs a fine grid "
                                 f"above {f_res_hz / 0.45:.0f} Hz; it is {fs:g} Hz")
            w = _prewarped(f_res_hz, fs)
            cache[fs] = signal.bilinear([w * w], [1.0, w / q, w * w], fs)
        b, den = cache[fs]
        return signal.lfilter(b, den, a - a[0]) + a[0]

    return apply


def lateral_coupling(sensor: str, gain: float, f_lat_hz: float, zeta: float = 0.05
                     ) -> Callable[[str, np.ndarray, float], np.ndarray]:
    """A measurement that adds ``gain`` x a unit-peak band-pass response at ``f_lat_hz`` of the
    axial acceleration to one sensor (``2 z w s / (s^2 + 2 z w s + w^2)``)."""
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def apply(name: str, a: np.ndarray, fs: float) -> np.ndarray:
        if name != sensor or gain == 0.0:
            return a
        if fs not in cache:
            w = _prewarped(f_lat_hz, fs)
            cache[fs] = signal.bilinear([2 * zeta * w, 0.0], [1.0, 2 * zeta * w, w * w], fs)
        b, den = cache[fs]
        return a + gain * signal.lfilter(b, den, a - a.mean())

    return apply


# --------------------------------------------------------------------------------- the library

def _hydraulic(acts_on: str) -> Candidate:
    return Candidate(
        id="hydraulic_force", variant=acts_on,
        params=(ParamSpec("c", 0.0, 1.2e-3, "N/kg per (gal/min)^2", "linear", 0.0),),
        side="model",
        signature=(f"c Q^2 on the {acts_on} towards the rock: grows with flow squared, so it "
                   "leaves low flows untouched and changes peaks and regimes at high flow."),
        build=lambda v: ModelChange(extras=[ExtraSpec.of("hydraulic", acts_on=acts_on, c=v["c"])]
                                    if v["c"] > 0 else []),
        fixed={"acts_on": acts_on},
    )


def _contact_law() -> Candidate:
    return Candidate(
        id="contact_law", variant="",
        params=(ParamSpec("hc_alpha", 0.05, 4.0, "s/m", "log", None),),
        side="model",
        signature=("Hunt-Crossley k d (1 + alpha d') at the four impact surfaces: "
                   "indentation-dependent dissipation, no pulling; changes impact peaks and "
                   "rebound at every flow."),
        build=lambda v: ModelChange(law="hunt_crossley", overrides={"hc_n": 1.0,
                                                                    "hc_alpha": v["hc_alpha"]}),
        fixed={"law": "hunt_crossley"},
    )


def _friction() -> Candidate:
    return Candidate(
        id="anvil_friction", variant="",
        params=(ParamSpec("force", 0.0, 400.0, "N/kg", "linear", 0.0),),
        side="model",
        signature=("Coulomb friction between anvil and housing: removes energy per unit "
                   "stroke, so it shortens or stops weak strokes (regimes, low-flow peaks)."),
        build=lambda v: ModelChange(extras=[ExtraSpec.of("friction", body="anvil",
                                                        other="housing", force=v["force"])]
                                    if v["force"] > 0 else []),
    )


def _radiation() -> Candidate:
    return Candidate(
        id="string_radiation", variant="",
        params=(ParamSpec("c", 0.0, 2.0e5, "N s/m per kg", "linear", 0.0),),
        side="model",
        signature=("A dashpot from the MWD to the ground (the string's impedance): damps the "
                   "upper string's ringing, seen above the motor more than at the bit."),
        build=lambda v: ModelChange(extras=[ExtraSpec.of("dashpot", body="mwd", k=0.0, c=v["c"])]
                                    if v["c"] > 0 else []),
    )


def _axial_lateral() -> Candidate:
    return Candidate(
        id="axial_lateral", variant="",
        params=(ParamSpec("gain", 0.0, 6.0, "-", "linear", 0.0, grid=4),
                ParamSpec("f_lat_hz", 25.0, 480.0, "Hz", "log", None, grid=40)),
        side="measurement",
        signature=("A lateral mode at f_lat seen by the sensor above the motor (x5) only: "
                   "x5 band levels and peaks change where harmonics of the excitation meet "
                   "the mode; x1 is untouched."),
        build=lambda v: ModelChange(measurement=lateral_coupling("x5", v["gain"],
                                                                  v["f_lat_hz"])),
    )


def _sensor_chain() -> Candidate:
    return Candidate(
        id="sensor_chain", variant="",
        params=(ParamSpec("f_res_hz", 150.0, 2000.0, "Hz", "log", None, grid=24),
                ParamSpec("q", 1.0, 30.0, "-", "log", None, grid=4)),
        side="measurement",
        signature=("The accelerometers' mount resonance (unit static gain, quality q): "
                   "both sensors' impact peaks and upper bands change alike."),
        build=lambda v: ModelChange(measurement=mount_resonance(v["f_res_hz"], v["q"])),
    )


CANDIDATES: dict[str, Candidate] = {c.key: c for c in (
    _hydraulic("anvil"), _hydraulic("bit"), _contact_law(), _friction(), _radiation(),
    _axial_lateral(), _sensor_chain())}
"""Every candidate variant by key (``hydraulic_force`` comes as ``[anvil]`` and ``[bit]``)."""


def candidate_ids() -> list[str]:
    """The reported candidate ids, in library order."""
    return list(dict.fromkeys(c.id for c in CANDIDATES.values()))


def candidate(key: str) -> Candidate:
    """A candidate by key (``"contact_law"``) or id with variant (``"hydraulic_force[bit]"``);
    an id with variants (``"hydraulic_force"``) is an error that lists them."""
    if key in CANDIDATES:
        return CANDIDATES[key]
    variants = [k for k, c in CANDIDATES.items() if c.id == key]
    if variants:
        raise ValueError(f"candidate {key!r} has variants: {', '.join(variants)}")
    raise ValueError(f"unknown candidate {key!r}: choose one of {', '.join(CANDIDATES)}")


def keys_for(ids: list[str] | tuple[str, ...] | None) -> list[str]:
    """Candidate keys for ids or keys (None: all); an id with variants gives all of them."""
    if ids is None:
        return list(CANDIDATES)
    out: list[str] = []
    for k in ids:
        if k in CANDIDATES:
            out.append(k)
            continue
        variants = [kk for kk, c in CANDIDATES.items() if c.id == k]
        if not variants:
            raise ValueError(f"unknown candidate {k!r}: choose from {', '.join(candidate_ids())}")
        out.extend(variants)
    return list(dict.fromkeys(out))
