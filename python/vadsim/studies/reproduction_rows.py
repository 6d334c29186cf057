"""The rows of the reproduction table: each published number beside vadsim's value.

Why this module exists: :func:`vadsim.studies.reproduction.reproduce` runs what the
dissertation's numbers need; this module reads each number from the files of ``data/thesis``
and sets vadsim's value for each preset beside it, with the status (one of
:data:`vadsim.studies.reproduction.STATUS`), the tolerance and, where it is known here, the
reason of a miss. One function per published file: :func:`parameter_rows` (Table 2.1),
:func:`regime_rows` (the regime bands of chapter 4), :func:`event_rows` (the field events,
simulated and recorded) and :func:`parametric_study_rows` (chapter 5: the design studies,
the numbers in its prose and the regime counts of its maps, :func:`map_regime_counts`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from vadsim.data import field_events, parametric_rows, published_regimes, table_2_1
from vadsim.model.presets import get_preset
from vadsim.studies.constants import (
    DESIGN_TARGETS,
    PEAK_TOL,
    REGIME_TOL_GPM,
    SPRING_J_TOL,
    band_scores,
)
from vadsim.studies.design import PUBLISHED, STUDIES, design_metrics

__all__ = ["event_rows", "map_regime_counts", "parameter_rows", "parametric_study_rows",
           "regime_rows"]

FIELD_TOL = 0.15
"""A field value counts as matched within this fraction, or within the dissertation's own
model's distance from it, whichever is larger."""


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


def parameter_rows(presets: Mapping[str, str]) -> list[dict[str, Any]]:
    """Table 2.1's parameters (``parameters.csv``): inputs, each row saying whether the presets
    use the published value.

    Parameters
    ----------
    presets
        ``{label: preset name}`` of :func:`~vadsim.studies.reproduction.reproduce`; only the
        labels are used (every preset is checked against the tool's shipped preset).

    Returns
    -------
    list of dict
        One row per parameter and tool, in the columns of
        :attr:`~vadsim.studies.reproduction.Reproduction.table` plus ``scan_target``.
    """
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


def regime_rows(sweeps: Mapping[str, Mapping[str, xr.Dataset]]) -> list[dict[str, Any]]:
    """The regime bands of chapter 4 (``regimes_7in.csv``) against each preset's CDE sweep.

    Parameters
    ----------
    sweeps
        ``{label: {name: dataset}}``, the sweeps of
        :func:`~vadsim.studies.reproduction.reproduce` (``"cde"`` is read).

    Returns
    -------
    list of dict
        One row per regime; its ``scan_target`` names the band in the constants scan.
    """
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


def event_rows(sweeps: Mapping[str, Mapping[str, xr.Dataset]], pdc: xr.Dataset
               ) -> list[dict[str, Any]]:
    """The field events (``field_events.csv``): operating point, the dissertation's simulated
    peak, impact frequency and behaviour, and the recorded ones, at each event's flow.

    Parameters
    ----------
    sweeps
        ``{label: {name: dataset}}``, the sweeps of
        :func:`~vadsim.studies.reproduction.reproduce` (``"cde"`` and ``"rc"`` are read).
    pdc
        The 9.5in PDC sweep at its events' flows (one, shared by every label).

    Returns
    -------
    list of dict
        Several rows per event; a miss of a 9.5in peak says the published values around it.
    """
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


def parametric_study_rows(sweeps: Mapping[str, Mapping[str, xr.Dataset]], run_s: float,
                          maps: Mapping[str, Mapping[str, xr.Dataset]]
                          ) -> list[dict[str, Any]]:
    """Chapter 5's numbers (``parametric.csv``): the J* changes and operating ranges of the
    design studies, the numbers in its prose, J* in kN, the method's own numbers and the
    regime counts of its maps.

    Parameters
    ----------
    sweeps
        ``{label: {name: dataset}}``, the sweeps of
        :func:`~vadsim.studies.reproduction.reproduce` (the CDE sweep and the design sweeps).
    run_s
        vadsim's wall time of the dissertation's timed run (s), set beside Simulink's.
    maps
        ``{label: {"gap": map, "spring": map}}``
        (:func:`~vadsim.studies.reproduction.thesis_maps`); a label without them gets "not
        measured" map rows.

    Returns
    -------
    list of dict
        The rows, in the columns of :func:`parameter_rows`' rows.
    """
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
