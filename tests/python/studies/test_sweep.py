"""Tests of vadsim.studies.sweep (python/vadsim/sweep.py): flow sweeps and 2-D maps.

Why these tests: a regime map is thousands of runs spread over threads, Dask workers and
interrupted sessions, so the things that can silently go wrong are bookkeeping, not physics:
a point landing in the wrong cell, a point lost or computed twice after a kill, a resumed or
distributed map that differs from a plain one, a NetCDF file that does not read back the same,
a continuation sweep that does not really continue. Each test below pins one of those down.

Runs are tiny (20 cycles, 10 analysed; a few flows and axis values): the numbers are not
meaningful physics, only exactly reproducible ones, which is all these tests compare.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import vadsim
import vadsim.studies.store as vstore
import vadsim.studies.sweep as vsweep
import xarray as xr
from _children import SIGINT_PRELUDE
from vadsim import _core
from vadsim.model.presets import get_preset
from vadsim.model.settings import ExtraSpec, RunSettings
from vadsim.studies.rows import FEATURES
from vadsim.studies.store import StoreWarning
from vadsim.studies.sweep import (
    GAP_REALISATIONS,
    PointSpec,
    design_overrides,
    flow_sweep,
    flows_from_hz,
    load_dataset,
    run_point,
    save_dataset,
    sweep,
)

SHORT: dict[str, Any] = dict(cycles=20, analyse_cycles=10)
QUIET: dict[str, Any] = dict(**SHORT, progress=False)
FLOWS = (200.0, 300.0, 350.0, 400.0)
GAPS = (0.9, 1.2)
STRING_VARS = ("periodicity", "error")
INT_VARS = ("scenario", "period", "steps")
CONT_FLOWS = (300.0, 320.0, 340.0, 360.0, 380.0, 400.0)  # the intermittent range (MODEL.md)

# The resume grid: 3 rows x 24 flows = 9 chunks of 8 flows (the module's chunk size).
RESUME_FLOWS = tuple(float(q) for q in np.linspace(200.0, 600.0, 24))
RESUME_GAPS = (0.85, 1.0, 1.3)
RESUME_CHUNK = 8
RESUME_KEYS = {f"chunk-{i}-{s}" for i in range(len(RESUME_GAPS))
               for s in range(0, len(RESUME_FLOWS), RESUME_CHUNK)}

# The child process slows every chunk down (after computing it, so numbers are unchanged) to
# give the parent time to kill it part-way through, whatever the machine's speed.
_CHILD = """
import json, sys, time
import vadsim.studies.sweep as vs
store, kw = sys.argv[1], json.loads(sys.argv[2])
_run = vs.run_point
def slow(spec):
    rows = _run(spec)
    time.sleep(DELAY)
    return rows
vs.run_point = slow
vs.sweep("7in-cde", kw["flows"], {"gap_ratio": kw["gaps"]}, store=store, workers=1,
         progress=False, cycles=kw["cycles"], analyse_cycles=kw["analyse_cycles"])
"""


def _strip(ds: xr.Dataset, *names: str) -> xr.Dataset:
    """A copy without the named attributes (those that legitimately differ between runs)."""
    out = ds.copy()
    out.attrs = {k: v for k, v in ds.attrs.items() if k not in names}
    return out


def _chunks(store: Path) -> set[str]:
    return {f.stem for f in store.glob("chunk-*.json")}


def _resume_key(spec: PointSpec) -> str:
    """The store key of the chunk a spec computes (mirrors sweep's chunk naming)."""
    (name, value), = spec.values
    assert name == "gap_ratio"
    return f"chunk-{RESUME_GAPS.index(value)}-{RESUME_FLOWS.index(spec.flows[0])}"


@pytest.fixture(scope="module")
def base_map() -> xr.Dataset:
    return sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, **QUIET)


@pytest.fixture(scope="module")
def resume_reference(tmp_path_factory: pytest.TempPathFactory) -> xr.Dataset:
    """The resume grid run in one go, in a fresh store."""
    store = tmp_path_factory.mktemp("fresh-store")
    return sweep("7in-cde", RESUME_FLOWS, {"gap_ratio": RESUME_GAPS}, store=store, **QUIET)


# --- shape, coordinates, attributes -------------------------------------------------------


def test_dims_coords_and_attrs(base_map: xr.Dataset) -> None:
    ds = base_map
    assert set(ds.data_vars) == set(FEATURES)
    for name in FEATURES:
        assert ds[name].dims == ("gap_ratio", "flow_gpm"), name
        assert ds[name].attrs["description"] == FEATURES[name]
    np.testing.assert_array_equal(ds["flow_gpm"], FLOWS)
    np.testing.assert_array_equal(ds["gap_ratio"], GAPS)
    alpha = get_preset("7in-cde").params["alpha"]
    assert ds["f_exc_hz"].dims == ("flow_gpm",)
    np.testing.assert_allclose(ds["f_exc_hz"], alpha * np.asarray(FLOWS) / (2 * math.pi),
                               rtol=1e-14)
    assert ds.attrs["mode"] == "independent"
    assert ds.attrs["preset"] == "7in-cde"
    assert ds.attrs["cycles"] == 20.0 and ds.attrs["analyse_cycles"] == 10.0
    assert ds.attrs["gap_via"] == "spring"
    for name in INT_VARS:
        assert ds[name].dtype == np.int64, name
    for name in STRING_VARS:
        assert ds[name].dtype.kind == "U", name
    assert (ds["error"] == "").all()
    # At 200 gal/min the 7in tool is in scenario 1 (MODEL.md), whatever the gap nearby.
    assert (ds["scenario"].sel(flow_gpm=200.0) == 1).all()


def test_point_is_the_run_simulate_gives(base_map: xr.Dataset) -> None:
    """Cell (gap, Q) holds the run at that gap and flow, not a neighbour's."""
    gap, q = GAPS[1], FLOWS[2]
    over = design_overrides(get_preset("7in-cde").params, {"gap_ratio": gap})
    r = vadsim.simulate("7in-cde", q, **SHORT, overrides=over, output_rate_hz=4096.0)
    cell = base_map.sel(gap_ratio=gap, flow_gpm=q)
    assert cell["z_spring"].item() == r.z["spring"]
    assert cell["z_impact"].item() == r.z["impact"]
    assert cell["j_pos"].item() == r.impulse_pos
    assert cell["j_mean"].item() == r.impulse_mean
    assert cell["scenario"].item() == r.scenario
    assert cell["steps"].item() == r.stats["steps"]


