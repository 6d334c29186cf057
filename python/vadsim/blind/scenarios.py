"""The blind benchmark's scenarios: classes of campaigns and the truth concealed in each.

Why this module exists: one benchmark score hides which kind of campaign a diagnosis fails
on. A diagnosis that fits nuisance constants (the WOB reading, the excitation phase at rest)
must say "none" when only those are off, name each effect of a pair, find generic effects
(masses, stiffnesses, the excitation) as well as the mechanistic ones, find an effect seen
by one sensor only, and keep working on another bit, with five events, and at 1 g noise. So
the scenarios come in classes (:data:`CLASSES`), each scored on its own.

A scenario is data only: candidate keys with values, and nuisance truths. Its model change is
built at write time through ``library[key].change(values)`` (:meth:`Scenario.change`), so the
scenarios can name candidates of a library that is not the one imported here (tests pass a
stand-in), and nothing here reaches into a candidate's internals.

Magnitudes are chosen so that an effect shows at some operating points and not at others
(``vadsim.blind.detectability`` measures it per event).

The classes ``indep_*`` are written by the independent generator
(:mod:`vadsim.blind.independent`: another simulator of the same model, its own sensor chain,
effects in its own form), so the benchmark also holds campaigns the diagnosis' own simulator
never wrote. Their truths are the library members the effects are scored as
(:func:`vadsim.blind.independent.nearest_library`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol

from vadsim.blind.independent.effects import EFFECTS, nearest_library
from vadsim.blind.independent.model import preset_params
from vadsim.blind.independent.recording import IndependentSpec
from vadsim.model.change import ModelChange

__all__ = ["CLASSES", "DEFAULT_FLOWS", "DEFAULT_SCENARIOS", "FIVE_FLOWS", "GENERATORS",
           "INDEPENDENT_SCENARIOS", "NUISANCE_NAMES", "Scenario", "candidate_id", "class_counts",
           "scenarios_of"]

GENERATORS: tuple[str, ...] = ("vadsim", "independent")
"""Who writes a scenario's campaign: vadsim's own simulator and sensor chain
(:func:`vadsim.campaigns.synthetic.synthetic_campaign`) or the independent generator
(:mod:`vadsim.blind.independent`)."""

DEFAULT_FLOWS: tuple[float, ...] = (200.0, 250.0, 300.0, 350.0, 400.0, 450.0, 500.0, 550.0,
                                    600.0, 650.0)
"""Ten events over the 7in tool's range (gal/min)."""

FIVE_FLOWS: tuple[float, ...] = (250.0, 350.0, 450.0, 550.0, 650.0)
"""Five events: a short campaign, where every held-out fold is a fifth of the data."""

NUISANCE_NAMES: tuple[str, ...] = ("wob_scale", "theta0")
"""Nuisance truths a scenario may set: the recording model's WOB x ``wob_scale`` (the
campaign states the nominal WOB) and its excitation phase at rest ``theta0`` (rad)."""


class _Candidate(Protocol):
    def change(self, values: Mapping[str, float]) -> ModelChange: ...


def candidate_id(key: str) -> str:
    """The id a diagnosis reports for a candidate key: the key without its ``[variant]``."""
    return key.partition("[")[0]


