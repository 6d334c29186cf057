"""Every number the dissertation publishes, vadsim's value, and why a miss is a miss.

Why this module exists: ``vadsim thesis`` once printed ``ok=False`` for most regime bands and
peaks, which reads as "the simulator is wrong". Most misses have a measured reason instead:
the number depends on constants the published lengths do not fix (the phase at rest theta0,
the gap; MODEL.md), or it contradicts another published number in this model, or it is not a
model output at all (J* in kN needs the unpublished reference mass). :func:`reproduce` lists
each published number once (the files of ``data/thesis``), with vadsim's value for the
reference preset and for the thesis preset (the constants of the scan,
:mod:`vadsim.studies.constants`), the tolerance, a status, and the reason, measured on the
scan where the scan covers the number.
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

from vadsim.data import field_events, parametric_rows, published_regimes, table_2_1
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import get_preset
from vadsim.model.settings import RunSettings
from vadsim.studies.constants import (
    DESIGN_TARGETS,
    PEAK_TOL,
    REGIME_TOL_GPM,
    SPRING_DESIGNS,
    SPRING_J_TOL,
    band_scores,
)
from vadsim.studies.design import (
    PUBLISHED,
    RECOMMENDED,
    STUDIES,
    design_metrics,
    design_sweep,
    one_at_a_time,
)
from vadsim.studies.sweep import sweep

__all__ = ["Reproduction", "map_regime_counts", "reproduce", "scan_reasons", "thesis_maps"]

FLOWS = np.arange(200.0, 650.0 + 1e-9, 10.0)
"""The 7in flow sweep of chapter 4 (10 gal/min, the resolution of the published bands)."""

FIELD_TOL = 0.15
"""A field value counts as matched within this fraction, or within the dissertation's own
model's distance from it, whichever is larger."""

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
    rows += _parameter_rows(presets)
    rows += _regime_rows(sweeps)
    rows += _event_rows(sweeps, pdc)
    given = {lab: dict(maps[lab]) for lab in presets if maps and lab in maps}
    rows += _parametric_rows(sweeps, run_s, given)
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


# ------------------------------------------------------------------------------ the rows

def _row(id_: str, source: str, quantity: str, published: Any, unit: str,
         values: Mapping[str, Any], statuses: Mapping[str, str], tolerance: str = "",
         reason: str = "", scan_target: str | None = None) -> dict[str, Any]:
    row: dict[str, Any] = dict(id=id_, source=source, quantity=quantity, published=published,
                               unit=unit)
    for lab, v in values.items():
        row[lab] = v
        row[f"status_{lab}"] = statuses[lab]
    row.update(tolerance=tolerance, reason=reason, scan_target=scan_target)
    return row


def _parameter_rows(presets: Mapping[str, str]) -> list[dict[str, Any]]:
    rows = []
    published = table_2_1()
    for tool, values in published.items():
        for name, v in values.items():
            preset = {"7in": "7in-cde", "9.5in": "9.5in-pdc"}[tool]
            key = name
            if name == "m1_RC":
                preset, key = "7in-rc", "m1"
            got = float(get_preset(preset).params[key])
            vals = {lab: got for lab in presets}
            st = {lab: "input" if got == v else "missed" for lab in presets}
            rows.append(_row(f"parameters.csv:{name}:{tool}", "parameters.csv",
                             f"Table 2.1 {name}, {tool} tool", v, "", vals, st,
                             reason="" if got == v else "the preset changes Table 2.1"))
    return rows


def _regime_rows(sweeps: Mapping[str, Mapping[str, xr.Dataset]]) -> list[dict[str, Any]]:
    per = {lab: {r["target"]: r for r in band_scores(s["cde"])} for lab, s in sweeps.items()}
    rows = []
    for _, p in published_regimes().iterrows():
        target = f"regime {int(p.scenario)}"
        pub = (f"{p.flow_from_gpm:g}-{p.flow_to_gpm:g} ({p.f_from_hz:g}-{p.f_to_hz:g} Hz; "
               f"{p.surface1}, {p.surface2}, {p.surface3}, {p.surface4})")
        vals = {lab: per[lab][target]["value"] for lab in sweeps}
        st = {lab: "reproduced" if per[lab][target]["ok"] else "missed" for lab in sweeps}
        rows.append(_row(f"regimes_7in.csv:{int(p.scenario)}", "regimes_7in.csv",
                         f"regime {int(p.scenario)} band", pub, "gal/min", vals, st,
                         f"both edges within {REGIME_TOL_GPM:g} gal/min", scan_target=target))
    return rows


