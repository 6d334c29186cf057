"""The result cache does not trust its folder (issue 36, item 3): entries are read with a size
cap, as regular files only (no device, folder or link leaving the cache), and checked against
the reader's schema after the checksum; any failure is a miss that is removed, never a
traceback. ``validate`` uses the cache like calibrate and diagnose."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import CampaignEvaluator, EventSimulation
from vadsim.model.cache import MAX_ENTRY_BYTES, ResultCache, default_cache
from vadsim.model.settings import RunSettings


def _entry(store: ResultCache, key: str):
    return store.folder / key[:2] / f"{key}.json.z"


def test_an_entry_linked_to_a_device_is_a_miss_in_bounded_memory(tmp_path):
    """Issue 36: an entry symlinked to /dev/zero grew the process until the kernel killed it
    (22 GB). Run in a child whose address space is capped at 2 GB, so a regression fails
    with a MemoryError instead of taking the machine."""
    code = textwrap.dedent(f"""
        import os, resource
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
        from vadsim.model.cache import ResultCache
        store = ResultCache({str(tmp_path)!r})
        key = store.key("device")
        path = store.folder / key[:2] / (key + ".json.z")
        path.parent.mkdir()
        os.symlink("/dev/zero", path)
        print(store.get(key), store.rejected, os.path.lexists(path), os.path.exists("/dev/zero"))
        hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")][0]
        print(int(hwm.split()[1]) // 1024)  # this process' own peak (not the parent's)
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    first, rss = proc.stdout.strip().split("\n")
    assert first == "None 1 False True"  # a miss, the link removed, the device untouched
    assert int(rss) < 400


def test_an_entry_replaced_by_a_folder_is_a_miss_and_is_written_again(tmp_path):
    """Issue 36: a folder in an entry's place gave an IsADirectoryError traceback on every
    later run (the write could not replace it)."""
    store = ResultCache(tmp_path)
    key = store.key("folder")
    _entry(store, key).mkdir(parents=True)
    (_entry(store, key) / "inside").write_text("x")
    assert store.get(key) is None and store.rejected == 1
    store.put(key, {"v": 1.5})
    assert _entry(store, key).is_file() and store.get(key) == {"v": 1.5}


def test_a_link_leaving_the_cache_is_a_miss_and_its_target_is_kept(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    store = ResultCache(tmp_path / "cache")
    key = store.key("link")
    store.put(key, [1.0, 2.0])
    target = outside / "entry"
    os.replace(_entry(store, key), target)  # a valid entry, but outside the cache
    os.symlink(target, _entry(store, key))
    assert store.get(key) is None and store.rejected == 1
    assert not os.path.lexists(_entry(store, key)) and target.exists()


def test_a_linked_shard_folder_is_a_miss(tmp_path):
    outside = tmp_path / "outside"
    store = ResultCache(tmp_path / "cache")
    key = store.key("shard")
    store.put(key, 3.0)
    os.replace(_entry(store, key).parent, outside)
    os.symlink(outside, _entry(store, key).parent)
    assert store.get(key) is None
    store.put(key, 4.0)  # the link is replaced by a folder of the cache's own
    assert not _entry(store, key).parent.is_symlink() and store.get(key) == 4.0
    assert (outside / f"{key}.json.z").exists()


def test_an_entry_over_the_size_cap_is_a_miss(tmp_path):
    store = ResultCache(tmp_path)
    key = store.key("big")
    path = _entry(store, key)
    path.parent.mkdir()
    with path.open("wb") as f:
        f.truncate(MAX_ENTRY_BYTES + 1)
    assert store.get(key) is None and store.rejected == 1 and not path.exists()


def test_a_compressed_bomb_is_a_miss(tmp_path):
    """A small entry that inflates past the cap (checksum valid) is refused while inflating."""
    import hashlib
    import zlib

    store = ResultCache(tmp_path)
    key = store.key("bomb")
    body = zlib.compress(b"[" + b"0," * (MAX_ENTRY_BYTES // 2 + 10) + b"0]", 9)
    path = _entry(store, key)
    path.parent.mkdir()
    path.write_bytes(b"vadsim-cache-1\n" + hashlib.sha256(body).hexdigest().encode() + body)
    assert store.get(key) is None and store.rejected == 1


@pytest.mark.parametrize("value", [[1, 2], {"flow_gpm": 1.0}, {"failed": "yes"}, "text", None,
                                   {"sensor": {"k": [1, 2]}}])
def test_a_valid_entry_of_the_wrong_structure_is_a_miss(tmp_path, value):
    """Issue 36: entries with a valid checksum but the wrong structure gave AttributeError and
    KeyError tracebacks; the reader's schema turns them into misses."""
    store = ResultCache(tmp_path)
    key = store.key("schema")
    store.put(key, value)
    assert store.get(key, parse=EventSimulation.from_json_entry) is None
    assert store.rejected == 1 and not _entry(store, key).exists()


def test_a_wrongly_shaped_entry_is_recomputed_by_the_evaluator(tmp_path):
    camp = synthetic_campaign("7in-cde", (250.0,), seed=2, cycles=70, analyse_cycles=50,
                              duration_s=1.0)
    settings = RunSettings("7in-cde", cycles=70, analyse_cycles=50)
    store = ResultCache(tmp_path)
    with CampaignEvaluator(camp, settings, cache=store, phases=2, workers=1) as ev:
        eid = ev.event_ids[0]
        key = ev._cache_key(ev_change(), ev.events[eid])
        assert key is not None
        store.put(key, [1, 2, 3])
        fresh = ev.simulate(None, eid)
    assert fresh is not None and store.rejected == 1
    assert isinstance(store.get(key), dict)  # written again, whole


def ev_change():
    from vadsim.model.change import ModelChange

    return ModelChange()


def test_validate_uses_the_cache_named_by_the_environment(tmp_path, monkeypatch):
    """Issue 36: ``vadsim validate`` ignored VADSIM_CACHE while calibrate and diagnose used
    it: a second validation now reads every run the first one stored."""
    from vadsim.fit.validate import validate

    camp = synthetic_campaign("7in-cde", (250.0, 400.0), seed=3, cycles=70, analyse_cycles=50,
                              duration_s=1.0)
    monkeypatch.setenv("VADSIM_CACHE", str(tmp_path / "cache"))
    first = validate(camp, cycles=70, analyse_cycles=50, progress=False, workers=1)
    store = default_cache()
    assert store is not None and store.misses == 2 and store.hits == 0
    second = validate(camp, cycles=70, analyse_cycles=50, progress=False, workers=1)
    assert store.hits == 2
    np.testing.assert_array_equal(first.residuals.to_numpy(), second.residuals.to_numpy())
    off = validate(camp, cycles=70, analyse_cycles=50, progress=False, workers=1, cache=False)
    assert store.hits == 2
    np.testing.assert_array_equal(off.residuals.to_numpy(), first.residuals.to_numpy())


def test_the_validate_command_takes_a_cache_option(tmp_path):
    from vadsim.cli import build_parser

    args = build_parser().parse_args(["validate", "thesis:7in-cde", "--cache", str(tmp_path)])
    assert args.cache == str(tmp_path)
