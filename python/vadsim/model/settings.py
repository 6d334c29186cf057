"""How the model is run: one object for the settings every layer passes along.

Why this module exists: a validation, a calibration, a diagnosis, a synthetic campaign and a
sweep all run the same model with the same bundle -- preset, parameter overrides, extra
physics, contact law, run length, weight on bit, solver settings. Passed field by field, each
layer re-spelled it (and the excitation frequency ``alpha Q / 2 pi`` with it). A
:class:`RunSettings` is that bundle as plain, picklable data: it travels to a thread, a forked
process or a Dask worker, and :meth:`RunSettings.run` is the one way the analysis layers start a
run.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from vadsim import _core
from vadsim._checks import shown
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import (
    OPTIONAL_PARAMS,
    Preset,
    canonical_name,
    get_preset,
    make_params,
    override_values,
)
from vadsim.model.result import SimulationResult
from vadsim.model.simulation import extra_force, simulate

__all__ = ["ExtraSpec", "RunSettings", "excitation_hz"]





def excitation_hz(alpha: float, flow_gpm: float | np.ndarray) -> Any:
    """The excitation frequency ``f = alpha Q / (2 pi)`` (Hz) of flow ``Q`` (gal/min): the one
    place the Python layer computes it (the core computes the same for a run)."""
    return alpha * flow_gpm / (2.0 * math.pi)


@dataclass(frozen=True)
class ExtraSpec:
    """An extra force (:func:`vadsim.extra_force`) as plain data: hashable, picklable and
    JSON-ready, so it can cross a process or a Dask boundary and be stored in a dataset.

    Examples
    --------
    >>> ExtraSpec.of("hydraulic", acts_on="anvil", c=1e-4).as_dict()
    {'kind': 'hydraulic', 'acts_on': 'anvil', 'c': 0.0001}
    """

    kind: str
    args: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def of(cls, kind: str, **kw: Any) -> ExtraSpec:
        """A spec from :func:`vadsim.extra_force`'s arguments (checked now)."""
        spec = cls(kind, tuple(kw.items()))
        spec.build()
        return spec

    @classmethod
    def coerce(cls, value: Any) -> ExtraSpec | _core.ExtraForce:
        """A spec from a spec or a mapping with ``kind``; a core extra force is kept as is."""
        if isinstance(value, (ExtraSpec, _core.ExtraForce)):
            return value
        if isinstance(value, Mapping):
            kw = dict(value)
            if "kind" not in kw:
                raise ValueError(f"extra force {value!r} needs a 'kind'")
            return cls.of(kw.pop("kind"), **kw)
        raise ValueError(f"extra force {value!r} must be an ExtraSpec, a mapping with 'kind' "
                         "or come from vadsim.extra_force(...)")

    def build(self) -> _core.ExtraForce:
        """The core object."""
        return extra_force(self.kind, **dict(self.args))

    def as_dict(self) -> dict[str, Any]:
        """``{"kind": ..., **arguments}``."""
        return {"kind": self.kind, **dict(self.args)}


def _label(extra: ExtraSpec | _core.ExtraForce) -> Any:
    return extra.as_dict() if isinstance(extra, ExtraSpec) else getattr(extra, "name", str(extra))


