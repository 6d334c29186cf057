"""Tests of vadsim.sweep (python/vadsim/sweep.py): flow sweeps and 2-D maps.

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
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import vadsim
import vadsim.sweep as vsweep
import xarray as xr
from vadsim.presets import get_preset
from vadsim.sweep import (
    FEATURES,
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
import vadsim.sweep as vs
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
    code = _CHILD.replace("DELAY", "0.15")
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
    resumed = sweep("7in-cde", RESUME_FLOWS, {"gap_ratio": RESUME_GAPS}, store=store,
                    workers=2, **QUIET)

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
    """A 2-worker local cluster of processes, closed even if a test fails."""
    distributed = pytest.importorskip("dask.distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
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
    spec = PointSpec(preset="7in-cde", flows=flows, values=(("gap_ratio", gap),),
                     continuation=True, cycles=20.0, analyse_cycles=10.0)
    rows = run_point(spec)
    indep = run_point(PointSpec(preset="7in-cde", flows=flows, values=(("gap_ratio", gap),),
                                cycles=20.0, analyse_cycles=10.0))
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
