"""Adaptive maps: refinement only near boundaries, points not run filled from agreeing cells,
the same results where points were run, and a store that resumes level by level."""

from __future__ import annotations

import numpy as np
import pytest
import vadsim.studies.sweep as vsweep
from vadsim.studies.refine import CONTINUOUS, Refinement, fill, lattice, next_points
from vadsim.studies.sweep import sweep


def _adaptive_on(truth: dict[str, np.ndarray], rule: Refinement):
    """What sweep(refine=rule) does, with a known field instead of runs."""
    shape = truth["scenario"].shape
    run = np.zeros(shape, dtype=bool)
    values = {k: np.full(shape, np.nan) for k in truth}
    stride = rule.coarse
    points = [(int(i), int(j)) for i in lattice(shape[0], stride)
              for j in lattice(shape[1], stride)]
    while points:
        for p in points:
            run[p] = True
            for k in truth:
                values[k][p] = truth[k][p]
        stride, points = next_points(shape, stride, values, run, rule)
    fill(shape, rule, values, run)
    return values, run


def _near_boundary(labels):
    out = np.zeros(labels.shape, dtype=bool)
    for i in range(labels.shape[0]):
        for j in range(labels.shape[1]):
            nb = labels[max(0, i - 1):i + 2, max(0, j - 1):j + 2]
            out[i, j] = np.any(nb != labels[i, j])
    return out


def test_lattice_keeps_the_last_point_and_nests():
    assert lattice(10, 4).tolist() == [0, 4, 8, 9]
    assert lattice(1, 8).tolist() == [0]
    assert set(lattice(85, 8)) <= set(lattice(85, 4)) <= set(lattice(85, 2))
    assert lattice(85, 1).tolist() == list(range(85))


def test_one_regime_with_a_linear_j_is_run_on_the_coarse_lattice_and_filled_exactly():
    i, j = np.mgrid[0:41, 0:57]
    truth = {"scenario": np.ones(i.shape), "j_pos": 100.0 + 2.0 * i + 0.5 * j}
    values, run = _adaptive_on(truth, Refinement(coarse=8, j_tol=None, range_edge=False))
    assert run.sum() == lattice(41, 8).size * lattice(57, 8).size
    np.testing.assert_allclose(values["j_pos"], truth["j_pos"], rtol=1e-12)
    assert np.all(values["scenario"] == 1)


def test_a_regime_island_is_refined_at_its_boundary_only_and_its_labels_are_kept():
    i, j = np.mgrid[0:64, 0:96]
    island = (i - 30.0) ** 2 / 15 ** 2 + (j - 50.0) ** 2 / 25 ** 2 < 1
    truth = {"scenario": np.where(island, 3.0, 1.0), "j_pos": np.where(island, 50.0, 120.0)}
    values, run = _adaptive_on(truth, Refinement(coarse=8, j_tol=None, range_edge=False))
    wrong = values["scenario"] != truth["scenario"]
    assert not np.any(wrong & ~_near_boundary(truth["scenario"]))
    assert np.all(values["scenario"][run] == truth["scenario"][run])
    assert run.mean() < 0.5  # the flat regions are not run
    # a point far inside either regime is never run (it lies in an agreeing coarse cell)
    assert not run[30, 50] or (30 % 8 == 0 and 50 % 8 == 0)


def test_j_differences_above_the_tolerance_refine():
    i, j = np.mgrid[0:33, 0:33]
    truth = {"scenario": np.ones(i.shape), "j_pos": np.where(j < 20, 10.0, 100.0 + 0 * i)}
    _, loose = _adaptive_on(truth, Refinement(coarse=8, j_tol=None, range_edge=False))
    values, tight = _adaptive_on(truth, Refinement(coarse=8, j_tol=0.1, range_edge=False))
    assert tight.sum() > loose.sum()
    assert np.all(tight[:, 19:21])  # the jump is run on both sides
    assert np.all(values["j_pos"][:, :20] == 10.0) and np.all(values["j_pos"][:, 20:] == 100.0)


def test_refinement_options_are_checked():
    with pytest.raises(ValueError, match="coarse = 6"):
        Refinement(coarse=6)
    with pytest.raises(ValueError, match="j_tol"):
        Refinement(j_tol=0.0)
    with pytest.raises(ValueError, match="halo"):
        Refinement(halo=-1)
    with pytest.raises(ValueError, match="independent"):
        sweep("7in-cde", [200, 300], {"gap_ratio": [1.0, 1.2]}, refine=True,
              mode="continuation", progress=False)
    with pytest.raises(ValueError, match="refine = 3"):
        sweep("7in-cde", [200, 300], refine=3, progress=False)


SMALL = dict(cycles=60, analyse_cycles=30, detail="map", progress=False, workers=2)
FLOWS = np.linspace(200, 650, 17)
AXES = {"gap_ratio": np.linspace(0.85, 1.5, 9)}


@pytest.fixture(scope="module")
def full_map():
    return sweep("7in-cde", FLOWS, AXES, **SMALL)


def test_an_adaptive_map_runs_the_same_points_the_same_and_fills_the_rest(full_map, tmp_path):
    ad = sweep("7in-cde", FLOWS, AXES, refine=Refinement(coarse=4, j_tol=None), **SMALL)
    ran = ad["simulated"].values
    assert ran.dtype == bool and 0 < ran.sum() < ran.size
    assert 0.0 < ad.attrs["simulated_fraction"] < 1.0
    for name in ("scenario", "j_pos", "z_impact", "steps"):
        np.testing.assert_array_equal(ad[name].values[ran], full_map[name].values[ran])
    f = full_map["scenario"].values
    wrong = ad["scenario"].values != f
    assert not np.any(wrong & ~_near_boundary(f))
    assert set(ad.data_vars) == set(full_map.data_vars) | {"simulated"}
    assert ad["j_pos"].attrs["units"] == "N/kg"
    # interpolated features are finite wherever every run was
    for name in CONTINUOUS:
        if np.all(np.isfinite(full_map[name].values)):
            assert np.all(np.isfinite(ad[name].values)), name


def test_an_adaptive_map_resumes_from_its_store_level_by_level(tmp_path, monkeypatch):
    rule = Refinement(coarse=4, j_tol=None)
    first = sweep("7in-cde", FLOWS, AXES, refine=rule, store=tmp_path / "s", **SMALL)
    monkeypatch.setattr(vsweep, "run_point", lambda spec: pytest.fail("computed again"))
    again = sweep("7in-cde", FLOWS, AXES, refine=rule, store=tmp_path / "s", **SMALL)
    for name in ("scenario", "j_pos", "simulated"):
        np.testing.assert_array_equal(again[name].values, first[name].values)
    # a full map's store is another grid: not shared with the adaptive one
    with pytest.raises(ValueError, match="grid"):
        sweep("7in-cde", FLOWS, AXES, store=tmp_path / "s", **SMALL)