def test_flow_sweep_and_flows_from_hz() -> None:
    hz = np.array([21.3, 30.0, 45.5])
    flows = flows_from_hz("7in-cde", hz)
    ds = flow_sweep("7in-cde", flows, **QUIET)
    assert ds["z_spring"].dims == ("flow_gpm",)
    np.testing.assert_allclose(ds["f_exc_hz"], hz, rtol=1e-13)
    np.testing.assert_allclose(flows[0], 200.0, rtol=2e-3)  # MODEL.md: 200 gal/min -> 21.3 Hz
    same = sweep("7in-cde", flows, None, **QUIET)
    xr.testing.assert_identical(ds, same)


def test_two_parameter_map() -> None:
    """Two axes: every (gap, kS) slice equals a one-axis map with kS as an override."""
    ks = (2.0e5, 3.0e5)
    flows = (200.0, 350.0, 600.0)
    ds = sweep("7in-cde", flows, {"gap_ratio": GAPS, "kS": ks}, **QUIET)
    for name in FEATURES:
        assert ds[name].dims == ("gap_ratio", "kS", "flow_gpm"), name
    np.testing.assert_array_equal(ds["kS"], ks)
    for k in ks:
        one = sweep("7in-cde", flows, {"gap_ratio": GAPS}, overrides={"kS": k}, **QUIET)
        xr.testing.assert_equal(ds.sel(kS=k, drop=True), one)
    # Axis order is the caller's: swapping the axes transposes the map.
    swapped = sweep("7in-cde", flows, {"kS": ks, "gap_ratio": GAPS}, **QUIET)
    assert swapped["j_pos"].dims == ("kS", "gap_ratio", "flow_gpm")
    xr.testing.assert_equal(swapped.transpose(*ds["j_pos"].dims), ds)


# --- the gap and its realisations ----------------------------------------------------------


@pytest.mark.parametrize("gap_via", GAP_REALISATIONS)
def test_design_overrides_sets_the_gap(gap_via: str) -> None:
    base = dict(get_preset("7in-cde").params)
    moved = {"spring": "LS", "anvil": "L2", "housing": "L3"}[gap_via]

    def gap(p: dict[str, float]) -> float:
        return p["L3"] - (p["L2"] + p["LS"] + p["LI"] + p["LOn"])

    for values in ({"gap_ratio": 1.3}, {"gap": 0.02}):
        over = design_overrides(base, values, gap_via)
        assert set(over) == {moved}
        target = gap(base) * 1.3 if "gap_ratio" in values else 0.02
        assert gap({**base, **over}) == pytest.approx(target, rel=1e-12, abs=1e-15)


def test_gap_realisations() -> None:
    """Spring and anvil realisations are the same model, the housing one is not.

    L2 and LS enter only the spring indentation (x3 + LS) - (x2 - L2) (MODEL.md), so moving
    either by the same amount is the same change; L3 also sets the housing's static position
    and the shoulder indentations, so the housing realisation is a different tool.
    """
    gaps = (0.85, 1.0, 1.5)
    flows = (200.0, 300.0, 350.0, 500.0)
    ds = {g: sweep("7in-cde", flows, {"gap_ratio": gaps}, gap_via=g, **QUIET)
          for g in GAP_REALISATIONS}
    for g, d in ds.items():
        assert d.attrs["gap_via"] == g
    spring, anvil, housing = (_strip(ds[g], "gap_via", "grid_hash") for g in GAP_REALISATIONS)
    xr.testing.assert_identical(spring, anvil)
    # The preset's own gap (ratio 1) is the same tool whichever length realises it...
    xr.testing.assert_identical(spring.sel(gap_ratio=[1.0]), housing.sel(gap_ratio=[1.0]))
    # ...any other gap is not.
    for g in (0.85, 1.5):
        assert not spring.sel(gap_ratio=g).equals(housing.sel(gap_ratio=g)), g
    assert (spring["j_pos"] != housing["j_pos"]).any()


# --- NetCDF ---------------------------------------------------------------------------------


def _assert_round_trip(ds: xr.Dataset, path: Path) -> None:
    assert save_dataset(ds, path) == path
    back = load_dataset(path)
    xr.testing.assert_identical(back, ds)
    assert set(back.variables) == set(ds.variables)
    for name in ds.variables:
        assert back[name].dtype == ds[name].dtype, name
        assert back[name].attrs == ds[name].attrs, name
    assert back.attrs == ds.attrs
    for name in STRING_VARS:
        assert back[name].values.tolist() == ds[name].values.tolist(), name
    assert not list(path.parent.glob("*.tmp"))


def test_netcdf_round_trip(base_map: xr.Dataset, tmp_path: Path) -> None:
    _assert_round_trip(base_map, tmp_path / "map.nc")


def test_netcdf_round_trip_with_failed_points(base_map: xr.Dataset, tmp_path: Path) -> None:
    """Failed points (NaN numbers, a long error message) survive the file too."""
    ds = base_map.copy(deep=True)
    err = ds["error"].values.astype(object)
    err[0, 1] = "CVODE failed at t = 0.123 s: too much work (ümlaut ok)"
    per = ds["periodicity"].values.astype(object)
    per[0, 1] = "failed"
    ds["error"] = (ds["error"].dims, err.astype(str), ds["error"].attrs)
    ds["periodicity"] = (ds["periodicity"].dims, per.astype(str), ds["periodicity"].attrs)
    ds["j_pos"][0, 1] = np.nan
    ds["scenario"][0, 1] = -1
    path = tmp_path / "sub" / "failed.nc"
    _assert_round_trip(ds, path)
    # Overwriting an existing file works (written aside, then renamed).
    _assert_round_trip(base_map, path)


# --- the store: refusing other grids, resuming ---------------------------------------------