@dataclass(frozen=True)
class Scenario:
    """One campaign's concealed truth and recording conditions.

    Parameters
    ----------
    class_name
        The class it is scored in (a key of :data:`CLASSES`).
    truths
        ``(candidate key, values)`` pairs; empty for a null campaign.
    nuisance
        Nuisance truths by name (:data:`NUISANCE_NAMES`); they are not missing physics.
    preset, flows, noise_g, duration_s
        How the campaign is recorded: the model, one event per flow (gal/min), sensor noise
        (g) and seconds per event.
    generator
        Who writes it (:data:`GENERATORS`).
    effects
        The independent generator's effects, ``(name, values)`` in its own form
        (:data:`vadsim.blind.independent.EFFECTS`). With them, ``truths`` are derived: the
        library key each effect is scored as, at the nearest member's values.
    """

    class_name: str
    truths: tuple[tuple[str, Mapping[str, float]], ...] = ()
    nuisance: Mapping[str, float] = field(default_factory=dict)
    preset: str = "7in-cde"
    flows: tuple[float, ...] = DEFAULT_FLOWS
    noise_g: float = 0.3
    duration_s: float = 8.0
    generator: str = "vadsim"
    effects: tuple[tuple[str, Mapping[str, float]], ...] = ()

    def __post_init__(self) -> None:
        if self.generator not in GENERATORS:
            raise ValueError(f"scenario generator {self.generator!r}: choose from "
                             f"{', '.join(GENERATORS)}")
        if self.effects and self.generator != "independent":
            raise ValueError("scenario effects are written by the independent generator "
                             "only (generator='independent')")
        effects = tuple((str(n), MappingProxyType({k: float(v) for k, v in dict(vals).items()}))
                        for n, vals in self.effects)
        unknown_effects = [n for n, _ in effects if n not in EFFECTS]
        if unknown_effects:
            raise ValueError(f"scenario effects {unknown_effects}: choose from "
                             f"{', '.join(EFFECTS)}")
        object.__setattr__(self, "effects", effects)
        if self.generator == "independent" and "theta0" in dict(self.nuisance):
            raise ValueError("the independent generator takes the phase at rest from MODEL.md "
                             "(beta (x2 - x3) + psi); a theta0 nuisance cannot be written")
        if effects and not self.truths:
            params = preset_params(self.preset)
            object.__setattr__(self, "truths", tuple(
                nearest_library(n, v, self.flows, params)[:2] for n, v in effects))
        truths = tuple((str(k), MappingProxyType({n: float(v) for n, v in dict(vals).items()}))
                       for k, vals in self.truths)
        object.__setattr__(self, "truths", truths)
        object.__setattr__(self, "nuisance", MappingProxyType(
            {k: float(v) for k, v in dict(self.nuisance).items()}))
        object.__setattr__(self, "flows", tuple(float(q) for q in self.flows))
        unknown = set(self.nuisance) - set(NUISANCE_NAMES)
        if unknown:
            raise ValueError(f"scenario nuisance {sorted(unknown)}: choose from "
                             f"{', '.join(NUISANCE_NAMES)}")
        if len(set(self.ids)) != len(self.ids):
            raise ValueError(f"scenario truths {self.keys}: one id twice cannot be scored")
        if not self.flows:
            raise ValueError("scenario flows is empty")

    @property
    def keys(self) -> list[str]:
        """Candidate keys of the truths (with variants)."""
        return [k for k, _ in self.truths]

    @property
    def ids(self) -> list[str]:
        """Candidate ids a diagnosis should report (``[]`` for a null campaign)."""
        return [candidate_id(k) for k in self.keys]

    @property
    def is_null(self) -> bool:
        """No missing physics (nuisance truths may still be set)."""
        return not self.truths

    @property
    def library_point(self) -> bool:
        """The truth is a point of the candidate library (every vadsim scenario; an
        independent one whose effects are all exact members): the regret can evaluate it."""
        if not self.effects:
            return True
        params = preset_params(self.preset)
        return all(nearest_library(n, v, self.flows, params)[2] for n, v in self.effects)

    def independent_spec(self, duration_s: float | None = None,
                         settle_cycles: float = 100.0) -> IndependentSpec:
        """What the independent generator writes for this scenario."""
        if self.generator != "independent":
            raise ValueError(f"scenario of class {self.class_name} is written by "
                             f"{self.generator}, not the independent generator")
        return IndependentSpec(preset=self.preset, flows=self.flows, effects=self.effects,
                               wob_scale=self.nuisance.get("wob_scale", 1.0),
                               noise_g=self.noise_g,
                               duration_s=duration_s or self.duration_s,
                               settle_cycles=settle_cycles)

    def nuisance_change(self) -> ModelChange:
        """The change of the nuisance truths alone: WOB scaled, excitation phase at rest."""
        wob = self.nuisance.get("wob_scale", 1.0)
        return ModelChange(scales={"wob": wob} if wob != 1.0 else {},
                           theta0=self.nuisance.get("theta0"))

    def change(self, library: Mapping[str, _Candidate] | None = None) -> ModelChange:
        """The recording model's change: every truth's ``library[key].change(values)``
        combined with the nuisance change. ``library`` defaults to
        :data:`vadsim.fit.candidates.CANDIDATES`. Not for an independent scenario: its
        effects are not model changes of vadsim."""
        if self.generator != "vadsim":
            raise ValueError(f"scenario of class {self.class_name} is written by the "
                             f"{self.generator} generator: it has no vadsim model change")
        if library is None:
            from vadsim.fit.candidates import CANDIDATES

            library = CANDIDATES
        out = ModelChange()
        for key, values in self.truths:
            if key not in library:
                raise ValueError(f"scenario truth {key!r} is not in the candidate library "
                                 f"({', '.join(library)})")
            out = out.combine(library[key].change(dict(values)))
        return out.combine(self.nuisance_change())

    def describe(self) -> dict[str, Any]:
        """The truth record of ``truth.json`` (JSON-ready)."""
        return {"class": self.class_name, "ids": self.ids, "keys": self.keys,
                "truths": [{"key": k, "id": candidate_id(k), "values": dict(v)}
                           for k, v in self.truths],
                "nuisance": dict(self.nuisance), "preset": self.preset,
                "flows": list(self.flows), "noise_g": self.noise_g,
                "duration_s": self.duration_s, "generator": self.generator,
                **({"effects": [{"name": n, "values": dict(v)} for n, v in self.effects],
                    "library_point": self.library_point}
                   if self.generator == "independent" else {})}


