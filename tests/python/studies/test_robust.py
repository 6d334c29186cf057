"""Designs over the plausible region of the constants the published numbers cannot fix."""

from __future__ import annotations

import numpy as np
import pytest
from vadsim.model.presets import get_preset
from vadsim.studies.design import RECOMMENDED, design_metrics
from vadsim.studies.robust import (
    GAP_SPREAD,
    THETA0_SPREAD,
    constants_sample,
    robust_compare,
    robust_metrics,
)
from vadsim.studies.sweep import sweep

FLOWS = np.array([250.0, 300.0, 400.0, 550.0])
TINY = dict(cycles=40, analyse_cycles=20, workers=2)


def test_the_sample_spans_the_stated_region_around_the_preset():
    t0 = get_preset("7in-cde").theta0
    five = constants_sample("7in-cde", 5)
    assert five[0] == {"theta0": t0, "gap_ratio": 1.0}
    assert max(p["theta0"] for p in five) - min(p["theta0"] for p in five) == pytest.approx(
        2 * THETA0_SPREAD)
    assert {p["gap_ratio"] for p in five} == {1.0, 1.0 - GAP_SPREAD, 1.0 + GAP_SPREAD}
    assert len(constants_sample("7in-cde", 9)) == 9
    with pytest.raises(ValueError, match="must be 1, 5 or 9"):
        constants_sample("7in-cde", 4)


def test_the_original_at_the_preset_constants_is_the_preset_itself():
    one = robust_metrics({}, "7in-cde", constants_sample("7in-cde", 1), FLOWS, **TINY)
    plain = design_metrics(sweep("7in-cde", FLOWS, progress=False, **TINY))
    assert one.j_max.iloc[0] == plain["j_max"]
    assert one.range_width_gpm.iloc[0] == plain["range_width_gpm"]
    assert one.j_ratio.iloc[0] == 0.0


def test_a_design_is_summarised_by_its_mean_and_worst_case_over_the_sample():
    res = robust_compare({"recommended": RECOMMENDED}, "7in-cde", constants_sample("7in-cde", 5),
                         FLOWS, **TINY)
    t = res.table
    assert list(t.index) == ["original", "recommended"]
    assert t.loc["original", "j_ratio_mean"] == 0.0
    rec = res.per_point["recommended"]
    assert len(rec) == 5 and t.loc["recommended", "j_max_worst"] == rec.j_max.min()
    assert t.loc["recommended", "j_max_worst"] <= t.loc["recommended", "j_max_mean"]
    # kN only with the m* it assumes
    assert t.loc["recommended", "j_max_mean_kN"] == pytest.approx(
        t.loc["recommended", "j_max_mean"] * t.loc["recommended", "m_ref_kg"] / 1000.0)
    # the design differs from the original at every point (Fo x1.78 moves J*)
    assert (rec.j_max != rec.j_max0).all()


def test_a_study_over_the_sample_has_one_row_per_value_and_none_at_its_nominal():
    from vadsim.studies.robust import robust_study

    t = robust_study("force", "7in-cde", 2, constants_sample("7in-cde", 5), FLOWS, **TINY)
    assert list(t.index) == pytest.approx([133.54, 534.17])
    assert (t.j_max_worst <= t.j_max_mean).all()
    # a larger force gives more J* at every point of the sample (Fo x4 from the low end)
    assert t.j_max_worst.iloc[1] > t.j_max_mean.iloc[0]
    with pytest.raises(ValueError, match="unknown study"):
        robust_study("mass", "7in-cde")