def test_store_reuse_and_other_grid_refused(tmp_path: Path, base_map: xr.Dataset,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    store = tmp_path / "store"
    first = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    xr.testing.assert_identical(first, base_map)
    grid = (store / "grid.json").read_text()
    n = len(_chunks(store))
    assert n == len(GAPS)  # 4 flows: one chunk per row

    def boom(spec: PointSpec) -> list[dict[str, Any]]:
        raise AssertionError("a complete store must not compute anything")

    monkeypatch.setattr(vsweep, "run_point", boom)
    again = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    xr.testing.assert_identical(again, base_map)

    for args, kw in [
        ((FLOWS[:3], {"gap_ratio": GAPS}), {}),
        ((FLOWS, {"gap_ratio": (0.9, 1.3)}), {}),
        ((FLOWS, {"kS": (2e5, 3e5)}), {}),
        ((FLOWS, {"gap_ratio": GAPS}), {"mode": "continuation"}),
        ((FLOWS, {"gap_ratio": GAPS}), {"gap_via": "housing"}),
        ((FLOWS, {"gap_ratio": GAPS}), {"overrides": {"kS": 3e5}}),
    ]:
        with pytest.raises(ValueError, match="different grid"):
            sweep("7in-cde", *args, store=store, **{**QUIET, **kw})
    with pytest.raises(ValueError, match="different grid"):
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, cycles=30, analyse_cycles=10,
              progress=False)
    assert (store / "grid.json").read_text() == grid
    assert len(_chunks(store)) == n