def _periodic(text: str) -> bool:
    """A published behaviour or a vadsim periodicity label, as periodic or not."""
    return text.startswith("period")  # "periodic ..." / "period-p" vs (quasi-/a-)periodic


def _event_sweep(sweeps: Mapping[str, Mapping[str, xr.Dataset]], pdc: xr.Dataset,
                 bit: str) -> dict[str, xr.Dataset]:
    if bit == "PDC":
        return {lab: pdc for lab in sweeps}
    return {lab: s["cde" if bit == "CDE" else "rc"] for lab, s in sweeps.items()}


def _event_rows(sweeps: Mapping[str, Mapping[str, xr.Dataset]], pdc: xr.Dataset
                ) -> list[dict[str, Any]]:
    rows = []
    for _, e in field_events().iterrows():
        by = _event_sweep(sweeps, pdc, e.bit)
        at = {lab: ds.sel(flow_gpm=e.flow_gpm) for lab, ds in by.items()}
        eid = f"field_events.csv:{e.tool}-{e.bit}-{int(e.event)}"
        name = f"{e.tool} {e.bit} event {int(e.event)} ({e.flow_gpm:g} gal/min)"
        f = {lab: round(float(a.f_exc_hz), 2) for lab, a in at.items()}
        rows.append(_row(f"{eid}:operating_point", "field_events.csv",
                         f"{name}: excitation (Hz) at its flow and WOB {e.wob_klbf:g} klbf",
                         e.f_exc_hz, "Hz", f,
                         {lab: "input" if abs(v - e.f_exc_hz) <= 0.06 else "missed"
                          for lab, v in f.items()}, "0.06 Hz (published to 0.1 Hz)"))
        peak = {lab: round(float(a.x1_peak_mean_g), 1) for lab, a in at.items()}
        rows.append(_row(f"{eid}:sim_peak_g", "field_events.csv", f"{name}: simulated peak",
                         e.sim_peak_g, "g", peak,
                         {lab: _within(v, e.sim_peak_g, PEAK_TOL) for lab, v in peak.items()},
                         f"{PEAK_TOL:.0%}", scan_target=_peak_target(e)))
        hz = {lab: round(float(a.x1_impact_hz), 1) for lab, a in at.items()}
        if np.isfinite(e.sim_impact_hz):
            st = {lab: _within(v, e.sim_impact_hz, PEAK_TOL) for lab, v in hz.items()}
            rows.append(_row(f"{eid}:sim_impact_hz", "field_events.csv",
                             f"{name}: simulated impact frequency", e.sim_impact_hz, "Hz", hz,
                             st, f"{PEAK_TOL:.0%}", _impact_reading(at, e, st)))
        if e.bit == "PDC" and any(_within(v, e.sim_peak_g, PEAK_TOL) == "missed"
                                  for v in peak.values()):
            rows[-2 if np.isfinite(e.sim_impact_hz) else -1]["reason"] = _neighbours(e)
        beh = {lab: str(a.periodicity.values) for lab, a in at.items()}
        rows.append(_row(f"{eid}:sim_behaviour", "field_events.csv",
                         f"{name}: simulated behaviour", e.sim_behaviour, "", beh,
                         {lab: "reproduced" if _periodic(v) == _periodic(e.sim_behaviour)
                          else "missed" for lab, v in beh.items()}, "periodic or not"))
        rows += _field_rows(eid, name, e, peak, hz, beh)
    return rows


def _impact_reading(at: Mapping[str, xr.Dataset], e: pd.Series, st: Mapping[str, str]
                    ) -> str:
    """Why an impact frequency misses when the impact face's own count matches: vadsim's x1
    count takes every major acceleration peak, the dissertation's the impacts."""
    if "missed" not in st.values():
        return ""
    face = {lab: float(a.z_impact * a.f_exc_hz) for lab, a in at.items()}
    if all(abs(v / e.sim_impact_hz - 1) <= PEAK_TOL for v in face.values()):
        return ("a reading that differs: the impact face's impacts per second are "
                + ", ".join(f"{lab} {v:.1f} Hz" for lab, v in face.items())
                + " (within tolerance); vadsim's x1 count also takes the other major peaks "
                "above half the typical impact level")
    return ""