CLASSES: dict[str, str] = {
    "null": "no effect: the diagnosis must say 'none'",
    "nuisance_null": "only the WOB reading (x0.9, x1.1) or the excitation phase at rest "
                     "(+-0.3 rad) is off: a fitted nuisance must still give 'none'",
    "nuisance_effect": "one effect under an off WOB reading: found, the nuisance not blamed",
    "pair": "two effects at once: both named (order-insensitive)",
    "generic": "generic effects: excitation amplitude and phase vs flow, a contact "
               "stiffness (impact face, recoil spring), the anvil's mass",
    "one_sensor": "an effect seen by one sensor only (x5 or x1)",
    "rc_bit": "the 7in RC bit (preset 7in-rc): a null and two effects",
    "five_events": "five events (250-650 gal/min): a null and two effects",
    "noise_1g": "sensor noise 1 g instead of 0.3 g: a null and two effects",
    "indep_null": "independent generator: two nulls and one with the WOB reading x0.9",
    "indep_excitation": "independent generator: the flow force Fo factor (Q/400)^p, a "
                        "library member (excitation_amplitude) written apart",
    "indep_hydraulic": "independent generator: a nozzle-law force c Q^2 with a smooth onset "
                       "on the anvil (scored as hydraulic_force[anvil])",
    "indep_friction": "independent generator: Stribeck friction anvil-housing, algebraic "
                      "regularisation (scored as anvil_friction)",
    "indep_contact": "independent generator: a Hertzian impact face k d^1.5 with "
                     "Hunt-Crossley damping, written apart (contact_law[impact])",
}
"""Classes of the default benchmark and what each tests."""

_HYD = {"f_ref": 60.0, "n": 2.0}

# Not concealed: rock_stiffness (x0.1 to x4) and hydraulic_force[bit] (f_ref up to 200 N/kg)
# leave the 1024 Hz records as the base model's (RMS z <= 0.5 at nearly every event, as a
# null): the rock contact is stiff, so they only change the static load. A truth no record
# shows cannot be scored.
_VADSIM_SCENARIOS: tuple[Scenario, ...] = (
    *(Scenario("null") for _ in range(3)),
    Scenario("nuisance_null", nuisance={"wob_scale": 0.9}),
    Scenario("nuisance_null", nuisance={"wob_scale": 1.1}),
    # the 7in tool's rest phase is 2.264 rad (MODEL.md): +-0.3 rad
    Scenario("nuisance_null", nuisance={"wob_scale": 1.1, "theta0": 2.564}),
    Scenario("nuisance_null", nuisance={"theta0": 1.964}),
    Scenario("nuisance_effect", (("hydraulic_force[anvil]", {"f_ref": 50.0, "n": 2.0}),),
             {"wob_scale": 0.9}),
    Scenario("nuisance_effect", (("anvil_friction", {"force": 120.0}),), {"wob_scale": 1.1}),
    Scenario("nuisance_effect", (("contact_law", {"factor": 3.0, "s": 1.0}),),
             {"wob_scale": 0.9}),
    Scenario("nuisance_effect", (("string_radiation", {"c": 1.5e5}),), {"wob_scale": 1.1}),
    Scenario("pair", (("hydraulic_force[anvil]", _HYD), ("anvil_friction", {"force": 100.0}))),
    Scenario("pair", (("sensor_chain[both]", {"f_res_hz": 600.0, "q": 6.0}),
                      ("contact_law", {"factor": 0.4, "s": 0.5}))),
    Scenario("pair", (("string_radiation", {"c": 1.5e5}),
                      ("excitation_amplitude", {"factor": 1.0, "p": 0.8}))),
    # each alone shows up to RMS z 10; together they partly cancel (at most 3.5)
    Scenario("pair", (("hydraulic_force[anvil]", {"f_ref": 40.0, "n": 1.5}),
                      ("contact_stiffness[impact]", {"factor": 2.0}))),
    Scenario("generic", (("excitation_amplitude", {"factor": 1.0, "p": 0.8}),)),
    Scenario("generic", (("contact_stiffness[impact]", {"factor": 2.5}),)),
    Scenario("generic", (("contact_stiffness[spring]", {"factor": 0.35}),)),
    Scenario("generic", (("mass[anvil]", {"factor": 1.3}),)),
    Scenario("generic", (("excitation_phase", {"slope": 1.2}),)),
    Scenario("one_sensor", (("sensor_chain[x5]", {"f_res_hz": 250.0, "q": 8.0}),)),
    Scenario("one_sensor", (("sensor_chain[x1]", {"f_res_hz": 700.0, "q": 8.0}),)),
    Scenario("one_sensor", (("axial_lateral", {"gain": 3.0, "f_lat_hz": 150.0}),)),
    Scenario("rc_bit", preset="7in-rc"),
    Scenario("rc_bit", (("hydraulic_force[anvil]", _HYD),), preset="7in-rc"),
    Scenario("rc_bit", (("anvil_friction", {"force": 120.0}),), preset="7in-rc"),
    Scenario("five_events", flows=FIVE_FLOWS),
    Scenario("five_events", (("hydraulic_force[anvil]", _HYD),), flows=FIVE_FLOWS),
    Scenario("five_events", (("sensor_chain[both]", {"f_res_hz": 500.0, "q": 6.0}),),
             flows=FIVE_FLOWS),
    Scenario("noise_1g", noise_g=1.0),
    Scenario("noise_1g", (("anvil_friction", {"force": 150.0}),), noise_g=1.0),
    Scenario("noise_1g", (("hydraulic_force[anvil]", _HYD),), noise_g=1.0),
)
"""The campaigns vadsim writes itself: 32 in 9 classes."""


