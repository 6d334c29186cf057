"""Nuisance constants: what a diagnosis fits alongside every hypothesis without reporting it
as missing physics.

Why this module exists: a field campaign's WOB reading is uncertain and the tool's withheld
constants are not known exactly; MODEL.md shows the published lengths cannot fix the
excitation phase at rest ``theta0`` at all. A diagnosis that holds these at their nominal
values blames their error on some candidate physics. Fitting them jointly with each candidate
and with "none" makes "none" mean "the calibrated base model explains the campaign".

Defaults: ``wob_scale`` in [0.85, 1.15] (the WOB reading +-15 %) and ``theta0`` over its whole
period [0, pi). More with ``NAME=LO:HI``: ``wob_scale``, ``theta0`` (rad), or any model
parameter by its Table 2.1 name (absolute values, e.g. ``l0=0.65:0.75``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from vadsim.fit.candidates import ParamSpec
from vadsim.model.change import ModelChange, rest_phase
from vadsim.model.presets import canonical_name, param_names
from vadsim.model.settings import RunSettings

__all__ = ["DEFAULT_NUISANCE", "WIDEN_BY", "NuisanceSpec", "parse_nuisance", "resolve_nuisance",
           "widen"]


@dataclass(frozen=True)
class NuisanceSpec(ParamSpec):
    """A nuisance constant: a :class:`~vadsim.fit.candidates.ParamSpec` whose ``null`` is the
    base model's value, possibly periodic (``theta0``: the search wraps around)."""

    periodic: bool = False

    def change(self, value: float) -> ModelChange:
        """The model change that sets this constant to ``value``; none at its nominal value
        (so that a hypothesis at the nominal constants re-measures the base model's runs)."""
        if self.null is not None and float(value) == float(f"{self.null:.6g}"):
            return ModelChange()
        if self.name == "wob_scale":
            return ModelChange(scales={"wob": float(value)})
        if self.name == "theta0":
            return ModelChange(theta0=float(value) % math.pi)
        return ModelChange(overrides={self.name: float(value)})

    def wrap(self, u: float) -> float:
        """A position in the search box: wrapped if periodic, clipped otherwise."""
        return float(u % 1.0) if self.periodic else min(max(float(u), 0.0), 1.0)


WOB_SCALE = NuisanceSpec("wob_scale", 0.85, 1.15, "-", "linear", 1.0, grid=5)
THETA0 = NuisanceSpec("theta0", 0.0, math.pi, "rad", "linear", None, grid=16, periodic=True)
DEFAULT_NUISANCE: tuple[NuisanceSpec, ...] = (WOB_SCALE, THETA0)
"""The WOB reading (+-15 %) and the excitation phase at rest (its whole period)."""


def parse_nuisance(text: str) -> NuisanceSpec:
    """``NAME=LO:HI`` -> a nuisance constant (errors name the bad part)."""
    name, sep, rng = text.partition("=")
    name = canonical_name(name.strip())
    lo_s, sep2, hi_s = rng.partition(":")
    if not (sep and sep2 and name):
        raise ValueError(f"nuisance {text!r} must be NAME=LO:HI, e.g. wob_scale=0.85:1.15")
    try:
        lo, hi = float(lo_s), float(hi_s)
    except ValueError:
        raise ValueError(f"nuisance {text!r}: LO and HI must be numbers") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"nuisance {text!r}: needs finite LO < HI")
    if name == "theta0":
        return replace(THETA0, lo=lo, hi=hi, periodic=(hi - lo) >= math.pi)
    if name == "wob_scale":
        if lo <= 0:
            raise ValueError(f"nuisance {text!r}: a WOB scale must be > 0")
        return replace(WOB_SCALE, lo=lo, hi=hi)
    if name not in param_names():
        raise ValueError(f"nuisance {text!r}: unknown name {name!r}; use wob_scale, theta0 or a "
                         "model parameter (vadsim params)")
    return NuisanceSpec(name, lo, hi, "", "linear", None, grid=5)


def resolve_nuisance(specs: tuple[NuisanceSpec, ...], settings: RunSettings
                     ) -> tuple[NuisanceSpec, ...]:
    """Specs with their null (the base model's value) filled in from ``settings``; one per
    name (a later spec replaces an earlier one)."""
    out: dict[str, NuisanceSpec] = {}
    for s in specs:
        if s.name == "theta0":
            null = rest_phase(settings)
            if not s.periodic:
                null = min(max(null, s.lo), s.hi)
        elif s.name == "wob_scale":
            null = 1.0
        else:
            null = settings.param(s.name)
        null = min(max(null, s.lo), s.hi) if not s.periodic else null
        out[s.name] = replace(s, null=float(null))
    return tuple(out.values())


WIDEN_BY = 0.5
"""A nuisance constant fitted at an end of its range has that end moved out by this fraction
of the range (:func:`widen`)."""


def widen(specs: tuple[NuisanceSpec, ...], at_bounds: list[dict[str, Any]]
          ) -> tuple[tuple[NuisanceSpec, ...], list[dict[str, Any]]]:
    """The specs with each constant that ``at_bounds`` (a fit's
    :attr:`~vadsim.fit.hypothesis_fit.HypothesisFit.at_bounds`) names at an end of its range
    widened at that end by :data:`WIDEN_BY` of the range; a positive lower end stays positive
    (at least half of what it was: a WOB scale or a length cannot reach 0).

    Why: a nuisance constant at its bound is evidence, not an estimate -- the recordings ask
    for more than the range allows, and a candidate fitted on top of that calibration starts
    from the wrong place. Returns the new specs and one record per change: ``name``,
    ``bound``, ``value`` (where the fit stopped), ``from`` and ``to`` (the ranges)."""
    hit = {e["param"]: e for e in at_bounds if e.get("of") == "nuisance"}
    out, changes = [], []
    for spec in specs:
        edge = hit.get(spec.name)
        if edge is None or spec.periodic:
            out.append(spec)
            continue
        span = spec.hi - spec.lo
        lo, hi = spec.lo, spec.hi
        if edge["bound"] == "lower":
            lo = lo - WIDEN_BY * span
            if spec.lo > 0:
                lo = max(lo, 0.5 * spec.lo)
        else:
            hi = hi + WIDEN_BY * span
        out.append(replace(spec, lo=float(f"{lo:.6g}"), hi=float(f"{hi:.6g}")))
        changes.append({"name": spec.name, "bound": edge["bound"], "value": edge["value"],
                        "from": [spec.lo, spec.hi], "to": [out[-1].lo, out[-1].hi]})
    return tuple(out), changes
