"""Stalls and races of a map's store and outputs (issue 36, item 6): a claim records its host,
PID and the process's start, so a reused PID is not its owner; a claim with no owner record
is no one's; every writer of a dataset has its own temporary file."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
import threading
import time
import warnings
from pathlib import Path
from typing import Any

import pytest
import xarray as xr
from vadsim.studies import store as vstore
from vadsim.studies import sweep as vsweep
from vadsim.studies.grid import make_grid
from vadsim.studies.store import StoreWarning
from vadsim.studies.sweep import load_dataset, sweep

QUIET: dict[str, Any] = dict(cycles=20, analyse_cycles=10, progress=False)
FLOWS = (200.0, 300.0)
GAPS = (0.9, 1.2)
HANG_S = 120  # only a hang guard: a stalled claim waited CLAIM_STALE_S = 600 s


@pytest.fixture(scope="module")
def filled(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, xr.Dataset]:
    store = tmp_path_factory.mktemp("filled") / "store"
    return store, sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store, **QUIET)


def _sweep_with_claim(tmp_path: Path, filled: tuple[Path, xr.Dataset], claim: str,
                      monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Sweep into a store whose first chunk holds ``claim``; the StoreWarnings, once the
    sweep ends (a hang fails the test). The grace periods are made endless: the claim must be
    found to be no one's from what it says, not from its age."""
    monkeypatch.setattr(vstore, "CLAIM_STALE_S", 1e9)
    monkeypatch.setattr(vstore, "CLAIM_WRITE_GRACE_S", 1e9)
    source, _ = filled
    store = tmp_path / "store"
    store.mkdir()
    (store / "grid.json").write_text((source / "grid.json").read_text())
    (store / "chunk-0-0.claim").write_text(claim)
    result: dict[str, Any] = {}

    def run() -> None:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                result["ds"] = sweep("7in-cde", FLOWS, {"gap_ratio": GAPS}, store=store,
                                     **QUIET)
            except BaseException as exc:  # reported below
                result["error"] = exc
        result["warnings"] = [str(w.message) for w in caught
                              if issubclass(w.category, StoreWarning)]

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(HANG_S)
    assert not thread.is_alive(), "the sweep waits for a claim no live process holds"
    assert "error" not in result, result
    xr.testing.assert_identical(result["ds"], filled[1])
    assert not list(store.glob("*.claim*"))
    return result["warnings"]


def test_a_claim_naming_a_reused_pid_is_taken_over_at_once(tmp_path, filled, monkeypatch):
    """Issue 36: a claim naming a live but unrelated process (a reused PID) stalled a resume
    up to 600 s. The parent of this process is alive, and is not the claim's owner: its start
    differs from the one the claim records."""
    claim = {"pid": os.getppid(), "host": socket.gethostname(), "start": "no-boot:1",
             "time": time.time(), "token": "someone-else"}
    messages = _sweep_with_claim(tmp_path, filled, json.dumps(claim), monkeypatch)
    assert len(messages) == 1, messages
    assert f"process {os.getppid()} on this host is another process than the claimant" \
        in messages[0]


def test_a_garbage_claim_is_taken_over_at_once(tmp_path, filled, monkeypatch):
    """Issue 36: a garbage claim stalled a resume 30 s (CLAIM_WRITE_GRACE_S). A claim is
    hard-linked into place only once its owner record is written, so a claim without a valid
    record was never a live writer's."""
    messages = _sweep_with_claim(tmp_path, filled, "{garbage", monkeypatch)
    assert len(messages) == 1 and "holds no owner record" in messages[0], messages


def test_a_live_claim_records_its_start_and_is_respected(tmp_path, filled):
    """This process's own claim, with its true start, is live: a second store object on the
    same folder does not take it."""
    source, _ = filled
    store_dir = tmp_path / "store"
    store_dir.mkdir()
    (store_dir / "grid.json").write_text((source / "grid.json").read_text())
    settings = vsweep.RunSettings("7in-cde", cycles=20, analyse_cycles=10)
    grid = make_grid(settings, FLOWS, {"gap_ratio": GAPS}, mode="independent",
                     gap_via="spring", detail="full", workers=None, portable=True)
    mine, other = vstore.Store.open(store_dir, grid), vstore.Store.open(store_dir, grid)
    chunk = grid.chunks()[0]
    assert mine.claim(chunk)
    record = json.loads((store_dir / f"{chunk.key}.claim").read_text())
    assert record["pid"] == os.getpid() and record["start"] == vstore.process_start(os.getpid())
    assert record["start"] is not None  # on Linux, /proc gives it
    with warnings.catch_warnings():
        warnings.simplefilter("error", StoreWarning)
        assert not other.claim(chunk)
    mine.release_all()


def test_concurrent_saves_to_one_file_do_not_collide(tmp_path, filled):
    """Issue 36: two processes saving to the same --out shared OUT.nc.tmp (42 of 80
    concurrent save_dataset writes failed with PermissionError)."""
    _, ds = filled
    src = tmp_path / "in.nc"
    vsweep.save_dataset(ds, src)
    out = tmp_path / "out.nc"
    code = textwrap.dedent(f"""
        from vadsim.studies.sweep import load_dataset, save_dataset
        ds = load_dataset({str(src)!r})
        for _ in range(10):
            save_dataset(ds, {str(out)!r})
        print("ok")
    """)
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(4)]
    for proc in procs:
        out_text, err = proc.communicate(timeout=HANG_S)
        assert proc.returncode == 0 and out_text.strip() == "ok", err[-2000:]
    xr.testing.assert_identical(load_dataset(out), ds)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.nc", "out.nc"]


def test_private_claim_files_of_a_killed_process_are_cleared(tmp_path, filled):
    """A kill -9 between writing a claim's owner record and linking it (or between setting a
    stale claim aside and removing it) leaves a private file that no one reads; a store that
    loads removes those whose owner has ended, and keeps a live process's and a fresh one
    without a record (a live writer holds it for microseconds)."""
    source, _ = filled
    store_dir = tmp_path / "store"
    store_dir.mkdir()
    (store_dir / "grid.json").write_text((source / "grid.json").read_text())
    child = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                           capture_output=True, text=True, check=True)
    dead = {"pid": int(child.stdout), "host": socket.gethostname(), "start": None,
            "time": time.time(), "token": "killed"}
    live = {"pid": os.getpid(), "host": socket.gethostname(),
            "start": vstore.process_start(os.getpid()), "time": time.time(), "token": "me"}
    files = {"chunk-0-0.claim.new-a": json.dumps(dead), "chunk-0-1.claim.stale-b":
             json.dumps(dead), "chunk-1-0.claim.new-c": json.dumps(live),
             "chunk-1-1.claim.new-d": "{garb", "chunk-1-2.claim.new-e": "{garb"}
    for name, text in files.items():
        (store_dir / name).write_text(text)
    old = time.time() - 2 * vstore.DEBRIS_AGE_S
    os.utime(store_dir / "chunk-1-2.claim.new-e", (old, old))
    settings = vsweep.RunSettings("7in-cde", cycles=20, analyse_cycles=10)
    grid = make_grid(settings, FLOWS, {"gap_ratio": GAPS}, mode="independent",
                     gap_via="spring", detail="full", workers=None, portable=True)
    vstore.Store.open(store_dir, grid).load(grid.chunks())
    assert sorted(p.name for p in store_dir.glob("*.claim*")) == [
        "chunk-1-0.claim.new-c", "chunk-1-1.claim.new-d"]