def _indep(class_name: str, *effects: tuple[str, Mapping[str, float]],
           wob_scale: float = 1.0) -> Scenario:
    return Scenario(class_name, generator="independent", effects=effects,
                    nuisance={"wob_scale": wob_scale} if wob_scale != 1.0 else {})


INDEPENDENT_SCENARIOS: tuple[Scenario, ...] = (
    _indep("indep_null"),
    _indep("indep_null"),
    _indep("indep_null", wob_scale=0.9),
    # the case: Fo (Q/400)^0.5, far from the calibrated nuisance
    _indep("indep_excitation", ("excitation_power", {"factor": 1.0, "p": 0.5})),
    _indep("indep_excitation", ("excitation_power", {"factor": 1.25, "p": 0.0})),
    _indep("indep_excitation", ("excitation_power", {"factor": 0.85, "p": -0.6})),
    _indep("indep_hydraulic", ("hydraulic_quadratic", {"f400": 60.0, "q_on": 350.0,
                                                       "width": 50.0})),
    _indep("indep_hydraulic", ("hydraulic_quadratic", {"f400": 45.0, "q_on": 450.0,
                                                       "width": 40.0})),
    _indep("indep_friction", ("friction_stribeck", {"force": 100.0, "static": 160.0,
                                                    "v_s": 0.05, "v0": 0.005})),
    _indep("indep_friction", ("friction_stribeck", {"force": 140.0, "static": 200.0,
                                                    "v_s": 0.1, "v0": 0.01})),
    _indep("indep_contact", ("hertz_contact", {"stiffness": 1.0, "damping": 0.2})),
    _indep("indep_contact", ("hertz_contact", {"stiffness": 2.0, "damping": 0.4})),
)
"""The independent generator's 12 campaigns (classes ``indep_*``): 10 events over
:data:`DEFAULT_FLOWS`, 0.3 g noise, 8 s records, the 7in CDE tool."""

DEFAULT_SCENARIOS: tuple[Scenario, ...] = (*_VADSIM_SCENARIOS, *INDEPENDENT_SCENARIOS)
"""The default benchmark: 44 campaigns in 14 classes (:data:`CLASSES`), 12 of them written by
the independent generator."""


def class_counts(scenarios: Sequence[Scenario] = DEFAULT_SCENARIOS) -> dict[str, int]:
    """Campaigns per class, in first-seen order."""
    out: dict[str, int] = {}
    for s in scenarios:
        out[s.class_name] = out.get(s.class_name, 0) + 1
    return out


def scenarios_of(classes: Sequence[str] | None,
                 scenarios: Sequence[Scenario] = DEFAULT_SCENARIOS) -> list[Scenario]:
    """The scenarios of ``classes`` (None: all); an unknown class is a ValueError that lists
    the known ones."""
    known = class_counts(scenarios)
    if classes is None:
        return list(scenarios)
    unknown = [c for c in classes if c not in known]
    if unknown:
        raise ValueError(f"unknown blind class(es) {', '.join(unknown)}: choose from "
                         f"{', '.join(known)}")
    return [s for s in scenarios if s.class_name in set(classes)]