def _run_child_and_interrupt(store: Path, sig: int, after: int) -> tuple[set[str], str]:
    """Run the resume grid in a child process and send ``sig`` once ``after`` chunks exist."""
    kw = dict(flows=RESUME_FLOWS, gaps=RESUME_GAPS, **SHORT)
    code = SIGINT_PRELUDE + _CHILD.replace("DELAY", "0.15")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-c", code, str(store), json.dumps(kw)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 120
        while len(_chunks(store)) < after:
            if proc.poll() is not None:
                pytest.fail(f"child ended before it was interrupted:\n{proc.stderr.read()}")
            if time.monotonic() > deadline:
                pytest.fail("child wrote no chunks in 120 s")
            time.sleep(0.005)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode != 0, "the child finished: it was not interrupted"
    return _chunks(store), err


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["kill-9", "ctrl-c"])
def test_resume_after_interrupt(sig: int, tmp_path: Path, resume_reference: xr.Dataset,
                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Interrupt a map part-way, resume it: only the missing chunks run, same final numbers."""
    store = tmp_path / "store"
    before, err = _run_child_and_interrupt(store, sig, after=3)
    if sig == signal.SIGINT:
        assert "KeyboardInterrupt" in err
    assert 3 <= len(before) < len(RESUME_KEYS), before
    assert before <= RESUME_KEYS
    contents = {k: (store / f"{k}.json").read_text() for k in before}
    # Debris a kill -9 could leave: a half-written temporary file (never read) and, should a
    # file system not honour the atomic rename, a truncated chunk (recomputed).
    (store / "chunk-0-0.json1234abcd.tmp").write_text('[{"z_spring": 0.')

    calls: list[str] = []
    real = vsweep.run_point

    def counting(spec: PointSpec) -> list[dict[str, Any]]:
        calls.append(_resume_key(spec))
        return real(spec)

    monkeypatch.setattr(vsweep, "run_point", counting)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        resumed = sweep("7in-cde", RESUME_FLOWS, {"gap_ratio": RESUME_GAPS}, store=store,
                        workers=2, **QUIET)
    # A killed child leaves its claims behind (Ctrl-C releases them): taken over, reported.
    reported = [str(w.message) for w in caught if issubclass(w.category, StoreWarning)]
    assert all("took over the claim" in m and ("has ended" in m or "no owner record" in m)
               for m in reported), reported
    if sig == signal.SIGINT:
        assert reported == []
    assert not list(store.glob("*.claim*"))

    assert len(calls) == len(set(calls)), f"a chunk was computed twice: {sorted(calls)}"
    assert set(calls) == RESUME_KEYS - before, "resume must compute exactly the missing chunks"
    assert _chunks(store) == RESUME_KEYS
    for k, text in contents.items():
        assert (store / f"{k}.json").read_text() == text, f"{k} was rewritten"
    xr.testing.assert_identical(resumed, resume_reference)
    # And the store now answers alone, again identically.
    calls.clear()
    xr.testing.assert_identical(
        sweep("7in-cde", RESUME_FLOWS, {"gap_ratio": RESUME_GAPS}, store=store, **QUIET),
        resume_reference)
    assert calls == []


def test_corrupt_chunk_is_recomputed(tmp_path: Path, base_map: xr.Dataset) -> None:
    store = tmp_path / "store"
    sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    (store / "chunk-1-0.json").write_text('[{"z_spring": 1.0, ')
    with pytest.warns(StoreWarning, match=r"chunk-1-0\.json is not readable JSON"):
        again = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    xr.testing.assert_identical(again, base_map)
    json.loads((store / "chunk-1-0.json").read_text())


# --- parallel execution: local threads and Dask --------------------------------------------


def test_local_runs_in_parallel_by_default(monkeypatch: pytest.MonkeyPatch) -> None:
    """With workers=None, chunks run on several threads at once (all local cores)."""
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one core")
    lock = threading.Lock()
    active, peak = [0], [0]
    real = vsweep.run_point

    def tracking(spec: PointSpec) -> list[dict[str, Any]]:
        with lock:
            active[0] += 1
            peak[0] = max(peak[0], active[0])
        try:
            time.sleep(0.1)
            return real(spec)
        finally:
            with lock:
                active[0] -= 1

    monkeypatch.setattr(vsweep, "run_point", tracking)
    sweep("7in-cde", FLOWS[:2], {"gap_ratio": (0.9, 1.0, 1.1, 1.2)}, **QUIET)
    assert peak[0] >= 2


@pytest.fixture(scope="module")
def dask_cluster() -> Iterator[Any]:
    """A 4-worker local cluster of processes (more workers than cores: where a point runs
    must not change its numbers), closed even if a test fails."""
    distributed = pytest.importorskip("dask.distributed")
    cluster = distributed.LocalCluster(n_workers=4, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
    try:
        yield cluster
    finally:
        cluster.close()


def test_dask_matches_local(dask_cluster: Any, base_map: xr.Dataset, tmp_path: Path) -> None:
    addr = dask_cluster.scheduler_address
    ds = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, scheduler=addr, **QUIET)
    assert "run_point" in dask_cluster.scheduler.task_prefixes  # it really ran there
    xr.testing.assert_identical(ds, base_map)
    # A store filled on the cluster serves a local call (and vice versa: same chunks).
    store = tmp_path / "store"
    on_cluster = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, scheduler=addr, store=store,
                       **QUIET)
    xr.testing.assert_identical(on_cluster, base_map)
    xr.testing.assert_identical(
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET), base_map)


def test_an_adaptive_map_on_dask_matches_local(dask_cluster: Any) -> None:
    from vadsim.studies.refine import Refinement

    rule = Refinement(coarse=2, j_tol=None)
    local = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, refine=rule, **QUIET)
    on_cluster = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, refine=rule,
                       scheduler=dask_cluster.scheduler_address, **QUIET)
    xr.testing.assert_identical(on_cluster, local)


def test_dask_matches_local_continuation(dask_cluster: Any,
                                         continuation_pair: tuple[xr.Dataset, xr.Dataset]
                                         ) -> None:
    cont, _ = continuation_pair
    ds = sweep("7in-cde", CONT_FLOWS, {"gap_ratio": GAPS}, mode="continuation",
               scheduler=dask_cluster.scheduler_address, **QUIET)
    xr.testing.assert_identical(ds, cont)


# --- continuation mode ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def continuation_pair() -> tuple[xr.Dataset, xr.Dataset]:
    cont = sweep("7in-cde", CONT_FLOWS, {"gap_ratio": GAPS}, mode="continuation", **QUIET)
    indep = sweep("7in-cde", CONT_FLOWS, {"gap_ratio": GAPS}, **QUIET)
    return cont, indep


def test_continuation_mode(continuation_pair: tuple[xr.Dataset, xr.Dataset]) -> None:
    cont, indep = continuation_pair
    assert cont.attrs["mode"] == "continuation"
    assert indep.attrs["mode"] == "independent"
    assert cont.attrs["grid_hash"] != indep.attrs["grid_hash"]
    # The first flow of every row starts from the static state in both modes.
    first = {"flow_gpm": [CONT_FLOWS[0]]}
    xr.testing.assert_identical(_strip(cont.sel(first), "mode", "grid_hash"),
                                _strip(indep.sel(first), "mode", "grid_hash"))
    assert (cont["error"] == "").all()
    # Intermittent regimes remember where they came from: if these happen to agree, the
    # chaining itself is still checked below (test_continuation_chains_final_states).
    rest = {"flow_gpm": list(CONT_FLOWS[1:])}
    if cont.sel(rest)["j_pos"].equals(indep.sel(rest)["j_pos"]):
        pytest.skip("continuation and independent runs happen to agree on this grid")


def test_continuation_chains_final_states() -> None:
    """Each flow starts from the previous flow's y_end: run_point equals manual chaining."""
    gap = 1.1
    flows = (300.0, 350.0, 400.0)
    settings = RunSettings("7in-cde", cycles=20.0, analyse_cycles=10.0)
    spec = PointSpec(settings, flows, (("gap_ratio", gap),), continuation=True)
    rows = run_point(spec)
    indep = run_point(PointSpec(settings, flows, (("gap_ratio", gap),)))
    over = design_overrides(get_preset("7in-cde").params, {"gap_ratio": gap})
    state = None
    for q, row, free in zip(flows, rows, indep, strict=True):
        r = vadsim.simulate("7in-cde", q, **SHORT, overrides=over, output_rate_hz=4096.0,
                            initial_state=state)
        if state is not None:  # the first recorded sample is the previous run's end
            r0 = vadsim.simulate("7in-cde", q, cycles=1, analyse_cycles=1, overrides=over,
                                 record="all", initial_state=state)
            assert r0.t[0] == 0.0
            np.testing.assert_array_equal(r0.x[0], state[:7])
            np.testing.assert_array_equal(r0.v[0], state[7:])
        assert row["j_pos"] == r.impulse_pos, q
        assert row["z_spring"] == r.z["spring"] and row["z_impact"] == r.z["impact"], q
        assert row["steps"] == r.stats["steps"], q
        if state is None:
            assert row == free  # the first flow starts from rest in both modes
        state = r.y_end
    assert rows[1:] != indep[1:]


def test_continuation_store_keeps_rows_whole(tmp_path: Path) -> None:
    """A continuation row is sequential, so it is one chunk: resuming never splits a row."""
    flows = tuple(float(q) for q in np.linspace(300.0, 400.0, 10))  # > one 8-flow piece
    store = tmp_path / "store"
    ds = sweep("7in-cde", flows, {"gap_ratio": GAPS}, mode="continuation", store=store,
               **QUIET)
    assert _chunks(store) == {"chunk-0-0", "chunk-1-0"}
    assert ds.attrs["mode"] == "continuation"
    ind = sweep("7in-cde", flows, {"gap_ratio": GAPS}, store=tmp_path / "ind", **QUIET)
    assert ind.attrs["mode"] == "independent"
    assert _chunks(tmp_path / "ind") == {"chunk-0-0", "chunk-0-8", "chunk-1-0", "chunk-1-8"}


# --- progress bar and bad input ------------------------------------------------------------


def test_progress_bar(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    store = tmp_path / "store"
    sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **SHORT, progress=True)
    err = capsys.readouterr().err
    assert "7in-cde sweep" in err and "8/8" in err
    sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **SHORT, progress=True)
    assert "8/8" in capsys.readouterr().err  # a resumed sweep starts the bar where it was
    sweep("7in-cde", FLOWS[:1], **QUIET)
    assert capsys.readouterr().err == ""


