"""Candidate physics: extensions of the dissertation's model that a diagnosis can add and fit.

Why this module exists: when recordings disagree with the model, the useful answer is not
"the model is wrong" but "this physics is missing, with this size". Each candidate here is a
physically parameterised *family* with bounds, a value at which it vanishes (so that "none"
is a special case of it where possible), and a short statement of its physical signature:
where in the operating range and in which sensor it should show. A field's contact law or
hydraulic force is never exactly the coded one, so each family is wide enough that a near
miss of form (an exponent, a damping shape) still lands on the right physics; and physics
outside the list is caught by generic candidates that say "a quantity of the model is not
what we think" (group ``"quantity"``), so that an unlisted cause is at least located.

Model-side candidates act through the core's extra-force hook, contact law or parameter
changes, so a fit runs at the core's speed (no Python callbacks inside the integrator).
Measurement-side candidates (``axial_lateral``, ``sensor_chain``) do not feed back into the
axial dynamics: they act on a sensor's acceleration on the solver's fine grid before the
recorded chain, so a fit reuses the runs of the base model and only re-measures.

Families of missing physics (group ``"physics"``)
-------------------------------------------------
``hydraulic_force[anvil]``, ``hydraulic_force[bit]``
    ``f_ref (Q / 400)^n`` (N/kg; ``f_ref`` the force at 400 gal/min, ``n`` in [1, 3]) on the
    anvil or the bit, towards the rock. The mud's pressure drop across the tool grows with
    flow: turbulent nozzles give n = 2, laminar or partly choked paths less, a motor whose
    differential pressure rises with flow more. Negligible at low flow, large at high flow,
    so it bends the high-flow end of every feature-vs-flow curve. Null: ``f_ref = 0``.
``contact_law``
    ``max(0, k d + factor c (d / d_c)^s d')`` at the four impact surfaces (law
    ``"power_damping"``), c each surface's own damping, d_c the preset's typical impact
    indentation ``pd_dc`` (1 mm for the 7in tool, 5 mm for the 9.5in; ``presets.py``),
    ``factor`` in [0.1, 10] (log), ``s`` in [0, 2]. s = 0 is Kelvin-Voigt without tension;
    s = 1 Hunt-Crossley's damping on a linear spring and 1.5 its Hertzian exponent: damping
    that vanishes at first touch, so the restitution falls with impact speed. The contact
    never pulls. Changes impact peaks and rebound at every flow, most where impacts are hard.
    No exact null: factor 1, s = 0 is Kelvin-Voigt *without* tension, not the dissertation's
    law, which keeps it.
``contact_law[impact]``
    The impact face alone as two curved steel faces: Hertz's spring with Hunt and Crossley's
    damping, ``max(0, stiffness kI d_c (d / d_c)^1.5 + factor cI (d / d_c)^1.5 d')`` (law
    ``"power_damping_impact"``, ``pd_spring = pd_shape = 1.5``), ``stiffness`` in [0.25, 4]
    (log; the force at d = d_c relative to the linear face's ``kI d_c``), ``factor`` in
    [0.03, 3] (log; the damping at d_c relative to ``cI``). Hunt-Crossley's alpha (s/m) is
    ``factor cI / (stiffness kI d_c)``. Softer than the linear face in light impacts and
    stiffer in hard ones, so it reshapes the impact peaks against flow; the spring, the
    shoulders and the rock keep Table 2.1's Kelvin-Voigt law. No exact null.
``anvil_friction``
    Coulomb friction ``force`` (N/kg) between anvil and housing (seals, splines). Dissipates
    in proportion to sliding distance: it damps the anvil's travel and may stop weak strokes,
    so it changes regimes and peaks where the stroke is short. Null: 0.
``anvil_friction[stribeck]``
    The same friction with a Stribeck peak, ``(force + (peak - 1) force exp(-(v / v_s)^2))
    tanh(v / v_eps)``: ``peak`` in [1, 3] the force at rest over the kinetic ``force``,
    ``v_s`` in [0.01, 0.3] m/s (log) the velocity over which it falls (seals and splines
    stick harder than they slide). Null: force 0.
``string_radiation``
    A dashpot ``c`` (N s/m per kg) from the MWD to the ground: the impedance of the drill
    string above, into which waves leave instead of reflecting at the top spring. Damps the
    upper string's modes, so it shows in the sensor above the motor more than at the bit.
``axial_lateral``
    The sensor above the motor also sees a lateral bending mode of the housing, excited by
    the axial motion (e.g. through a bent housing): measured = axial + ``gain`` x a band-pass
    response at ``f_lat_hz`` (damping ratio 0.05). Only the x5 sensor, only near the mode.
``sensor_chain[both]``, ``sensor_chain[x1]``, ``sensor_chain[x5]``
    An accelerometer's mounting resonance: a second-order low-pass with unit static gain at
    ``f_res_hz`` and quality factor ``q`` in front of the recorded chain of both sensors, or
    of one (a loose or differently mounted sensor). Amplifies the impact content near the
    resonance (aliased into the recorded band when it lies above Nyquist).

Generic "a quantity is not what we think" (group ``"quantity"``)
----------------------------------------------------------------
``excitation_amplitude``
    ``Fo x factor (Q / 400)^p``: the flow-driven force is larger or smaller than Table 2.1's
    and may grow with flow other than the model's way (a different pressure-flow law of the
    pulse valve). ``factor`` in [0.5, 2] (log) moves every flow; ``p`` in [-1.5, 1.5] tilts
    the features about 400 gal/min. Null: factor 1, p 0.
``excitation_phase``
    ``theta0 + slope (Q / 400 - 1)``: the excitation phase at rest drifts with flow (a valve
    timing that depends on flow). Its constant part is the nuisance ``theta0`` a diagnosis
    fits anyway; the slope changes nothing at 400 gal/min and most in the phase-sensitive
    regimes (300-500 gal/min for the 7in tool). Null: 0.
``contact_stiffness[spring|impact|off_bottom|on_bottom]``
    ``kS``, ``kI``, ``kOff`` or ``kOn`` x ``factor`` in [0.25, 4] (log): a surface stiffer or
    softer than Table 2.1's (wear, a different spring). Null: 1.
``rock_stiffness``
    ``kR`` x ``factor`` in [0.25, 4] (log): another formation or bit. Null: 1.
``mass[bit|anvil|housing|motor|sub|lwd|mwd]``
    ``m1`` .. ``m7`` x ``factor`` in [0.6, 1.6] (log): a body heavier or lighter than Table
    2.1's (another bit, sub or collar). Null: 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal

from vadsim.model.change import FLOW_REF_GPM, ModelChange
from vadsim.model.settings import ExtraSpec

__all__ = ["BODIES", "CANDIDATES", "HERTZ_EXPONENT", "SENSOR_SETS", "SURFACES", "Candidate",
           "ModelChange", "ParamSpec", "candidate", "candidate_ids", "keys_for", "lateral_coupling",
           "mount_resonance"]


HERTZ_EXPONENT = 1.5
"""Hertz's exponent of the force between two curved elastic faces against their
indentation (and Hunt-Crossley's damping's, which follows the spring's)."""


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
    limits: tuple[float, float] = (-math.inf, math.inf)
    """What the model accepts for it: a diagnosis that widens the range
    (:meth:`vadsim.fit.hypothesis.Hypothesis.widened`) stops there."""

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
    hydraulic force acts on), reported among the parameters as ``fixed``; ``side`` is
    ``"model"`` (runs the model again) or ``"measurement"`` (re-measures the base runs);
    ``group`` is ``"physics"`` (a named mechanism the model lacks) or ``"quantity"`` (a model
    quantity that is off: the generic candidates that catch physics outside the list, whose
    answer locates a cause rather than names it).
    """

    id: str
    variant: str
    params: tuple[ParamSpec, ...]
    side: str
    signature: str
    build: Callable[[Mapping[str, float]], ModelChange] = field(repr=False)
    fixed: Mapping[str, Any] = field(default_factory=dict)
    group: str = "physics"

    @property
    def key(self) -> str:
        """Unique name of this variant, e.g. ``"hydraulic_force[anvil]"``."""
        return f"{self.id}[{self.variant}]" if self.variant else self.id

    def check(self, values: Mapping[str, float],
              params: Sequence[ParamSpec] | None = None) -> dict[str, float]:
        """Values by name, each inside its bounds (errors name the parameter and bounds);
        ``params``: the candidate's parameters over other ranges (a diagnosis widens a range
        its fit ended at: :meth:`vadsim.fit.hypothesis.Hypothesis.widened`)."""
        out: dict[str, float] = {}
        for p in self.params if params is None else params:
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

    def change(self, values: Mapping[str, float],
               params: Sequence[ParamSpec] | None = None) -> ModelChange:
        """The model change for these values (checked, against ``params`` where given)."""
        return self.build(self.check(values, params))

    def public_parameters(self, values: Mapping[str, float]) -> dict[str, Any]:
        """Values plus the fixed choices (what a report prints)."""
        return {**dict(self.fixed), **{k: float(v) for k, v in values.items()}}


# --------------------------------------------------------------------------- measurement filters

def _prewarped(f_hz: float, fs: float) -> float:
    return 2.0 * fs * math.tan(math.pi * f_hz / fs)


def mount_resonance(f_res_hz: float, q: float, sensors: tuple[str, ...] | None = None
                    ) -> Callable[[str, np.ndarray, float], np.ndarray]:
    """A measurement that passes ``sensors`` (None: every sensor) through
    ``w^2 / (s^2 + w s / q + w^2)``; the others are returned unchanged."""
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def apply(name: str, a: np.ndarray, fs: float) -> np.ndarray:
        if sensors is not None and name not in sensors:
            return a
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

SURFACES = {"spring": "kS", "impact": "kI", "off_bottom": "kOff", "on_bottom": "kOn"}
"""Impact surfaces of ``contact_stiffness`` and the stiffness each scales."""

BODIES = {"bit": "m1", "anvil": "m2", "housing": "m3", "motor": "m4", "sub": "m5", "lwd": "m6",
          "mwd": "m7"}
"""Bodies of ``mass`` and the mass each scales (MODEL.md's dofs 1..7)."""

SENSOR_SETS: dict[str, tuple[str, ...] | None] = {"both": None, "x1": ("x1",), "x5": ("x5",)}
"""Variants of ``sensor_chain`` and the sensors each filters (None: every sensor)."""

# The signatures below were measured on the 7in CDE tool: peaks of both sensors and Z at
# 200, 300, 400, 500 and 650 gal/min for each quantity x0.5 / x2 (masses x0.77 / x1.25).
# 400 gal/min is intermittent (regime 3-4) and moves under almost any change.
_FACTOR_SIGNATURE = {
    "spring": ("The recoil spring is only touched in regimes 1-3 (up to ~450 gal/min for the "
               "7in tool): its stiffness moves the low- and middle-flow peaks of both sensors "
               "(20-30 % for x0.5 / x2) and the regime edges; nothing changes where the spring "
               "is never hit (high flow)."),
    "impact": ("The impact face is hit at every flow: its stiffness sets the impact pulse, so "
               "the peaks of both sensors change at every flow but the lowest, most at high "
               "flow and at the sensor above the motor (x5)."),
    "off_bottom": ("The off-bottom shoulder carries force only when the bit travels its full "
                   "stroke (off bottom): silent in on-bottom drilling (no change at any flow "
                   "of the 7in tool), so it is found only in off-bottom events."),
    "on_bottom": ("The on-bottom shoulder carries the weight on bit from housing to bit at "
                  "every flow: it changes the transmission to the sensor above the motor (x5, "
                  "5-15 % for x2) and, softer, the rest phase and so the middle-flow regimes."),
}

_MASS_SIGNATURE = {
    "bit": "the bit sensor's (x1) peaks, 20-30 % at every flow; x5 barely",
    "anvil": ("the stroke's momentum: peaks of both sensors and the regimes at middle and "
              "high flow (25-40 %), not at the lowest"),
    "housing": "the sensor above the motor (x5) at high flow (~10 %) and the middle-flow regimes",
    "motor": "the sensor above the motor (x5), 5-10 % at most flows; x1 barely",
    "sub": "nearly silent (< 2 % on either sensor outside the intermittent middle flows)",
    "lwd": "nearly silent outside the intermittent middle flows",
    "mwd": "the sensor above the motor (x5), ~5 % at most flows; x1 barely",
}
"""Where a heavier or lighter body shows (the same measurement)."""


_HYDRAULIC_SIGNATURE = {
    "anvil": ("f_ref (Q/400)^n on the anvil towards the rock: pushes the anvil onto the bit "
              "more as flow grows, so peaks and regimes of both sensors change most at high "
              "flow and least at low flow (how little depends on n)."),
    "bit": ("f_ref (Q/400)^n on the bit towards the rock: adds to the weight on bit, so it is "
            "weak (the 7in tool's 1000 N/kg dwarfs it) and shows mostly where the bit's "
            "seating decides the regime, the intermittent middle flows."),
}


def _hydraulic(acts_on: str) -> Candidate:
    def build(v: Mapping[str, float]) -> ModelChange:
        if v["f_ref"] == 0.0:
            return ModelChange()
        c = v["f_ref"] / FLOW_REF_GPM ** v["n"]
        return ModelChange(extras=[ExtraSpec.of("hydraulic", acts_on=acts_on, c=c, n=v["n"])])

    return Candidate(
        id="hydraulic_force", variant=acts_on,
        params=(ParamSpec("f_ref", 0.0, 200.0, "N/kg at 400 gal/min", "linear", 0.0),
                ParamSpec("n", 1.0, 3.0, "-", "linear", None, grid=5,
                          limits=(0.0, 4.0))),  # the core's range of the exponent
        side="model",
        signature=_HYDRAULIC_SIGNATURE[acts_on],
        build=build, fixed={"acts_on": acts_on},
    )


def _contact_law() -> Candidate:
    return Candidate(
        id="contact_law", variant="",
        params=(ParamSpec("factor", 0.1, 10.0, "-", "log", None, grid=7),
                ParamSpec("s", 0.0, 2.0, "-", "linear", None, grid=5)),
        side="model",
        signature=("max(0, k d + factor c (d/d_c)^s d') at the four impact surfaces: "
                   "indentation-dependent dissipation, no pulling; changes impact peaks and "
                   "rebound at every flow, both sensors, most where impacts are hard."),
        build=lambda v: ModelChange(law="power_damping", overrides={
            "pd_factor": v["factor"], "pd_shape": v["s"]}),
        fixed={"law": "power_damping"},
    )


def _contact_law_impact() -> Candidate:
    def build(v: Mapping[str, float]) -> ModelChange:
        return ModelChange(law="power_damping_impact",
                           scales={"kI": v["stiffness"]} if v["stiffness"] != 1.0 else {},
                           overrides={"pd_factor": v["factor"], "pd_shape": HERTZ_EXPONENT,
                                      "pd_spring": HERTZ_EXPONENT})

    return Candidate(
        id="contact_law", variant="impact",
        params=(ParamSpec("stiffness", 0.25, 4.0, "-", "log", None, grid=9),
                ParamSpec("factor", 0.03, 3.0, "-", "log", None, grid=5)),
        side="model",
        signature=("The impact face as Hertz's curved faces with Hunt-Crossley damping, "
                   "max(0, stiffness kI d_c (d/d_c)^1.5 + factor cI (d/d_c)^1.5 d'): softer "
                   "than the linear face below d_c and stiffer above, never pulling; changes "
                   "the impact peaks' size and width at every flow, most at high flow where "
                   "impacts are hard. The other surfaces keep Table 2.1's law."),
        build=build, fixed={"law": "power_damping_impact"},
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


def _friction_stribeck() -> Candidate:
    def build(v: Mapping[str, float]) -> ModelChange:
        if v["force"] == 0.0:
            return ModelChange()
        return ModelChange(extras=[ExtraSpec.of(
            "friction", body="anvil", other="housing", force=v["force"],
            static_force=v["force"] * v["peak"], v_s=v["v_s"])])

    return Candidate(
        id="anvil_friction", variant="stribeck",
        params=(ParamSpec("force", 0.0, 400.0, "N/kg", "linear", 0.0),
                ParamSpec("peak", 1.0, 3.0, "-", "linear", None, grid=3),
                ParamSpec("v_s", 0.01, 0.3, "m/s", "log", None, grid=3)),
        side="model",
        signature=("Friction between anvil and housing with a Stribeck peak: force x peak "
                   "at rest, falling to the kinetic force over v_s. Like Coulomb's, it "
                   "shortens or stops weak strokes; the peak holds the anvil longer at its "
                   "turning points, so it shifts the strike's timing more than its size."),
        build=build, fixed={"law": "stribeck"},
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
        build=lambda v: (ModelChange(measurement=lateral_coupling("x5", v["gain"],
                                                                   v["f_lat_hz"]))
                         if v["gain"] != 0.0 else ModelChange()),
    )


def _sensor_chain(sensors: str) -> Candidate:
    which = {"both": "both sensors' impact peaks and upper bands change alike",
             "x1": "only the bit sensor's (x1) impact peaks and upper bands change; x5 untouched",
             "x5": ("only the upper sensor's (x5) impact peaks and upper bands change; x1 "
                    "untouched")}[sensors]
    return Candidate(
        id="sensor_chain", variant=sensors,
        params=(ParamSpec("f_res_hz", 150.0, 2000.0, "Hz", "log", None, grid=24),
                ParamSpec("q", 1.0, 30.0, "-", "log", None, grid=4)),
        side="measurement",
        signature=f"An accelerometer mount resonance (unit static gain, quality q): {which}.",
        build=lambda v: ModelChange(measurement=mount_resonance(v["f_res_hz"], v["q"],
                                                                SENSOR_SETS[sensors])),
        fixed={"sensors": sensors},
    )


def _scaled(name: str, factor: float) -> ModelChange:
    """``name`` x ``factor``; the empty change at factor 1, so the null is the base run."""
    return ModelChange(scales={name: factor}) if factor != 1.0 else ModelChange()


def _excitation_amplitude() -> Candidate:
    def build(v: Mapping[str, float]) -> ModelChange:
        return ModelChange(scales={"Fo": v["factor"]} if v["factor"] != 1.0 else {},
                           flow_powers={"Fo": v["p"]} if v["p"] != 0.0 else {})

    return Candidate(
        id="excitation_amplitude", variant="",
        params=(ParamSpec("factor", 0.5, 2.0, "-", "log", 1.0, grid=7),
                ParamSpec("p", -1.5, 1.5, "-", "linear", 0.0, grid=5)),
        side="model",
        signature=("Fo x factor (Q/400)^p: the flow-driven force is off by a factor (every "
                   "flow, both sensors) and grows with flow another way (p tilts the "
                   "features about 400 gal/min: nothing changes there at factor 1)."),
        build=build, group="quantity",
    )


def _excitation_phase() -> Candidate:
    return Candidate(
        id="excitation_phase", variant="",
        params=(ParamSpec("slope", -1.5, 1.5, "rad", "linear", 0.0, grid=13),),
        side="model",
        signature=("theta0 + slope (Q/400 - 1): the excitation phase drifts with flow; nothing "
                   "changes at 400 gal/min, regimes and peaks move away from it, most in the "
                   "phase-sensitive middle flows (300-500 gal/min for the 7in tool)."),
        build=lambda v: (ModelChange(flow_slopes={"theta0": v["slope"]}) if v["slope"] != 0.0
                         else ModelChange()),
        group="quantity",
    )


def _contact_stiffness(surface: str) -> Candidate:
    name = SURFACES[surface]
    return Candidate(
        id="contact_stiffness", variant=surface,
        params=(ParamSpec("factor", 0.25, 4.0, "-", "log", 1.0, grid=9),),
        side="model",
        signature=f"{name} x factor. {_FACTOR_SIGNATURE[surface]}",
        build=lambda v: _scaled(name, v["factor"]),
        fixed={"surface": surface}, group="quantity",
    )


def _rock_stiffness() -> Candidate:
    return Candidate(
        id="rock_stiffness", variant="",
        params=(ParamSpec("factor", 0.25, 4.0, "-", "log", 1.0, grid=9),),
        side="model",
        signature=("kR x factor (another formation or bit): nearly silent in periodic regimes "
                   "(< 3 % on peaks for x0.5 / x2 at the 7in tool's 200, 300, 500, 650 "
                   "gal/min); it moves the intermittent middle flows' peaks and regimes."),
        build=lambda v: _scaled("kR", v["factor"]),
        group="quantity",
    )


def _mass(body: str) -> Candidate:
    name = BODIES[body]
    return Candidate(
        id="mass", variant=body,
        params=(ParamSpec("factor", 0.6, 1.6, "-", "log", 1.0, grid=9),),
        side="model",
        signature=f"{name} x factor: {_MASS_SIGNATURE[body]}.",
        build=lambda v: _scaled(name, v["factor"]),
        fixed={"body": body}, group="quantity",
    )


CANDIDATES: dict[str, Candidate] = {c.key: c for c in (
    _hydraulic("anvil"), _hydraulic("bit"), _contact_law(), _contact_law_impact(), _friction(),
    _friction_stribeck(), _radiation(),
    _axial_lateral(), *(_sensor_chain(v) for v in SENSOR_SETS), _excitation_amplitude(),
    _excitation_phase(), *(_contact_stiffness(v) for v in SURFACES), _rock_stiffness(),
    *(_mass(v) for v in BODIES))}
"""Every candidate variant by key (an id with variants comes as ``id[variant]``:
``hydraulic_force[anvil]``, ``mass[lwd]``...)."""


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
    """Candidate keys for ids or keys (None: all); an id with variants gives all of them. A
    name that is a key stays that key: ``"contact_law"`` is the four surfaces' family, not
    ``"contact_law[impact]"`` too."""
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