def _neighbours(e: pd.Series) -> str:
    """The published values around an event, for a simulated peak the preset misses."""
    ev = field_events(e.tool, e.bit).sort_values("flow_gpm").reset_index(drop=True)
    k = int(ev.index[ev.event == e.event][0])
    near = ev.iloc[max(k - 1, 0):k + 2]
    return ("the 9.5in preset was calibrated on all 12 of these events; the dissertation's "
            "simulated peaks around this flow: "
            + ", ".join(f"{r.flow_gpm:g} gal/min {r.sim_peak_g:g} g" for _, r in near.iterrows())
            + f" (field here: {e.field_peak_g:g} g)")


def _within(value: float, published: float, tol: float) -> str:
    return "reproduced" if abs(value / published - 1) <= tol else "missed"


def _peak_target(e: pd.Series) -> str | None:
    return f"{e.bit} {e.flow_gpm:g} gal/min" if e.bit in ("CDE", "RC") else None


def _field_rows(eid: str, name: str, e: pd.Series, peak: Mapping[str, float],
                hz: Mapping[str, float], beh: Mapping[str, str]) -> list[dict[str, Any]]:
    """The field recordings' numbers: compared with the model as the dissertation compares
    its own (a field value is not a model output: its status says how close vadsim is)."""
    rows = []
    tol = max(FIELD_TOL, abs(e.sim_peak_g / e.field_peak_g - 1))
    rows.append(_row(f"{eid}:field_peak_g", "field_events.csv", f"{name}: field peak",
                     e.field_peak_g, "g", peak, {lab: "compared with field" for lab in peak},
                     f"{tol:.0%} (the dissertation's model: {e.sim_peak_g:g} g)",
                     _field_reason(peak, e.field_peak_g, tol)))
    if np.isfinite(e.field_impact_hz):
        rows.append(_row(f"{eid}:field_impact_hz", "field_events.csv",
                         f"{name}: field impact frequency", e.field_impact_hz, "Hz", hz,
                         {lab: "compared with field" for lab in hz}, f"{FIELD_TOL:.0%}",
                         _field_reason(hz, e.field_impact_hz, FIELD_TOL)))
    rows.append(_row(f"{eid}:field_behaviour", "field_events.csv", f"{name}: field behaviour",
                     e.field_behaviour, "", beh, {lab: "compared with field" for lab in beh},
                     "periodic or not",
                     "same class as the field" if all(_periodic(v) == _periodic(
                         e.field_behaviour) for v in beh.values()) else "differs from the field"))
    return rows


def _field_reason(values: Mapping[str, float], field_value: float, tol: float) -> str:
    parts = [f"{lab} {v / field_value - 1:+.0%}" for lab, v in values.items()]
    ok = all(abs(v / field_value - 1) <= tol for v in values.values())
    return ("within the tolerance of the field" if ok else "outside it") + ": " + ", ".join(parts)


# ------------------------------------------------------------------- chapter 5's numbers

Metrics = Mapping[str, Mapping[str, dict]]
"""design_metrics of each design sweep by sweep key (``cde``, ``force``...), then preset
label."""


