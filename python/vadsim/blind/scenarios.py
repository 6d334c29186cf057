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
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol

from vadsim.model.change import ModelChange

__all__ = ["CLASSES", "DEFAULT_FLOWS", "DEFAULT_SCENARIOS", "FIVE_FLOWS", "NUISANCE_NAMES",
           "Scenario", "candidate_id", "class_counts", "scenarios_of"]

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
    """

    class_name: str
    truths: tuple[tuple[str, Mapping[str, float]], ...] = ()
    nuisance: Mapping[str, float] = field(default_factory=dict)
    preset: str = "7in-cde"
    flows: tuple[float, ...] = DEFAULT_FLOWS
    noise_g: float = 0.3
    duration_s: float = 8.0

    def __post_init__(self) -> None:
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

    def nuisance_change(self) -> ModelChange:
        """The change of the nuisance truths alone: WOB scaled, excitation phase at rest."""
        wob = self.nuisance.get("wob_scale", 1.0)
        return ModelChange(scales={"wob": wob} if wob != 1.0 else {},
                           theta0=self.nuisance.get("theta0"))

    def change(self, library: Mapping[str, _Candidate] | None = None) -> ModelChange:
        """The recording model's change: every truth's ``library[key].change(values)``
        combined with the nuisance change. ``library`` defaults to
        :data:`vadsim.fit.candidates.CANDIDATES`."""
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
                "duration_s": self.duration_s}


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
}
"""Classes of the default benchmark and what each tests."""

_HYD = {"f_ref": 60.0, "n": 2.0}

# Not concealed: rock_stiffness (x0.1 to x4) and hydraulic_force[bit] (f_ref up to 200 N/kg)
# leave the 1024 Hz records as the base model's (RMS z <= 0.5 at nearly every event, as a
# null): the rock contact is stiff, so they only change the static load. A truth no record
# shows cannot be scored.
DEFAULT_SCENARIOS: tuple[Scenario, ...] = (
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
"""The default benchmark: 32 campaigns in 9 classes (:data:`CLASSES`)."""


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
