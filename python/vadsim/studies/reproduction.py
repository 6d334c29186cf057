"""Every number the dissertation publishes, vadsim's value, and why a miss is a miss.

Why this module exists: ``vadsim thesis`` once printed ``ok=False`` for most regime bands and
peaks, which reads as "the simulator is wrong". Most misses have a measured reason instead:
the number depends on constants the published lengths do not fix (the phase at rest theta0,
the gap; MODEL.md), or it contradicts another published number in this model, or it is not a
model output at all (J* in kN needs the unpublished reference mass). :func:`reproduce` lists
each published number once (the files of ``data/thesis``), with vadsim's value for the
reference preset and for the thesis preset (the constants of the scan,
:mod:`vadsim.studies.constants`), the tolerance, a status, and the reason, measured on the
scan where the scan covers the number. This module runs what the numbers need (the sweeps,
:func:`thesis_maps`) and explains the misses; the rows themselves, one published number
each, are built in :mod:`vadsim.studies.reproduction_rows`.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from vadsim.data import field_events
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import get_preset
from vadsim.model.settings import RunSettings
from vadsim.studies.constants import SPRING_DESIGNS
from vadsim.studies.design import RECOMMENDED, STUDIES, design_sweep, one_at_a_time
from vadsim.studies.reproduction_rows import (
    event_rows,
    parameter_rows,
    parametric_study_rows,
    regime_rows,
)
from vadsim.studies.sweep import sweep

__all__ = ["Reproduction", "reproduce", "scan_reasons", "thesis_maps"]

FLOWS = np.arange(200.0, 650.0 + 1e-9, 10.0)
"""The 7in flow sweep of chapter 4 (10 gal/min, the resolution of the published bands)."""

MAP_STUDIES = ("gap", "spring")
"""The chapter 5 maps whose regime counts the dissertation publishes."""

SPRING_MAP_STEPS = 96
"""kS values of :func:`thesis_maps`' spring map. The published step (0.79 kN/(kg m)) gives 948
values, 92,000 runs; every tenth of them keeps the map at 9,300 runs (the gap map keeps its
published 85 values)."""

STATUS = ("reproduced", "missed", "input", "compared with field", "not comparable",
          "not a model output", "not measured")
"""The statuses a row can have."""


@dataclass
class Reproduction:
    """The table of every published number and the sweeps behind it.

    Attributes
    ----------
    table
        One row per published number: ``id, source, quantity, published, unit``, then per
        preset label (``reference``, ``thesis``) the value and the status, then ``tolerance``
        and ``reason``.
    presets
        ``{label: preset name}``.
    sweeps
        ``{label: {name: dataset}}``: the CDE, RC and PDC sweeps and the design sweeps.
    """

    table: pd.DataFrame
    presets: dict[str, str]
    sweeps: dict[str, dict[str, xr.Dataset]] = field(default_factory=dict)
    seconds: float = 0.0
    maps: dict[str, dict[str, xr.Dataset]] = field(default_factory=dict)
    """``{label: {study: map}}``: the chapter 5 maps the map-count rows were measured on."""

    def counts(self) -> pd.DataFrame:
        """Rows per status and preset."""
        labels = list(self.presets)
        return pd.DataFrame({lab: self.table[f"status_{lab}"].value_counts()
                             for lab in labels}).fillna(0).astype(int)


def reproduce(reference: str = "7in-cde", thesis: str | None = "7in-cde-thesis",
              scan: pd.DataFrame | None = None, *, cycles: float = DEFAULTS.cycles,
              analyse_cycles: float = DEFAULTS.analyse_cycles, workers: int | None = None,
              progress: bool = True,
              maps: Mapping[str, Mapping[str, xr.Dataset]] | None = None) -> Reproduction:
    """Run what the published numbers need and tabulate them.

    Parameters
    ----------
    reference, thesis
        The 7in CDE presets compared (their RC twins are the names with ``-rc``); ``thesis``
        None compares the reference alone.
    scan
        :attr:`vadsim.studies.constants.ConstantScan.scores` (or the ``scores.csv`` a scan
        wrote): the reasons of the misses it covers are measured on it.
    cycles, analyse_cycles, workers, progress
        As :func:`vadsim.studies.sweep`.
    maps
        ``{label: {"gap": map, "spring": map}}`` (labels ``reference``, ``thesis``), e.g. from
        :func:`thesis_maps`: the dissertation's regime counts in its chapter 5 maps are
        measured on them. Without them those rows say "not measured".
    """
    t0 = time.perf_counter()
    presets = {"reference": reference, **({"thesis": thesis} if thesis else {})}
    kw: dict[str, Any] = dict(cycles=cycles, analyse_cycles=analyse_cycles, workers=workers,
                              progress=progress)
    sweeps = {lab: _preset_sweeps(name, kw) for lab, name in presets.items()}
    pdc = sweep("9.5in-pdc", field_events("9.5in", "PDC").flow_gpm.to_numpy(float), **kw)
    run_s = _one_run_seconds()
    rows: list[dict[str, Any]] = []
    rows += parameter_rows(presets)
    rows += regime_rows(sweeps)
    rows += event_rows(sweeps, pdc)
    given = {lab: dict(maps[lab]) for lab in presets if maps and lab in maps}
    rows += parametric_study_rows(sweeps, run_s, given)
    table = _explain(pd.DataFrame(rows), list(presets), scan)
    return Reproduction(table, presets, sweeps, time.perf_counter() - t0, given)


def _explain(table: pd.DataFrame, labels: list[str], scan: pd.DataFrame | None
             ) -> pd.DataFrame:
    """Fill the reason of every miss: the scan's (where it covers the number, or the number's
    event), else what is known to be outside it."""
    reasons = scan_reasons(scan) if scan is not None else {}
    event_target = {}
    for _, r in table.iterrows():  # an event's other numbers follow its peak
        if isinstance(r.scan_target, str) and r.source == "field_events.csv":
            event_target[r.id.rsplit(":", 1)[0]] = r.scan_target
    for i, r in table.iterrows():
        missed = any(r[f"status_{lab}"] == "missed" for lab in labels)
        if not missed or r.reason:
            continue
        key = r.scan_target if isinstance(r.scan_target, str) else event_target.get(
            r.id.rsplit(":", 1)[0])
        if key in reasons:
            own = "" if key == r.scan_target else f"this event's peak ({key}) is "
            table.at[i, "reason"] = own + reasons[key]
        elif key is not None:
            table.at[i, "reason"] = "covered by the constants scan: run vadsim constants"
        else:
            table.at[i, "reason"] = "not covered by the constants scan (theta0, gap)"
    return table.drop(columns=["scan_target"])


# ----------------------------------------------------------------------------- the runs

def _rc_twin(name: str) -> str:
    return name.replace("-cde", "-rc")


def _preset_sweeps(name: str, kw: Mapping[str, Any]) -> dict[str, xr.Dataset]:
    """The CDE flow sweep, the RC sweep at the RC events' flows, and the design sweeps."""
    out = {"cde": sweep(name, FLOWS, **kw),
           "rc": sweep(_rc_twin(name), field_events("7in", "RC").flow_gpm.to_numpy(float),
                       **kw)}
    designs = {"force": {"Fo": STUDIES["force"].hi * STUDIES["force"].scale},
               "gap": {"gap_ratio": 1.5}, "recommended": dict(RECOMMENDED), **SPRING_DESIGNS}
    for key, design in designs.items():
        out[key] = design_sweep(name, FLOWS, design, **kw)
    return out