def _parametric_rows(sweeps: Mapping[str, Mapping[str, xr.Dataset]], run_s: float,
                     maps: Mapping[str, Mapping[str, xr.Dataset]]) -> list[dict[str, Any]]:
    m: Metrics = {key: {lab: design_metrics(s[key]) for lab, s in sweeps.items()}
                  for key in ("cde", "force", "gap", "recommended", "spring_lo", "spring_hi")}
    base = m["cde"]
    rows = []
    for key, target in (("force", "force_j"), ("gap", "gap_j"), ("recommended", "recommended_j")):
        ratio = {lab: round(m[key][lab]["j_max"] / base[lab]["j_max"] - 1, 3) for lab in sweeps}
        pub = DESIGN_TARGETS[target][2]
        rows.append(_row(f"parametric.csv:{key}:j_ratio", "parametric.csv",
                         f"max J* change, {key} design", pub, "ratio", ratio,
                         {lab: "reproduced" if abs(v - pub) <= 0.10 else "missed"
                          for lab, v in ratio.items()}, "0.10", scan_target=target))
    rec = m["recommended"]
    rng = {lab: round(rec[lab]["range_width_gpm"] / base[lab]["range_width_gpm"] - 1, 3)
           if base[lab]["range_width_gpm"] > 0 else math.nan for lab in sweeps}
    pub = PUBLISHED["recommended_range_ratio"]
    rows.append(_row("parametric.csv:recommended:range_ratio", "parametric.csv",
                     "operating range change, recommended design", pub, "ratio", rng,
                     {lab: "reproduced" if abs(v - pub) <= 0.25 else "missed"
                      for lab, v in rng.items()}, "0.25", scan_target="recommended_range"))
    for which, metrics, lo, hi in (
            ("original", base, PUBLISHED["original_range_from_gpm"],
             PUBLISHED["original_range_to_gpm"]),
            ("recommended", rec, 300.0, 390.0)):
        vals = {lab: f"{mm['range_from_gpm']:g}-{mm['range_to_gpm']:g}" for lab, mm in
                metrics.items()}
        rows.append(_row(f"parametric.csv:recommended:range_{which}", "parametric.csv",
                         f"operating range (J* >= 90 % of max), {which} design",
                         f"{lo:g}-{hi:g}", "gal/min", vals,
                         {lab: "reproduced" if max(abs(mm["range_from_gpm"] - lo),
                                                   abs(mm["range_to_gpm"] - hi)) <= 10
                          else "missed" for lab, mm in metrics.items()}, "10 gal/min",
                         scan_target="recommended_range"))
    rows += _force_edge_rows(m)
    rows += _prose_rows(m, run_s, maps)
    return rows


def _force_edge_rows(m: Metrics) -> list[dict[str, Any]]:
    rows = []
    for which, key, pub in (("nominal Fo", "cde", PUBLISHED["force_regime1_edge_hz_from"]),
                            ("Fo 534.17 N/kg", "force", PUBLISHED["force_regime1_edge_hz_to"])):
        vals = {lab: round(mm["regime1_edge_hz"], 1) for lab, mm in m[key].items()}
        rows.append(_row(f"parametric.csv:force:edge_{which.split()[0].lower()}",
                         "parametric.csv", f"regime 1 upper edge, {which}", pub, "Hz", vals,
                         {lab: "reproduced" if abs(v - pub) <= 1.1 else "missed"
                          for lab, v in vals.items()}, "1.1 Hz (10 gal/min)",
                         scan_target="regime 1" if which == "nominal Fo" else "force_j"))
    return rows


def _prose_rows(m: Metrics, run_s: float, maps: Mapping[str, Mapping[str, xr.Dataset]]
                ) -> list[dict[str, Any]]:
    """parametric.csv's numbers in prose: the study ranges (inputs), the findings vadsim can
    measure from its sweeps, J* in kN (not comparable), the maps and the solver."""
    base = m["cde"]
    labs = list(base)
    rows = []
    for study in STUDIES.values():
        rows.append(_row(f"parametric.csv:{study.name}:range", "parametric.csv",
                         f"{study.name} study: {study.parameter} from-to-step",
                         f"{study.lo:g}-{study.hi:g} step {study.step:g}", "",
                         {lab: f"{study.lo:g}-{study.hi:g}" for lab in labs},
                         {lab: "input" for lab in labs}))
    lo, hi = m["spring_lo"], m["spring_hi"]
    ks = {lab: round(hi[lab]["j_max"] / lo[lab]["j_max"] - 1, 3) for lab in labs}
    rows.append(_row("parametric.csv:spring:peak_j", "parametric.csv",
                     "spring study: peak J* hardly changes (kS 39.37 -> 787.4)", "hardly",
                     "ratio", ks, {lab: "reproduced" if abs(v) <= SPRING_J_TOL else "missed"
                                   for lab, v in ks.items()}, f"|change| <= {SPRING_J_TOL:g}",
                     scan_target="spring_j"))
    gap = m["gap"]
    edge = {lab: f"{base[lab]['regime1_edge_gpm']:g} -> {gap[lab]['regime1_edge_gpm']:g}"
            for lab in labs}
    rows.append(_row("parametric.csv:gap:regime1", "parametric.csv",
                     "gap study: regime 1 extends to higher flow as the gap grows (x1.5)",
                     "extends", "gal/min", edge,
                     {lab: "reproduced" if gap[lab]["regime1_edge_gpm"]
                      > base[lab]["regime1_edge_gpm"] else "missed" for lab in labs},
                     "edge moves up",
                     "MODEL.md: a larger gap narrows regime 1 in every reading of the model "
                     "tried (spring end, anvil, housing, drag, contact laws, continuation)"))
    best = {lab: round(gap[lab]["f_at_max_hz"], 1) for lab in labs}
    rows.append(_row("parametric.csv:gap:best_hz", "parametric.csv",
                     "gap study: best J* at 30-34 Hz (gap x1.5)", "30-34", "Hz", best,
                     {lab: "reproduced" if 29.0 <= v <= 35.0 else "missed"
                      for lab, v in best.items()}, "1 Hz", scan_target="gap_j"))
    rows += _kn_rows(m)
    rows += _fixed_rows(labs, run_s)
    rows += _map_rows(labs, maps)
    return rows