BAD_INPUT: list[tuple[str, Callable[[], object], str]] = [
    ("empty flows", lambda: sweep("7in-cde", [], **QUIET), "flows is empty"),
    ("negative flow", lambda: sweep("7in-cde", [200.0, -5.0], **QUIET), "-5"),
    ("nan flow", lambda: sweep("7in-cde", [200.0, math.nan], **QUIET), "nan"),
    ("unknown axis", lambda: sweep("7in-cde", [200.0], {"bogus": [1.0]}, **QUIET), "bogus"),
    ("empty axis", lambda: sweep("7in-cde", [200.0], {"kS": []}, **QUIET), "kS"),
    ("flow axis", lambda: sweep("7in-cde", [200.0], {"flow_gpm": [1.0]}, **QUIET), "flow"),
    ("mode typo", lambda: sweep("7in-cde", [200.0], mode="continous", **QUIET), "continous"),
    ("gap_via typo", lambda: sweep("7in-cde", [200.0], {"gap_ratio": [1.0]},
                                   gap_via="spirng", **QUIET), "spirng"),
    ("gap_via typo, no axis", lambda: sweep("7in-cde", [200.0], gap_via="spirng", **QUIET),
     "spirng"),
    ("gap_via typo, design_overrides",
     lambda: design_overrides(get_preset("7in-cde").params, {"gap": 0.1}, "houseing"),
     "houseing"),
    ("unknown preset", lambda: sweep("7in-xyz", [200.0], **QUIET), "7in-xyz"),
    ("bad axis value", lambda: sweep("7in-cde", [200.0], {"kS": [2e5, -1.0]}, **QUIET), "kS"),
]


@pytest.mark.parametrize("call, match", [c[1:] for c in BAD_INPUT], ids=[c[0] for c in BAD_INPUT])
def test_bad_input(call: Callable[[], object], match: str) -> None:
    with pytest.raises(ValueError, match=re.escape(match)):
        call()


# --- run settings (RunSettings) -------------------------------------------------------------


def test_settings_bundle_equals_loose_keywords() -> None:
    """sweep(settings=RunSettings(...)) is the same map as today's keyword call, and extras
    may be ExtraSpec or mappings with 'kind'."""
    extra = {"kind": "hydraulic", "acts_on": "anvil", "c": 1e-4}
    flows = (200.0, 350.0)
    loose = sweep("7in-cde", flows, {"gap_ratio": GAPS}, overrides={"kS": 3e5}, wob_klbf=5.0,
                  extras=[extra], **QUIET)
    settings = RunSettings("7in-cde", overrides={"kS": 3e5}, wob_klbf=5.0,
                           extras=(ExtraSpec.of(**extra),), **SHORT)
    bundled = sweep(None, flows, {"gap_ratio": GAPS}, settings=settings, progress=False)
    xr.testing.assert_identical(bundled, loose)
    spec = sweep("7in-cde", flows, {"gap_ratio": GAPS}, overrides={"kS": 3e5}, wob_klbf=5.0,
                 extras=[ExtraSpec.of(**extra)], **QUIET)
    xr.testing.assert_identical(spec, loose)
    assert json.loads(loose.attrs["extras"]) == [extra]
    with pytest.raises(ValueError, match="either settings or cycles"):
        sweep(None, flows, settings=settings, cycles=30, progress=False)
    with pytest.raises(ValueError, match="9.5in-pdc"):
        sweep("9.5in-pdc", flows, settings=settings, progress=False)


def test_point_spec_carries_run_settings_and_pickles() -> None:
    """A chunk's spec is plain data that crosses a process boundary unchanged."""
    import pickle

    settings = RunSettings("7in-cde", overrides={"kS": 3e5}, **SHORT,
                           extras=({"kind": "hydraulic", "acts_on": "anvil", "c": 1e-4},))
    spec = PointSpec(settings, (200.0, 300.0), (("gap_ratio", 1.1),))
    back = pickle.loads(pickle.dumps(spec))
    assert back == spec
    assert run_point(back) == run_point(spec)


def test_flows_from_hz_uses_the_settings_alpha() -> None:
    hz = [20.0, 40.0]
    settings = RunSettings("7in-cde", overrides={"alpha": 0.5})
    np.testing.assert_allclose(settings.f_exc_hz(flows_from_hz(settings, hz)), hz, rtol=1e-14)
    np.testing.assert_array_equal(flows_from_hz("7in-cde", hz),
                                  RunSettings("7in-cde").flows_for_hz(hz))


# --- the store verifies what it reads --------------------------------------------------------


def _doc(store: Path, key: str = "chunk-1-0") -> dict[str, Any]:
    return json.loads((store / f"{key}.json").read_text())


def _put(store: Path, doc: Any, key: str = "chunk-1-0", *, reseal: bool = False) -> None:
    """Write a chunk file; ``reseal``: with a checksum that matches its (edited) rows, i.e. a
    chunk that lies consistently, so that the other checks are the ones that catch it."""
    if reseal:
        doc["checksum"] = vstore._checksum(doc["rows"])
    (store / f"{key}.json").write_text(json.dumps(doc))


def _short(store: Path) -> None:
    doc = _doc(store)
    doc["rows"] = doc["rows"][:2]
    _put(store, doc, reseal=True)


def _extra_row(store: Path) -> None:
    doc = _doc(store)
    doc["rows"].append(doc["rows"][0])
    _put(store, doc, reseal=True)


def _missing_key(store: Path) -> None:
    doc = _doc(store)
    del doc["rows"][1]["j_pos"]
    _put(store, doc, reseal=True)


def _unknown_key(store: Path) -> None:
    doc = _doc(store)
    doc["rows"][1]["j_max"] = 1.0
    _put(store, doc, reseal=True)


def _edited_value(store: Path) -> None:
    doc = _doc(store)
    doc["rows"][1]["z_spring"] = 2.3e251
    _put(store, doc)


def _wrong_type(store: Path) -> None:
    doc = _doc(store)
    doc["rows"][1]["z_spring"] = "many"
    _put(store, doc, reseal=True)


def _other_cell(store: Path) -> None:
    """A valid chunk under another chunk's name (its rows belong to gap index 0)."""
    _put(store, _doc(store, "chunk-0-0"), "chunk-1-0")


def _old_rows(store: Path, rows: Any) -> None:
    """vadsim 0.1's chunk: a bare list of rows."""
    _put(store, rows)


DAMAGE: list[tuple[str, Callable[[Path], None], str]] = [
    ("fewer rows", _short, "has 2 rows for 4 flows"),
    ("extra row", _extra_row, "has 5 rows for 4 flows"),
    ("missing key", _missing_key, "row 1 lacks j_pos"),
    ("unknown key", _unknown_key, "row 1 has unknown keys j_max"),
    ("edited value", _edited_value, "does not match its checksum"),
    ("wrong type", _wrong_type, "row 1 has z_spring = 'many'"),
    ("another cell's chunk", _other_cell, "holds key 'chunk-0-0'"),
    ("empty object", lambda s: _put(s, {}), "carries no grid hash or checksum"),
    ("old chunk, fewer rows", lambda s: _old_rows(s, _doc(s)["rows"][:2]),
     "carries no grid hash"),
    ("old chunk, extra row", lambda s: _old_rows(s, _doc(s)["rows"] * 2),
     "carries no grid hash"),
    ("truncated", lambda s: (s / "chunk-1-0.json").write_text('{"grid": "'),
     "is not readable JSON"),
]