def _one_run_seconds() -> float:
    """Wall time of one 400-cycle run at 200 gal/min (the dissertation's timed run), best of
    three."""
    s = RunSettings(get_preset("7in-cde"))
    best = math.inf
    for _ in range(3):
        t = time.perf_counter()
        s.run(200.0, record="none")
        best = min(best, time.perf_counter() - t)
    return best


def thesis_maps(preset: str, folder: str | os.PathLike[str], *,
                spring_steps: int = SPRING_MAP_STEPS, cycles: float = DEFAULTS.cycles,
                analyse_cycles: float = DEFAULTS.analyse_cycles, **sweep_kwargs: Any
                ) -> dict[str, xr.Dataset]:
    """The gap and spring maps of chapter 5 for ``preset``, kept in ``folder``.

    The gap map has the published 85 gap ratios, the spring map ``spring_steps`` kS values,
    both the dissertation's flow axis (21.3-69.3 Hz in 0.5 Hz). A map already in ``folder``
    (``<preset>-<study>.nc``, same axis and run length) is read, not run again; an
    interrupted one resumes from its store (``<preset>-<study>.store``).
    """
    if not (isinstance(spring_steps, int) and spring_steps >= 2):
        raise ValueError(f"spring_steps = {spring_steps!r} must be an integer >= 2 (kS values "
                         "of the spring map)")
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    maps = {}
    for study in MAP_STUDIES:
        steps = spring_steps if study == "spring" else None
        nc = out / f"{preset}-{study}.nc"
        param = STUDIES[study].parameter
        want = STUDIES[study].values(steps)
        if nc.is_file():
            with xr.open_dataset(nc) as old:
                ds = old.load()
            if (ds.attrs.get("preset") == preset and ds[param].size == want.size
                    and float(ds.attrs.get("cycles", -1)) == cycles
                    and float(ds.attrs.get("analyse_cycles", -1)) == analyse_cycles):
                maps[study] = ds
                continue
        ds = one_at_a_time(study, preset, steps=steps, detail="map", cycles=cycles,
                           analyse_cycles=analyse_cycles,
                           store=out / f"{preset}-{study}.store", **sweep_kwargs)
        ds.to_netcdf(nc)
        maps[study] = ds
    return maps


# ------------------------------------------------------------------------- the reasons

def scan_reasons(scores: pd.DataFrame) -> dict[str, str]:
    """Per scanned target, the measured reason a preset may miss it: where in the scan of
    theta0 and the gap it is met, and which other targets it is never met together with.

    ``scores`` is :attr:`vadsim.studies.constants.ConstantScan.scores` (or its CSV)."""
    scored = scores.pivot_table(index=["theta0", "gap_ratio"], columns="target", values="ok",
                                aggfunc="first")
    ok = scored.fillna(False).astype(bool)  # a target not scored at a point is not met there
    out = {}
    for target in ok.columns:
        met = ok[target]
        n = int(scored[target].notna().sum())  # the design targets: a coarser grid
        if not met.any():
            out[target] = (f"met at none of the {n} scan points (theta0 over [0, pi), gap "
                           f"{ok.index.get_level_values(1).min():g}-"
                           f"{ok.index.get_level_values(1).max():g}x): out of reach of the "
                           "unidentifiable constants in this model")
            continue
        where = met[met].index
        t_lo, t_hi = where.get_level_values(0).min(), where.get_level_values(0).max()
        never = [o for o in ok.columns if o != target and ok[o].any()
                 and not (met & ok[o]).any()]
        text = (f"unidentifiable: met at {int(met.sum())} of {n} scan points (theta0 "
                f"{t_lo:.2f}-{t_hi:.2f}, gap {where.get_level_values(1).min():g}-"
                f"{where.get_level_values(1).max():g}x)")
        if never:
            text += ("; never met together with " + ", ".join(never[:4])
                     + (f" and {len(never) - 4} more" if len(never) > 4 else "")
                     + " (self-contradictory in this model)")
        out[target] = text
    return out