def _kn_rows(m: Metrics) -> list[dict[str, Any]]:
    base = m["cde"]
    labs = list(base)
    wob_kn = 4.0 * 4.4482216152605
    reason = (f"J* in kN is J* (N/kg) times the reference mass m*, which the dissertation does "
              f"not publish; and the mean force through the bit equals the WOB ({wob_kn:.1f} "
              "kN at 4 klbf), which J* cannot exceed on average: its kN values are compared "
              "as ratios (rows above)")
    rows = []
    for key, text, pub in (("spring", "spring study: J* in regime 1", "5-20"),
                           ("gap", "gap study: max J*, original -> x1.5", "20 -> 22.8"),
                           ("force", "force study: max J*, original -> Fo x1.78",
                            "20 -> 31.2"),
                           ("recommended", "recommended design: max J*, original -> it",
                            "20 -> 37")):
        other = m["spring_hi" if key == "spring" else key]
        vals = {lab: f"{base[lab]['j_max']:.1f} -> {other[lab]['j_max']:.1f} N/kg"
                for lab in labs}
        rows.append(_row(f"parametric.csv:{key}:kN", "parametric.csv", text, pub, "kN", vals,
                         {lab: "not comparable" for lab in labs}, "", reason))
    return rows


def _fixed_rows(labs: list[str], run_s: float) -> list[dict[str, Any]]:
    """Numbers about the method, not the model's output."""
    rows = []
    maps = parametric_rows()["maps"]
    for id_, text, pub, value, status, reason in (
            ("maps:axis", "maps: excitation axis from-to-step (Hz)",
             f"{maps['from']}-{maps['to']} step {maps['step']}", "21.3-69.3 step 0.5",
             "input", "vadsim.studies.design.thesis_flows"),
            ("maps:cycles", "every run: 400 cycles, the last 200 analysed", "400/200",
             "400/200", "input", "RunSettings defaults"),
            ("solver:ode23t", "one run of the workflow in Simulink ode23t (s)", "48",
             f"{run_s:.3f}", "not a model output",
             "vadsim's time for the same run (400 cycles, 200 gal/min), measured by this report"),
            ("solver:ode15s", "the same with ode15s (s)", "121-126", f"{run_s:.3f}",
             "not a model output", "as above")):
        rows.append(_row(f"parametric.csv:{id_}", "parametric.csv", text, pub, "",
                         {lab: value for lab in labs}, {lab: status for lab in labs},
                         reason=reason))
    return rows


def map_regime_counts(ds: xr.Dataset, table_4_2: bool = True) -> dict[int, int]:
    """Points of a map per scenario, the runs that failed left out: Table 4.2's six (1-6),
    or with ``table_4_2=False`` every code present (0: no impacts, 7: spring impacts only)."""
    sc = np.asarray(ds.scenario.values, dtype=float).ravel()
    if "error" in ds:
        sc = sc[np.asarray(ds.error.values).ravel() == ""]
    codes = range(1, 7) if table_4_2 else np.unique(sc[np.isfinite(sc)])
    return {int(k): int(np.sum(sc == k)) for k in codes if np.any(sc == k)}


def _map_axis(ds: xr.Dataset) -> str:
    param = _param(ds)
    v = ds[param].values
    return (f"{param} {v.min():g}-{v.max():g} in {v.size} values x {ds.flow_gpm.size} flows, "
            f"{ds.scenario.size:,} runs")