@pytest.fixture(scope="module")
def filled_store(tmp_path_factory: pytest.TempPathFactory, base_map: xr.Dataset) -> Path:
    store = tmp_path_factory.mktemp("filled") / "store"
    xr.testing.assert_identical(
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET), base_map)
    return store


def _copy_store(src: Path, dst: Path) -> Path:
    import shutil

    shutil.copytree(src, dst)
    return dst


@pytest.mark.parametrize("damage, why", [d[1:] for d in DAMAGE], ids=[d[0] for d in DAMAGE])
def test_damaged_chunk_is_reported_and_recomputed(
        damage: Callable[[Path], None], why: str, filled_store: Path, tmp_path: Path,
        base_map: xr.Dataset, monkeypatch: pytest.MonkeyPatch) -> None:
    """A user's store with a short, empty, over-long or edited chunk gave garbage (2.3e251,
    exit 0) or a traceback: now that chunk alone is recomputed, with a warning saying why."""
    store = _copy_store(filled_store, tmp_path / "store")
    damage(store)
    calls: list[tuple[tuple[str, float], ...]] = []
    real = vsweep.run_point

    def counting(spec: PointSpec) -> list[dict[str, Any]]:
        calls.append(spec.values)
        return real(spec)

    monkeypatch.setattr(vsweep, "run_point", counting)
    with pytest.warns(StoreWarning, match=re.escape(f"chunk-1-0.json {why}")) as caught:
        again = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    assert len(caught) == 1, [str(w.message) for w in caught]
    assert calls == [(("gap_ratio", GAPS[1]),)]
    xr.testing.assert_identical(again, base_map)
    assert _doc(store) == _doc(filled_store)  # rewritten, verified
    calls.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    assert calls == []


def test_chunk_records_grid_checksum_and_index_set(filled_store: Path) -> None:
    doc = _doc(filled_store, "chunk-1-0")
    grid_text = (filled_store / "grid.json").read_text()
    import hashlib

    assert doc["grid"] == hashlib.sha256(grid_text.encode()).hexdigest()
    assert doc["key"] == "chunk-1-0" and doc["index"] == [1]
    assert doc["values"] == [["gap_ratio", GAPS[1]]]
    assert doc["flow_index"] == [0, 1, 2, 3] and doc["flows"] == list(FLOWS)
    assert len(doc["rows"]) == len(FLOWS) and doc["checksum"].startswith("sha256:")


GRID_DAMAGE: list[tuple[str, Callable[[Path], None], str]] = [
    ("deleted", lambda s: (s / "grid.json").unlink(), "no grid.json"),
    ("garbage", lambda s: (s / "grid.json").write_text("{not json"), "grid.json is unreadable"),
    ("old format", lambda s: (s / "grid.json").write_text('{"version": 1, "flows": []}'),
     "store format 1"),
]


@pytest.mark.parametrize("damage, match", [d[1:] for d in GRID_DAMAGE],
                         ids=[d[0] for d in GRID_DAMAGE])
@pytest.mark.parametrize("other", [False, True], ids=["same-settings", "other-settings"])
def test_store_without_verifiable_grid_is_refused(
        damage: Callable[[Path], None], match: str, other: bool, filled_store: Path,
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """grid.json deleted (or unreadable) while chunks remain: a map with other settings used
    to reuse the old points silently; now the store is refused, whatever the settings."""
    store = _copy_store(filled_store, tmp_path / "store")
    damage(store)
    before = {f.name: f.read_bytes() for f in store.iterdir()}
    monkeypatch.setattr(vsweep, "run_point", lambda spec: pytest.fail("computed"))
    kw = {"overrides": {"kS": 3e5}} if other else {}
    with pytest.raises(ValueError, match=re.escape(match)):
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET, **kw)
    assert {f.name: f.read_bytes() for f in store.iterdir()} == before  # nothing touched


def test_replaced_grid_json_is_refused(filled_store: Path, tmp_path: Path) -> None:
    """grid.json rewritten for other settings over old chunks: the chunks' grid hash says so."""
    store = _copy_store(filled_store, tmp_path / "store")
    # the grid.json of a map with other settings, put over the old chunks (as if by hand)
    sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=tmp_path / "fresh",
          overrides={"kS": 3e5}, **QUIET)
    (store / "grid.json").write_text((tmp_path / "fresh" / "grid.json").read_text())
    with pytest.raises(ValueError, match="belongs to grid .* grid.json was replaced"):
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, overrides={"kS": 3e5},
              **QUIET)


def test_other_grid_message_names_the_difference(filled_store: Path, tmp_path: Path) -> None:
    store = _copy_store(filled_store, tmp_path / "store")
    with pytest.raises(ValueError, match=r"different grid \(settings\.cycles 20\.0 -> 30\.0"):
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, cycles=30,
              analyse_cycles=10, progress=False)


def test_axis_order_is_part_of_the_grid(tmp_path: Path) -> None:
    """The same axes in another order are another grid (chunk indices mean other cells)."""
    store = tmp_path / "store"
    ks = (2.0e5, 3.0e5)
    sweep("7in-cde", FLOWS[:1], {"gap_ratio": GAPS, "kS": ks}, store=store, **QUIET)
    with pytest.raises(ValueError, match="different grid"):
        sweep("7in-cde", FLOWS[:1], {"kS": ks, "gap_ratio": GAPS}, store=store, **QUIET)


def test_stray_chunk_file_is_reported(filled_store: Path, tmp_path: Path,
                                      base_map: xr.Dataset) -> None:
    store = _copy_store(filled_store, tmp_path / "store")
    (store / "chunk-7-0.json").write_text("[]")
    with pytest.warns(StoreWarning, match="chunk-7-0.json"):
        again = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    xr.testing.assert_identical(again, base_map)


# --- several processes on one store: claims ----------------------------------------------------