@dataclass(frozen=True)
class RunSettings:
    """Everything but the operating point that decides a run.

    Parameters
    ----------
    preset
        A :class:`~vadsim.model.presets.Preset` or a preset name.
    overrides
        Parameters replaced by name (Table 2.1 names, ``l0``, ``wob``...).
    extras
        Extra physics: :class:`ExtraSpec`, mappings with ``kind`` (the arguments of
        :func:`vadsim.extra_force`) or core objects.
    law
        Contact law of the impact surfaces (None: the preset's).
    cycles, analyse_cycles
        Run length and steady window, in excitation cycles.
    wob_klbf
        Weight on bit (klbf) when the operating point does not give one (None: the preset's).
    method, rtol
        CVODE method and relative tolerance.
    steady
        ``"auto"`` (default): a run stops at a confirmed periodic orbit and is built from it;
        ``"full"``: every cycle integrated (:func:`vadsim.simulate`).
    """

    preset: Preset
    overrides: Mapping[str, float] = field(default_factory=dict)
    extras: tuple[ExtraSpec | _core.ExtraForce, ...] = ()
    law: str | None = None
    cycles: float = DEFAULTS.cycles
    analyse_cycles: float = DEFAULTS.analyse_cycles
    wob_klbf: float | None = None
    method: str = "adams"
    rtol: float = 1e-6
    steady: str = "auto"

    def __post_init__(self) -> None:
        object.__setattr__(self, "preset", get_preset(self.preset))
        object.__setattr__(self, "overrides", override_values(self.overrides))
        if not isinstance(self.extras, Sequence) or isinstance(self.extras, (str, bytes)):
            raise ValueError(f"extras = {shown(self.extras)} must be a sequence of extra forces")
        object.__setattr__(self, "extras", tuple(ExtraSpec.coerce(e) for e in self.extras))
        # 160 and 160.0 cycles are one run, so one cache key: the command line reads floats,
        # and its diagnosis then reads the runs the same diagnosis from Python made
        for name in ("cycles", "analyse_cycles"):
            value = getattr(self, name)
            if isinstance(value, int) and not isinstance(value, bool):
                object.__setattr__(self, name, float(value))

    def with_changes(self, **changes: Any) -> RunSettings:
        """A copy with fields replaced; ``overrides`` given here are merged into the current
        ones and ``extras`` appended (what a candidate physics does to a base model)."""
        if "overrides" in changes:
            changes["overrides"] = {**self.overrides, **{canonical_name(k): v for k, v in
                                                         dict(changes["overrides"] or {}).items()}}
        if "extras" in changes:
            changes["extras"] = (*self.extras, *changes["extras"])
        return replace(self, **changes)

    def param(self, name: str) -> float:
        """A parameter's value in these settings (the override, else the preset's; nan for an
        optional one neither sets, e.g. ``L_gap``)."""
        if name in self.overrides:
            return float(self.overrides[name])
        if name in OPTIONAL_PARAMS:
            return float(self.preset.params.get(name, math.nan))
        return float(self.preset.params[name])

    def params(self) -> _core.Params:
        """The core parameters of these settings (preset, overrides and law; validated)."""
        return make_params(self.preset, self.overrides, law=self.law)

    def f_exc_hz(self, flow_gpm: float | np.ndarray) -> Any:
        """Excitation frequency (Hz) at ``flow_gpm``."""
        return excitation_hz(self.param("alpha"), flow_gpm)

    def flows_for_hz(self, hz: Iterable[float]) -> np.ndarray:
        """Flow rates (gal/min) that give excitation frequencies ``hz``."""
        alpha = self.param("alpha")
        return np.asarray([2.0 * math.pi * f / alpha for f in hz], dtype=float)

    def run(self, flow_gpm: float, *, wob_klbf: float | None = None, **options: Any
            ) -> SimulationResult:
        """One run at ``flow_gpm`` (and ``wob_klbf``, else the settings'); ``options`` are
        :func:`vadsim.simulate`'s output and budget options (``record``, ``output_rate_hz``,
        ``summary_rate_hz``, ``initial_state``...)."""
        wob = wob_klbf if wob_klbf is not None else self.wob_klbf
        options.setdefault("steady", self.steady)
        return simulate(self.preset, flow_gpm, cycles=self.cycles,
                        analyse_cycles=self.analyse_cycles, overrides=self.overrides,
                        wob_klbf=wob, law=self.law, method=self.method, rtol=self.rtol,
                        extras=[e.build() if isinstance(e, ExtraSpec) else e
                                for e in self.extras], **options)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready description (for reports and dataset attributes)."""
        return {"preset": self.preset.name, "overrides": dict(self.overrides),
                "extras": [_label(e) for e in self.extras], "law": self.law or self.preset.law,
                "cycles": float(self.cycles), "analyse_cycles": float(self.analyse_cycles),
                "wob_klbf": float(self.wob_klbf if self.wob_klbf is not None
                                  else self.preset.wob_klbf),
                "method": self.method, "rtol": float(self.rtol), "steady": self.steady}
