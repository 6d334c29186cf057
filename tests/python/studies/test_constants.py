"""The scan of the constants the published numbers cannot fix (theta0, the gap)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr
from vadsim.data import field_events, published_regimes
from vadsim.studies.constants import (
    PEAK_TOL,
    REGIME_TOL_GPM,
    best_constants,
    scan_constants,
    score_targets,
)
from vadsim.studies.sweep import sweep

FLOWS = np.arange(200.0, 650.0 + 1e-9, 10.0)


def _published_scenarios(shift_gpm: float = 0.0) -> np.ndarray:
    """The scenario of every flow of FLOWS as section 4.1 publishes it, the edge between
    regimes 1 and 2 moved by ``shift_gpm``."""
    out = np.zeros(FLOWS.size, int)
    for _, p in published_regimes().iterrows():
        lo, hi = p.flow_from_gpm, p.flow_to_gpm
        if p.scenario == 1:
            hi += shift_gpm
        if p.scenario == 2:
            lo += shift_gpm
        out[(FLOWS >= lo) & (FLOWS <= hi)] = p.scenario
    return out


def _grid(scenarios: list[np.ndarray], peaks: np.ndarray) -> xr.Dataset:
    """A (theta0, gap_ratio, flow) dataset of one gap ratio and one theta0 per scenario row."""
    sc = np.array(scenarios)[:, None, :]
    pk = np.broadcast_to(peaks, sc.shape)
    return xr.Dataset(
        {"scenario": (("theta0", "gap_ratio", "flow_gpm"), sc),
         "x1_peak_mean_g": (("theta0", "gap_ratio", "flow_gpm"), pk),
         "j_pos": (("theta0", "gap_ratio", "flow_gpm"), np.ones(sc.shape))},
        coords={"theta0": np.arange(len(scenarios), dtype=float), "gap_ratio": [1.0],
                "flow_gpm": FLOWS})


def test_bands_and_peaks_are_scored_against_the_published_numbers():
    ev = field_events("7in", "CDE")
    peaks = np.full(FLOWS.size, np.nan)
    for _, e in ev.iterrows():
        peaks[FLOWS == e.flow_gpm] = e.sim_peak_g
    peaks[FLOWS == 300.0] *= 1.0 + 2 * PEAK_TOL  # one peak off by twice its tolerance
    ds = _grid([_published_scenarios(0.0), _published_scenarios(20.0)], peaks)
    scores = score_targets(ds, xr.Dataset(), {}, tool="7in")
    exact = scores[scores.theta0 == 0.0].set_index("target")
    shifted = scores[scores.theta0 == 1.0].set_index("target")
    assert len(exact) == len(published_regimes()) + len(ev)  # each target once per point
    assert exact.loc[[f"regime {s}" for s in range(1, 6)], "ok"].all()
    assert (exact.loc[[f"regime {s}" for s in range(1, 6)], "error"] == 0).all()
    # the 1/2 edge 20 gal/min late: both bands miss by 20 (regime 2 then starts at 340 and
    # ends where regime 3 begins: it vanishes, so its error is infinite)
    assert shifted.loc["regime 1", "error"] == 20.0 > REGIME_TOL_GPM
    assert not shifted.loc["regime 1", "ok"]
    assert math.isinf(shifted.loc["regime 2", "error"])
    assert exact.loc["CDE 300 gal/min", "error"] == pytest.approx(2 * PEAK_TOL)
    assert not exact.loc["CDE 300 gal/min", "ok"]
    assert exact.loc["CDE 350 gal/min", "ok"]
    best = best_constants(scores)
    assert best["theta0"] == 0.0 and best["met"] == best["of"] - 1
    assert [m["target"] for m in best["missed"]] == ["CDE 300 gal/min"]


def test_the_spring_study_is_scored_as_the_change_of_max_j_across_ks():
    """Chapter 5: over kS 39.37-787.4 the peak J* "hardly changes" (|change| <= 15 %)."""
    from vadsim.studies.constants import SPRING_J_TOL

    base = _grid([_published_scenarios(0.0), _published_scenarios(0.0)], np.ones(FLOWS.size))
    designs = {name: base.copy() for name in ("force", "gap", "recommended", "spring_lo")}
    hi = base.copy()
    hi["j_pos"] = base.j_pos * xr.DataArray([1.10, 1.30], dims="theta0")  # +10 %; +30 %
    designs["spring_hi"] = hi
    scores = score_targets(base, xr.Dataset(), designs, tool="7in")
    spring = scores[scores.target == "spring_j"].set_index("theta0")
    assert list(spring.value) == [pytest.approx(0.10), pytest.approx(0.30)]
    assert list(spring.ok) == [True, False] and (spring.tolerance == SPRING_J_TOL).all()
    # a scan written before the spring ends were swept scores the other designs alone
    old = {k: v for k, v in designs.items() if not k.startswith("spring")}
    assert "spring_j" not in set(score_targets(base, xr.Dataset(), old).target)


def test_best_constants_breaks_ties_by_the_errors():
    rows = []
    for t, errs in ((0.0, (0.5, 2.0)), (1.0, (0.9, 0.9)), (2.0, (3.0, 4.0))):
        for k, e in enumerate(errs):
            rows.append(dict(theta0=t, gap_ratio=1.0, group="g", target=f"t{k}", value=e,
                             published=0.0, error=e, tolerance=1.0, ok=e <= 1.0))
    scores = pd.DataFrame(rows)
    best = best_constants(scores)
    assert (best["theta0"], best["met"], best["of"]) == (1.0, 2, 2)
    with pytest.raises(ValueError, match="no target"):
        best_constants(scores, groups=["nothing"])


def test_a_scan_point_is_the_preset_with_that_phase_and_gap():
    th, gaps, flows = [2.3, 2.6], [0.8, 1.0], [250.0, 400.0]
    scan = scan_constants("7in-cde", th, gaps, flows=flows, designs=False, cycles=40,
                          analyse_cycles=20, workers=2, progress=False)
    assert dict(scan.cde.sizes) == {"flow_gpm": 2, "theta0": 2, "gap_ratio": 2}
    assert list(scan.rc.flow_gpm.values) == list(field_events("7in", "RC").flow_gpm)
    # the nominal gap at theta0 = 2.6 is a plain sweep of the preset with theta0 = 2.6
    plain = sweep("7in-cde", flows, overrides={"theta0": 2.6}, cycles=40, analyse_cycles=20,
                  workers=2, progress=False)
    got = scan.cde.sel(theta0=2.6, gap_ratio=1.0)
    np.testing.assert_allclose(got.j_pos.values, plain.j_pos.values, rtol=1e-9)
    # ... and a smaller gap changes the runs (the scan really moves the spring's end)
    assert not np.allclose(scan.cde.sel(theta0=2.6, gap_ratio=0.8).j_pos.values,
                           plain.j_pos.values, rtol=1e-6)
    groups = set(scan.scores.group)
    assert groups == {"regime band", "CDE peak", "RC peak"}  # no design targets asked
    summary = scan.summary()
    assert len(summary) == 4 and summary["all"].is_monotonic_decreasing
    with pytest.raises(ValueError, match="gap_ratio"):
        scan_constants("7in-cde", th, [0.0], flows=flows, designs=False, progress=False)


def test_the_reproduction_lists_every_published_number_once_and_explains_every_miss(tmp_path):
    from vadsim.data import parametric_rows, table_2_1
    from vadsim.report.reproduction import write_reproduction_report
    from vadsim.studies.reproduction import STATUS, reproduce

    scores = scan_constants("7in-cde", [2.264, 2.553], [1.0], flows=FLOWS[::5], designs=False,
                            cycles=40, analyse_cycles=20, workers=2, progress=False).scores
    maps = {"reference": {"gap": _map("gap_ratio", [1, 2, 3, 4, 5], rare=6),
                          "spring": _map("kS", [1, 2, 3, 4, 5])}}
    rep = reproduce("7in-cde", None, scores, cycles=40, analyse_cycles=20, workers=2,
                    progress=False, maps=maps)
    t = rep.table
    counted = t.set_index("id").loc[["parametric.csv:maps:regime6",
                                     "parametric.csv:maps:regimes"]]
    assert list(counted.reference) == ["2 of 400", "5; 6"]
    assert (counted.status_reference == "reproduced").all()
    assert t.id.is_unique
    n_params = sum(len(v) for v in table_2_1().values())
    assert (t.source == "parameters.csv").sum() == n_params
    assert (t[t.source == "parameters.csv"].status_reference == "input").all()
    assert (t.source == "regimes_7in.csv").sum() == len(published_regimes())
    ev = field_events()
    per_event = 5 + ev.sim_impact_hz.notna() + ev.field_impact_hz.notna()  # + peaks, beh., op.
    assert (t.source == "field_events.csv").sum() == int(per_event.sum())
    for _, e in ev.iterrows():
        eid = f"field_events.csv:{e.tool}-{e.bit}-{int(e.event)}"
        assert {f"{eid}:{c}" for c in ("sim_peak_g", "field_peak_g", "sim_behaviour",
                                        "field_behaviour", "operating_point")} <= set(t.id)
    studies = {r.split(":")[1] for r in t[t.source == "parametric.csv"].id}
    assert studies == set(parametric_rows())  # every row of parametric.csv is covered
    assert set(t.status_reference) <= set(STATUS)
    missed = t[t.status_reference == "missed"]
    assert (missed.reason.str.len() > 0).all(), missed[["id", "reason"]]
    # a scanned miss says where in the scan it is met, or that it is met nowhere
    scanned = missed[missed.id.str.startswith("regimes_7in.csv")]
    assert scanned.reason.str.contains("scan points").all()
    path = write_reproduction_report(rep, tmp_path)
    text = path.read_text()
    assert "ok=False" not in text and "| regime 1 band" in text
    files = tmp_path / "reproduction"
    assert (files / "reproduction.csv").is_file() and (files / "peaks-reference.png").is_file()
    assert (files / "gap-map-reference.png").is_file()


def _map(param: str, regimes: list[int], rare: int | None = None) -> xr.Dataset:
    """A 20 x 20 map (param x flow) tiled with ``regimes``, plus two points of ``rare``."""
    values = np.linspace(1.0, 2.0, 20)
    flows = np.linspace(200.0, 650.0, 20)
    sc = np.array(regimes, dtype=float)[np.arange(400) % len(regimes)].reshape(20, 20)
    if rare is not None:
        sc[3, 7] = sc[11, 2] = rare
    dims = (param, "flow_gpm")
    return xr.Dataset({"scenario": (dims, sc), "j_pos": (dims, np.ones_like(sc)),
                       "error": (dims, np.full(sc.shape, ""))},
                      coords={param: values, "flow_gpm": flows})


def test_map_counts_name_what_the_maps_hold_and_why_a_count_misses(tmp_path):
    from vadsim.studies.reproduction import thesis_maps
    from vadsim.studies.reproduction_rows import _map_rows, map_regime_counts

    with pytest.raises(ValueError, match="spring_steps = 1 must be an integer >= 2"):
        thesis_maps("7in-cde", tmp_path, spring_steps=1)

    gap = _map("gap_ratio", [1, 3, 4, 5])
    gap["error"][0, 0] = "CVode failed"  # a failed run is not a point of any regime
    assert map_regime_counts(gap) == {1: 99, 3: 100, 4: 100, 5: 100}
    rows = {r["id"].split(":")[-1]: r for r in _map_rows(
        ["reference"], {"reference": {"gap": gap, "spring": _map("kS", [1, 2, 3])}})}
    assert rows["regime6"]["reference"] == "0 of 399"
    assert rows["regime6"]["status_reference"] == "missed"
    assert "gap_ratio 1-2 in 20 values x 20 flows" in rows["regime6"]["reason"]
    assert rows["regimes"]["reference"] == "3; 4"
    assert rows["regimes"]["status_reference"] == "missed"
    assert "spring 1: 134, 2: 133, 3: 133" in rows["regimes"]["reason"]
    assert "spring map has 3 regimes at 20 values, not the published 948" in (
        rows["regimes"]["reason"])
    extra = _map("kS", [1, 2, 3, 4, 5], rare=6)  # one regime more than published
    rows = {r["id"].split(":")[-1]: r for r in _map_rows(
        ["reference"], {"reference": {"gap": _map("gap_ratio", [1, 2, 3, 4, 5], rare=6),
                                      "spring": extra}})}
    assert rows["regimes"]["reference"] == "6; 6"
    assert "6 regimes, the rarest regime 6 in 2 of 400 points" in rows["regimes"]["reason"]
    # a code outside Table 4.2 (7: spring impacts only) is shown, not counted as a regime
    spring_only = _map("kS", [1, 2, 3, 4, 5], rare=7)
    assert set(map_regime_counts(spring_only)) == {1, 2, 3, 4, 5}
    assert map_regime_counts(spring_only, table_4_2=False)[7] == 2
    rows = {r["id"].split(":")[-1]: r for r in _map_rows(
        ["reference"], {"reference": {"gap": _map("gap_ratio", [1, 2, 3, 4, 5], rare=6),
                                      "spring": spring_only}})}
    assert rows["regimes"]["status_reference"] == "reproduced"
    assert "7 (spring impacts only, not one of Table 4.2's six): 2" in (
        rows["regimes"]["reason"])
    none = {r["id"].split(":")[-1]: r for r in _map_rows(["reference"], {})}
    assert none["regime6"]["status_reference"] == "not measured"
    assert "vadsim thesis --maps" in none["regimes"]["reason"]