# 4 rows x 24 flows = 12 chunks of 8 flows; 10-cycle runs.
SHARE_FLOWS = RESUME_FLOWS
SHARE_GAPS = (0.85, 1.0, 1.15, 1.3)
SHARE_KW: dict[str, Any] = dict(cycles=10, analyse_cycles=5)
SHARE_KEYS = {f"chunk-{i}-{s}" for i in range(len(SHARE_GAPS))
              for s in range(0, len(SHARE_FLOWS), RESUME_CHUNK)}

# Each child waits for the other (a barrier of files) so that both really run at once, and
# pauses after each chunk (numbers unchanged) so that neither is done before the other starts.
_SHARER = """
import json, sys, time
from pathlib import Path
import vadsim.studies.sweep as vs
store, barrier, me, out, kw = sys.argv[1:6]
kw = json.loads(kw)
computed = []
_run = vs.run_point
def counting(spec):
    rows = _run(spec)
    (name, value), = spec.values
    computed.append(f"chunk-{kw['gaps'].index(value)}-{kw['flows'].index(spec.flows[0])}")
    time.sleep(0.05)
    return rows
vs.run_point = counting
Path(barrier, me).touch()
deadline = time.monotonic() + 60
while len(list(Path(barrier).iterdir())) < 2 and time.monotonic() < deadline:
    time.sleep(0.005)
ds = vs.sweep("7in-cde", kw["flows"], {"gap_ratio": kw["gaps"]}, store=store, workers=1,
              progress=False, cycles=kw["cycles"], analyse_cycles=kw["analyse_cycles"])
vs.save_dataset(ds, out)
print(json.dumps(computed))
"""


@pytest.fixture(scope="module")
def share_reference() -> xr.Dataset:
    return sweep("7in-cde", SHARE_FLOWS, {"gap_ratio": SHARE_GAPS}, **SHARE_KW, progress=False)