def _map_rows(labs: list[str], maps: Mapping[str, Mapping[str, xr.Dataset]]
              ) -> list[dict[str, Any]]:
    """The regime counts of chapter 5's maps: measured where ``maps`` has the map."""
    def measured(study: str) -> bool:
        return all(lab in maps and study in maps[lab] for lab in labs)

    rows = []
    if measured("gap"):
        counts = {lab: map_regime_counts(maps[lab]["gap"]) for lab in labs}
        vals = {lab: f"{c.get(6, 0)} of {sum(c.values()):,}" for lab, c in counts.items()}
        st = {lab: "reproduced" if 0 < c.get(6, 0) <= 0.005 * sum(c.values()) else "missed"
              for lab, c in counts.items()}
        reason = ("measured on the gap map (" + "; ".join(
            f"{lab}: {_map_axis(maps[lab]['gap'])}" for lab in labs) + ")")
        rows.append(_row("parametric.csv:maps:regime6", "parametric.csv",
                         "gap study: regime 6 in 4 of 7826 map points", "4 of 7826", "points",
                         vals, st, "present and rare (at most 0.5 % of the points)",
                         reason if "missed" in st.values() else ""))
    else:
        rows.append(_row("parametric.csv:maps:regime6", "parametric.csv",
                         "gap study: regime 6 in 4 of 7826 map points", "4 of 7826", "",
                         {lab: "" for lab in labs}, {lab: "not measured" for lab in labs},
                         reason="needs the thesis-resolution gap map: vadsim thesis --maps DIR "
                         "(about 17,500 runs per preset)"))
    if measured("gap") and measured("spring"):
        n = {lab: (len(map_regime_counts(maps[lab]["spring"])),
                   len(map_regime_counts(maps[lab]["gap"]))) for lab in labs}
        vals = {lab: f"{a}; {b}" for lab, (a, b) in n.items()}
        st = {lab: "reproduced" if v == (5, 6) else "missed" for lab, v in n.items()}
        detail = "; ".join(
            f"{lab}: spring {_counts_text(maps[lab]['spring'])}, gap "
            f"{_counts_text(maps[lab]['gap'])}" for lab in labs)
        why = [_count_reason(lab, study, maps[lab][study], want)
               for lab in labs for study, want in (("spring", 5), ("gap", 6))]
        rows.append(_row("parametric.csv:maps:regimes", "parametric.csv",
                         "spring and gap studies: five and six regimes in their maps", "5; 6",
                         "regimes", vals, st, "the same number of regimes in each map",
                         "; ".join([w for w in why if w] + [f"points per regime: {detail}"])))
    else:
        rows.append(_row("parametric.csv:maps:regimes", "parametric.csv",
                         "spring and gap studies: five and six regimes in their maps", "5; 6",
                         "", {lab: "" for lab in labs}, {lab: "not measured" for lab in labs},
                         reason="needs the spring and gap maps: vadsim thesis --maps DIR"))
    return rows


def _count_reason(lab: str, study: str, ds: xr.Dataset, published: int) -> str:
    """Why a map's number of regimes differs from the published one ("" if it does not)."""
    counts = map_regime_counts(ds)
    if len(counts) == published:
        return ""
    if len(counts) > published:
        rare = sorted(counts, key=lambda k: counts[k])[:len(counts) - published]
        return (f"{lab}'s {study} map has {len(counts)} regimes, the rarest "
                + ", ".join(f"regime {k} in {counts[k]} of {sum(counts.values()):,} points"
                            for k in rare)
                + " (isolated points of an intermittent regime, which move with the last "
                "bits of a run)")
    steps = f" at {ds[_param(ds)].size} values, not the published 948" if study == "spring" else ""
    return (f"{lab}'s {study} map has {len(counts)} regimes{steps}: a regime of a few points "
            "can fall between its grid points")


def _param(ds: xr.Dataset) -> str:
    return next(str(d) for d in ds.scenario.dims if d != "flow_gpm")


def _counts_text(ds: xr.Dataset) -> str:
    outside = {0: "no impacts", 7: "spring impacts only"}
    return ", ".join(f"{k}: {v}" if k not in outside else f"{k} ({outside[k]}, not one of Table "
                     f"4.2's six): {v}" for k, v in map_regime_counts(ds, False).items())


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
