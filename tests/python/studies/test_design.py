"""Design-study and thesis-comparison logic on constructed data (no long simulations)."""

import math

import numpy as np
import pytest
import xarray as xr
from vadsim.studies import design, thesis


def _sweep(flows, scenario, j, m_ref=10.0):
    flows = np.asarray(flows, float)
    ds = xr.Dataset(coords={"flow_gpm": flows, "f_exc_hz": ("flow_gpm", 0.67 * flows / 2 / np.pi)})
    ds["scenario"] = ("flow_gpm", np.asarray(scenario, np.int64))
    ds["j_pos"] = ("flow_gpm", np.asarray(j, float))
    ds.attrs["m_ref_kg"] = m_ref
    return ds


def test_operating_range_is_the_contiguous_band_around_the_maximum():
    q = np.arange(200, 300, 10.0)
    j = np.array([50, 85, 91, 95, 100, 92, 80, 95, 99, 10], float)  # 95, 99 not contiguous
    assert design.operating_range(q, j) == (220.0, 250.0)
    assert design.operating_range(q, j, frac=0.5) == (200.0, 280.0)


def test_operating_range_breaks_on_nan_and_handles_all_nan():
    q = np.arange(5.0)
    assert design.operating_range(q, [1, 1, np.nan, 1, 0.5]) == (0.0, 1.0)
    lo, hi = design.operating_range(q, [np.nan] * 5)
    assert math.isnan(lo) and math.isnan(hi)
    with pytest.raises(ValueError):
        design.operating_range([1, 2], [1.0])


def test_design_metrics_of_a_constructed_sweep():
    ds = _sweep([200, 210, 220, 230, 240], [1, 1, 1, 3, 5], [10, 19, 20, 18, 5], m_ref=50.0)
    m = design.design_metrics(ds)
    assert m["j_max"] == 20 and m["j_max_kN"] == pytest.approx(1.0)
    assert (m["range_from_gpm"], m["range_to_gpm"], m["range_width_gpm"]) == (210, 230, 20)
    assert m["regime1_edge_gpm"] == 220
    assert m["regime1_edge_hz"] == pytest.approx(0.67 * 220 / 2 / np.pi)


def test_studies_use_the_published_ranges():
    s = design.STUDIES["force"]
    v = s.values()
    assert v[0] == pytest.approx(133.54) and v[-1] == pytest.approx(534.17)
    assert len(v) == round((534.17 - 133.54) / 6.677) + 1  # the published step
    assert design.STUDIES["spring"].values(3)[-1] == pytest.approx(787_400.0)  # kN -> N
    assert design.STUDIES["gap"].values(2).tolist() == pytest.approx([0.85, 1.5])
    with pytest.raises(ValueError, match="unknown study"):
        design.one_at_a_time("springs")


def test_thesis_flow_axis_spans_the_published_frequencies():
    q = design.thesis_flows("7in-cde")
    f = 0.67 * q / (2 * np.pi)
    assert len(q) == 97
    assert f[0] == pytest.approx(21.3) and f[-1] == pytest.approx(69.3)


def test_regime_intervals_and_comparison_on_a_constructed_sweep():
    q = np.arange(200, 660, 10.0)
    sc = np.where(q <= 310, 1, np.where(q <= 330, 2, np.where(q <= 420, 3,
                  np.where(q <= 500, 4, 5))))
    ds = _sweep(q, sc, np.ones_like(q))
    runs = thesis.regime_intervals(ds)
    assert runs.scenario.tolist() == [1, 2, 3, 4, 5]
    table = thesis.compare_regimes(ds)
    assert table.ok.all() and (table.d_from == 0).all() and (table.d_to == 0).all()
    # Shift the 3/4 boundary by 30 gal/min: both sides report it, the rest stays exact.
    sc2 = sc.copy()
    sc2[(q > 420) & (q <= 450)] = 3
    table2 = thesis.compare_regimes(_sweep(q, sc2, np.ones_like(q)))
    assert table2.set_index("scenario").loc[3, "d_to"] == 30
    assert table2.set_index("scenario").loc[4, "d_from"] == 30
    assert table2.ok.tolist() == [True, True, False, False, True]


def test_design_overrides_realise_the_gap_three_ways():
    from vadsim.model.presets import get_preset
    from vadsim.studies.sweep import design_overrides

    base = dict(get_preset("7in-cde").params)
    gap0 = base["L3"] - (base["L2"] + base["LS"] + base["LI"] + base["LOn"])
    for via, name in (("spring", "LS"), ("anvil", "L2"), ("housing", "L3")):
        ov = design_overrides(base, {"gap_ratio": 1.5}, via)
        new = {**base, **ov}
        gap = new["L3"] - (new["L2"] + new["LS"] + new["LI"] + new["LOn"])
        assert list(ov) == [name]
        assert gap == pytest.approx(1.5 * gap0)
    with pytest.raises(ValueError, match="gap_via"):
        design_overrides(base, {"gap_ratio": 1.2}, "bit")