def test_two_processes_share_one_store(tmp_path: Path, share_reference: xr.Dataset) -> None:
    """Two processes started together on one store compute each chunk once between them, and
    each returns the whole map (loading what the other computed)."""
    store, barrier = tmp_path / "store", tmp_path / "barrier"
    barrier.mkdir()
    kw = json.dumps(dict(flows=SHARE_FLOWS, gaps=SHARE_GAPS, **SHARE_KW))
    procs = [subprocess.Popen([sys.executable, "-c", _SHARER, str(store), str(barrier), name,
                               str(tmp_path / f"{name}.nc"), kw],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for name in ("a", "b")]
    computed = []
    try:
        for proc in procs:
            out, err = proc.communicate(timeout=300)  # only to catch a hang
            assert proc.returncode == 0, err
            assert "StoreWarning" not in err, err
            computed.append(json.loads(out.strip().splitlines()[-1]))
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    a, b = computed
    assert len(a) == len(set(a)) and len(b) == len(set(b))
    assert not set(a) & set(b), f"computed by both: {sorted(set(a) & set(b))}"
    assert set(a) | set(b) == SHARE_KEYS
    assert len(a) >= 1 and len(b) >= 1, (len(a), len(b))
    for name in ("a", "b"):
        xr.testing.assert_identical(load_dataset(tmp_path / f"{name}.nc"), share_reference)
    assert _chunks(store) == SHARE_KEYS
    assert not list(store.glob("*.claim*"))


def _claim(store: Path, key: str, pid: int, host: str | None = None) -> Path:
    import socket

    path = store / f"{key}.claim"
    path.write_text(json.dumps({"pid": pid, "host": host or socket.gethostname(),
                                "time": time.time(), "token": "someone-else"}))
    return path


def test_live_claim_is_waited_for_then_loaded(tmp_path: Path, filled_store: Path,
                                              base_map: xr.Dataset,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """A chunk claimed by a live process is not computed: the sweep computes the rest, waits,
    and loads that chunk once it appears."""
    store = tmp_path / "store"
    store.mkdir()
    (store / "grid.json").write_text((filled_store / "grid.json").read_text())
    claim = _claim(store, "chunk-0-0", os.getpid())  # this process: certainly alive
    calls: list[tuple[tuple[str, float], ...]] = []
    real = vsweep.run_point

    def counting(spec: PointSpec) -> list[dict[str, Any]]:
        calls.append(spec.values)
        return real(spec)

    monkeypatch.setattr(vsweep, "run_point", counting)
    result: dict[str, Any] = {}

    def run() -> None:
        try:
            result["ds"] = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
        except BaseException as exc:  # reported below
            result["error"] = exc

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 120
    while "chunk-1-0" not in _chunks(store):
        assert time.monotonic() < deadline and thread.is_alive(), result
        time.sleep(0.01)
    time.sleep(3 * vsweep._POLL_S)
    assert thread.is_alive(), f"the sweep did not wait for the claimed chunk: {result}"
    # the "other process" delivers its chunk, then lets go of the claim
    (store / "chunk-0-0.json").write_text((filled_store / "chunk-0-0.json").read_text())
    claim.unlink()
    thread.join(timeout=120)
    assert not thread.is_alive(), "the sweep hangs"
    assert "error" not in result, result
    assert calls == [(("gap_ratio", GAPS[1]),)]
    xr.testing.assert_identical(result["ds"], base_map)


def test_stale_claims_are_taken_over(tmp_path: Path, filled_store: Path, base_map: xr.Dataset
                                     ) -> None:
    """A claim whose process has ended (this host) or that shows no life for CLAIM_STALE_S
    (any host) is taken over and reported."""
    store = tmp_path / "store"
    store.mkdir()
    (store / "grid.json").write_text((filled_store / "grid.json").read_text())
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    _claim(store, "chunk-0-0", dead.pid)
    old = _claim(store, "chunk-1-0", 1, host="elsewhere.example")
    past = time.time() - vstore.CLAIM_STALE_S - 60
    os.utime(old, (past, past))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    messages = sorted(str(w.message) for w in caught if issubclass(w.category, StoreWarning))
    assert len(messages) == 2, messages
    assert f"chunk-0-0 (process {dead.pid} on this host has ended)" in messages[0]
    assert "chunk-1-0 (no sign of life for" in messages[1]
    xr.testing.assert_identical(ds, base_map)
    assert not list(store.glob("*.claim*"))



def test_claim_never_written_is_taken_over(tmp_path: Path, filled_store: Path,
                                           base_map: xr.Dataset) -> None:
    """A kill -9 between creating a claim and writing its owner leaves an empty claim file:
    past CLAIM_WRITE_GRACE_S it is taken over (it used to be waited for until CLAIM_STALE_S,
    ten minutes, as a CI run on a loaded machine showed)."""
    store = tmp_path / "store"
    store.mkdir()
    (store / "grid.json").write_text((filled_store / "grid.json").read_text())
    empty = store / "chunk-0-0.claim"
    empty.write_text("")
    past = time.time() - vstore.CLAIM_WRITE_GRACE_S - 5
    os.utime(empty, (past, past))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    messages = [str(w.message) for w in caught if issubclass(w.category, StoreWarning)]
    assert len(messages) == 1 and "chunk-0-0 (holds no owner record" in messages[0], messages
    xr.testing.assert_identical(ds, base_map)


@pytest.mark.parametrize("when", ["before", "after"])
def test_ctrl_c_while_claiming_leaves_no_claim(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              when: str) -> None:
    """Ctrl-C just before or just after a claim comes into being: the interrupted sweep
    releases it (a loaded CI run once left an empty claim that Ctrl-C did not release)."""
    real_link = os.link

    def interrupted(src: Any, dst: Any, *args: Any, **kw: Any) -> None:
        if str(dst).endswith(".claim"):
            if when == "after":
                real_link(src, dst, *args, **kw)
            raise KeyboardInterrupt
        real_link(src, dst, *args, **kw)

    monkeypatch.setattr(vsweep.os, "link", interrupted)
    with pytest.raises(KeyboardInterrupt):
        sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=tmp_path / "s", **QUIET)
    assert not list((tmp_path / "s").glob("*.claim*"))


def test_claim_left_on_a_finished_chunk_is_cleared(tmp_path: Path, filled_store: Path,
                                                   base_map: xr.Dataset,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A process killed between writing a chunk and releasing its claim leaves the claim on a
    finished chunk: the next sweep uses the chunk and removes the dead claim, silently."""
    store = _copy_store(filled_store, tmp_path / "store")
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    _claim(store, "chunk-1-0", dead.pid)
    live = _claim(store, "chunk-0-0", os.getpid())  # a live holder about to release: kept
    monkeypatch.setattr(vsweep, "run_point", lambda spec: pytest.fail("computed"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)
    xr.testing.assert_identical(ds, base_map)
    assert list(store.glob("*.claim*")) == [live]

# --- Ctrl-C ----------------------------------------------------------------------------------


def test_ctrl_c_keeps_finished_chunks_and_rerun_computes_the_rest(
        tmp_path: Path, resume_reference: xr.Dataset, monkeypatch: pytest.MonkeyPatch) -> None:
    """A real SIGINT to the main thread while chunk N+1 runs: KeyboardInterrupt propagates,
    the N finished chunks are in the store (verified), no claim is left, and a rerun computes
    exactly the other chunks."""
    store = tmp_path / "store"
    n = 3
    order: list[str] = []
    release = threading.Event()
    real = vsweep.run_point

    def interrupting(spec: PointSpec) -> list[dict[str, Any]]:
        order.append(_resume_key(spec))
        if len(order) == n + 1:
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
            # Still running when the interrupt lands: held until the main thread asks the
            # runs to stop (the 60 s only catch a hang), then the run sees that request.
            deadline = time.monotonic() + 60
            while (not (_core.interrupt_requested() or release.is_set())
                   and time.monotonic() < deadline):
                time.sleep(0.01)
        return real(spec)

    monkeypatch.setattr(vsweep, "run_point", interrupting)
    # Python's handler, even where the suite runs as a background job that ignores SIGINT.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            sweep("7in-cde", RESUME_FLOWS, {"gap_ratio": RESUME_GAPS}, store=store, workers=1,
                  **QUIET)
    finally:
        release.set()
        signal.signal(signal.SIGINT, previous)
    assert _chunks(store) == set(order[:n])
    assert not list(store.glob("*.claim*")) and not list(store.glob("*.tmp"))

    calls: list[str] = []

    def counting(spec: PointSpec) -> list[dict[str, Any]]:
        calls.append(_resume_key(spec))
        return real(spec)

    monkeypatch.setattr(vsweep, "run_point", counting)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the kept chunks verify: nothing reported
        again = sweep("7in-cde", RESUME_FLOWS, {"gap_ratio": RESUME_GAPS}, store=store,
                      **QUIET)
    assert sorted(calls) == sorted(RESUME_KEYS - set(order[:n]))
    xr.testing.assert_identical(again, resume_reference)


# --- dataset conventions -----------------------------------------------------------------------


def test_every_variable_and_coordinate_has_units_and_long_name(base_map: xr.Dataset) -> None:
    ds = sweep("7in-cde", FLOWS[:2], {"kS": (2e5, 3e5), "alpha": (0.6, 0.7)}, **QUIET)
    for d in (base_map, ds):
        for name, var in d.variables.items():
            assert isinstance(var.attrs.get("units"), str), name
            assert isinstance(var.attrs.get("long_name"), str) and var.attrs["long_name"], name
            if name not in STRING_VARS:
                assert var.attrs["units"], name
    units = {name: base_map[name].attrs["units"] for name in base_map.variables}
    assert units["flow_gpm"] == "gal/min" and units["f_exc_hz"] == "Hz"
    assert all(units[f"z_{s}"] == "1" for s in vadsim.SURFACES)
    assert units["j_pos"] == "N/kg" and units["j_pos_kN"] == "kN"
    assert units["x1_peak_mean_g"] == units["x5_peak_std_g"] == "g"
    assert units["x1_impact_hz"] == "Hz" and units["gap_ratio"] == "1"
    assert ds["kS"].attrs["units"] == "N/m/kg"
    assert ds["kS"].attrs["long_name"] == "recoil spring stiffness (#1)"
    assert ds["alpha"].attrs["units"] == "(rad/s)/(gal/min)"
    assert ds["f_exc_hz"].attrs["units"] == "Hz" and ds["f_exc_hz"].dims == ("alpha", "flow_gpm")
    for name in FEATURES:
        assert base_map[name].attrs["description"] == FEATURES[name]
