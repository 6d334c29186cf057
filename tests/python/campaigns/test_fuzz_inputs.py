"""Property-based fuzz of every input vadsim reads from others (issue 36, item 7): campaigns
(campaign.toml and event CSVs), preset files, store chunks, cache entries and ``simulate()``'s
arguments. Each case either works or fails with the error of its kind naming the file, key or
argument at fault; never another exception (a traceback for the user), never a wrong name.

Budgets are counts (``max_examples``), not times, and every case is small: the suite's 2,600
cases take well under a minute on two cores. Each test also tallies what it saw; the last test
checks the tallies and writes them, with this process' peak memory, to
``$VADSIM_FUZZ_REPORT`` (a JSON file) when that is set::

    VADSIM_FUZZ_REPORT=/tmp/fuzz.json python -m pytest -q tests/python/campaigns/test_fuzz_inputs.py
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import resource
import shutil
import tempfile
import warnings
import zlib
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
import vadsim
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vadsim.campaigns import CampaignError, ClippedSamplesWarning, load_campaign
from vadsim.compare import EventSimulation
from vadsim.model.cache import ResultCache
from vadsim.model.presets import load_preset_file

TALLY: dict[str, Counter[str]] = {}
"""Per suite: cases, ok (worked), named (a clean error naming the right thing), traceback
(another exception) and wrong_name (the right exception type, naming the wrong thing)."""

FUZZ = settings(deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])


def _count(suite: str, outcome: str) -> None:
    TALLY.setdefault(suite, Counter())["cases"] += 1
    TALLY[suite][outcome] += 1


def _folder() -> Path:
    return Path(tempfile.mkdtemp(prefix="vadsim-fuzz-"))


# ------------------------------------------------------------------------------ campaigns

BASE_DOC: dict[str, Any] = {
    "name": "fuzz", "tool": "7in", "bit": "CDE", "wob_klbf": 4.0,
    "sensors": {"x1": {"dof": 1, "rate_hz": 1024.0, "range_g": 250.0, "lowpass_hz": 400.0},
                "x5": {"dof": 5, "rate_hz": 1024.0, "range_g": 250.0}},
    "events": [{"id": "e01", "flow_gpm": 200.0, "file": "e01.csv"},
               {"id": "e02", "flow_gpm": 250.0, "wob_klbf": 5.0,
                "features": {"x1_peak_mean_g": 60.0, "x1_impact_hz": 24.0}}],
}
PATHS = [("name",), ("tool",), ("bit",), ("wob_klbf",), ("description",),
         ("sensors", "x1", "dof"), ("sensors", "x1", "rate_hz"), ("sensors", "x1", "range_g"),
         ("sensors", "x1", "lowpass_hz"), ("sensors", "x5", "rate_hz"), ("sensors", "x9"),
         ("events", 0, "id"), ("events", 0, "flow_gpm"), ("events", 0, "wob_klbf"),
         ("events", 0, "file"), ("events", 1, "features"), ("events", 1, "id"),
         ("events", 1, "features", "x1_peak_mean_g"), ("events", 1, "reference"),
         ("sensors",), ("events",), ("unknown",), ("events", 0, "unknown")]

WEIRD_TEXT = ["", " ", "e01", "../outside.csv", "/etc/passwd", "e01.csv", ".", "x" * 300,
              "n" * 5000, "\x00", "\u202e\u00e9\U0001f600", "7in", "PDC", "campaign.toml",
              "a\nb", "1e999", "nan"]
VALUES = st.one_of(
    st.sampled_from(WEIRD_TEXT), st.text(max_size=40),
    st.integers(min_value=-2**63, max_value=2**63 - 1),
    st.sampled_from([0, 1, 7, 8, -1, 2**62]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e300, 1e-300, -0.0, 5e-324, 1e9, 0.5, 1024.0]),
    st.booleans(), st.lists(st.integers(), max_size=3),
    st.dictionaries(st.sampled_from(["dof", "rate_hz", "x1_peak_mean_g", "zz"]),
                    st.one_of(st.integers(-3, 9), st.floats(-1e3, 1e3), st.text(max_size=3)),
                    max_size=3),
)


def _set(doc: dict[str, Any], path: tuple[Any, ...], value: Any) -> None:
    node: Any = doc
    for part in path[:-1]:
        node = node[part]
    if value is _DELETE:
        if isinstance(node, dict):
            node.pop(path[-1], None)
    else:
        node[path[-1]] = value


_DELETE = object()

CSV_TOKENS = ["", "nan", "NaN", "inf", "-inf", "1e999", "abc", "\u0661\u0662", "\x00",
              " 1.5 ", "1" * 400, "-", "1,2", "0x10", "1e5", "250", "-250", "\"1\"", "1_0"]


@st.composite
def csv_damage(draw: st.DrawFn) -> tuple[str, Any]:
    kind = draw(st.sampled_from(["cell", "drop_row", "dup_row", "blank", "header", "bytes",
                                 "cr", "truncate", "long_line", "bom", "none", "time"]))
    arg: Any = None
    if kind == "cell":
        arg = (draw(st.integers(0, 60)), draw(st.integers(0, 2)),
               draw(st.one_of(st.sampled_from(CSV_TOKENS), st.text(max_size=8))))
    elif kind in ("drop_row", "dup_row", "blank", "truncate", "time"):
        arg = draw(st.integers(0, 60))
    elif kind == "header":
        arg = draw(st.sampled_from(["time_s,x1_g", "x1_g,time_s,x5_g", "time_s,x1_g,x1_g",
                                    "time_s,x1_g,x9_g", "", "time_s;x1_g;x5_g",
                                    "time_s,x1_g,x5_g,extra"]))
    elif kind == "bytes":
        arg = (draw(st.integers(0, 2000)), draw(st.binary(min_size=1, max_size=16)))
    elif kind == "long_line":
        arg = draw(st.integers(200, 5000))
    return kind, arg


def _csv_text(damage: tuple[str, Any]) -> bytes:
    n = 64
    t = np.arange(n) / 1024.0
    rows = [f"{t[i]:.7f},{math.sin(i):.6f},{math.cos(i) * 300:.3f}" for i in range(n)]
    header = "time_s,x1_g,x5_g"
    kind, arg = damage
    if kind == "cell":
        i, j, token = arg
        cells = rows[i % n].split(",")
        cells[j] = token
        rows[i % n] = ",".join(cells)
    elif kind == "drop_row":
        del rows[arg % n]
    elif kind == "dup_row":
        rows.insert(arg % n, rows[arg % n])
    elif kind == "blank":
        rows.insert(arg % n, "")
    elif kind == "header":
        header = arg
    elif kind == "time":
        rows[arg % n] = "0.5" + rows[arg % n][rows[arg % n].index(","):]
    elif kind == "long_line":
        rows[5] = rows[5] + " " * arg
    text = (header + "\n" + "\n".join(rows) + "\n").encode()
    if kind == "bytes":
        at, blob = arg
        text = text[:at] + blob + text[at:]
    elif kind == "cr":
        text = text.replace(b"\n", b"\r")
    elif kind == "truncate":
        text = text[: arg * 9]
    elif kind == "bom":
        text = b"\xef\xbb\xbf" + text
    return text


def _load_and_judge(folder: Path, suite: str, names: tuple[str, ...]) -> None:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ClippedSamplesWarning)
            load_campaign(folder)
    except CampaignError as exc:
        text = str(exc)
        _count(suite, "named" if any(n in text for n in names) and len(text) < 2000
               else "wrong_name")
        return
    except Exception as exc:  # noqa: BLE001 -- counted, then failed below
        _count(suite, "traceback")
        raise AssertionError(f"{type(exc).__name__} escaped load_campaign: {exc!r}") from exc
    _count(suite, "ok")


@settings(FUZZ, max_examples=400)
@given(path=st.sampled_from(PATHS), value=st.one_of(VALUES, st.just(_DELETE)),
       damage=csv_damage())
def test_fuzz_campaign_folders(path: tuple[Any, ...], value: Any, damage: tuple[str, Any]
                               ) -> None:
    folder = _folder()
    try:
        doc = json.loads(json.dumps(BASE_DOC))
        _set(doc, path, value)
        try:
            text = tomli_w.dumps(doc)
        except (TypeError, ValueError):  # a value TOML cannot hold (nan keys...): raw text
            text = tomli_w.dumps(BASE_DOC) + f"\n{path[-1]} = {value!r}\n"
        (folder / "campaign.toml").write_text(text, encoding="utf-8", errors="surrogatepass")
        (folder / "e01.csv").write_bytes(_csv_text(damage))
        _load_and_judge(folder, "campaigns", ("campaign.toml", "e01.csv", "outside.csv"))
        assert TALLY["campaigns"]["wrong_name"] == 0
    finally:
        shutil.rmtree(folder)


@settings(FUZZ, max_examples=200)
@given(data=st.binary(max_size=400), keep=st.integers(0, 400))
def test_fuzz_campaign_file_bytes(data: bytes, keep: int) -> None:
    """Raw bytes spliced into a valid campaign.toml (syntax, encoding, control characters)."""
    folder = _folder()
    try:
        good = tomli_w.dumps(BASE_DOC).encode()
        (folder / "campaign.toml").write_bytes(good[:keep] + data + good[keep:])
        (folder / "e01.csv").write_bytes(_csv_text(("none", None)))
        _load_and_judge(folder, "campaign_bytes", ("campaign.toml", "e01.csv"))
        assert TALLY["campaign_bytes"]["wrong_name"] == 0
    finally:
        shutil.rmtree(folder)


@settings(FUZZ, max_examples=400)
@given(damage=csv_damage())
def test_fuzz_event_csvs(damage: tuple[str, Any]) -> None:
    """A valid campaign.toml, a damaged CSV: the error names the CSV."""
    folder = _folder()
    try:
        (folder / "campaign.toml").write_text(tomli_w.dumps(BASE_DOC))
        (folder / "e01.csv").write_bytes(_csv_text(damage))
        _load_and_judge(folder, "event_csvs", ("e01.csv",))
        assert TALLY["event_csvs"]["wrong_name"] == 0
    finally:
        shutil.rmtree(folder)


# ------------------------------------------------------------------------------ preset files

PRESET_KEYS = ["name", "base", "wob_klbf", "law", "note", "params", "zz"]


@settings(FUZZ, max_examples=300)
@given(key=st.sampled_from(PRESET_KEYS), value=VALUES,
       param=st.sampled_from(["kS", "kI", "l0", "wob", "theta0", "L_gap", "zz", "ks"]),
       pvalue=VALUES, raw=st.one_of(st.none(), st.binary(max_size=40)))
def test_fuzz_preset_files(key: str, value: Any, param: str, pvalue: Any,
                           raw: bytes | None) -> None:
    folder = _folder()
    path = folder / "p.toml"
    try:
        doc: dict[str, Any] = {"name": "fuzzed", "base": "7in-cde", key: value}
        if key != "params":
            doc["params"] = {param: pvalue}
        try:
            body = tomli_w.dumps(doc).encode()
        except (TypeError, ValueError):
            body = b'base = "7in-cde"\n'
        path.write_bytes(body if raw is None else raw + body)
        try:
            load_preset_file(path)
        except ValueError as exc:
            _count("presets", "named" if f"preset file {path}" in str(exc) else "wrong_name")
        except Exception as exc:  # noqa: BLE001
            _count("presets", "traceback")
            raise AssertionError(f"{type(exc).__name__}: {exc!r}") from exc
        else:
            _count("presets", "ok")
        assert TALLY["presets"]["wrong_name"] == 0
    finally:
        shutil.rmtree(folder)


# ------------------------------------------------------------------------------ store chunks


@pytest.fixture(scope="module")
def store_chunk(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Any, str]:
    from vadsim.studies import store as vstore
    from vadsim.studies import sweep as vsweep
    from vadsim.studies.grid import make_grid

    folder = tmp_path_factory.mktemp("fuzz-store") / "store"
    vsweep.sweep("7in-cde", (200.0, 300.0), {"kS": (2e5, 4e5)}, cycles=20, analyse_cycles=10,
                 progress=False, store=folder)
    settings_ = vsweep.RunSettings("7in-cde", cycles=20, analyse_cycles=10)
    grid = make_grid(settings_, (200.0, 300.0), {"kS": (2e5, 4e5)},
                     mode="independent", gap_via="spring", detail="full",
                     workers=None, portable=True)
    store = vstore.Store.open(folder, grid)
    chunk = grid.chunks()[0]
    return store, chunk, (folder / f"{chunk.key}.json").read_text()


JSONISH = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=6)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.text(max_size=6), inner, max_size=4)),
    max_leaves=12)


@settings(FUZZ, max_examples=300)
@given(edit=st.sampled_from(["key", "text", "bytes"]),
       field_=st.sampled_from(["rows", "checksum", "grid", "key", "flows", "indices",
                               "format", "zz"]),
       value=JSONISH, cut=st.integers(0, 3000), blob=st.binary(max_size=30))
def test_fuzz_store_chunks(store_chunk: tuple[Any, Any, str], edit: str, field_: str,
                           value: Any, cut: int, blob: bytes) -> None:
    from vadsim.studies.store import StoreWarning

    store, chunk, good = store_chunk
    path = store.path / f"{chunk.key}.json"
    doc = json.loads(good)
    if edit == "key":
        doc[field_] = value
        path.write_text(json.dumps(doc))
    elif edit == "text":
        path.write_text(good[:cut] + json.dumps(value) + good[cut:])
    else:
        path.write_bytes(good.encode()[:cut] + blob)
    store._bad.clear()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            rows = store.read(chunk)
    except ValueError as exc:  # a chunk of another grid: the store is refused, by name
        _count("store_chunks", "named" if chunk.key in str(exc) else "wrong_name")
        path.write_text(good)
        assert TALLY["store_chunks"]["wrong_name"] == 0
        return
    except Exception as exc:  # noqa: BLE001
        _count("store_chunks", "traceback")
        raise AssertionError(f"{type(exc).__name__}: {exc!r}") from exc
    finally:
        path.write_text(good)
    if rows is not None:
        _count("store_chunks", "ok")
    else:
        named = any(issubclass(w.category, StoreWarning) and chunk.key in str(w.message)
                    for w in caught)
        _count("store_chunks", "named" if named else "wrong_name")
    assert TALLY["store_chunks"]["wrong_name"] == 0


# ------------------------------------------------------------------------------ cache entries


def _sim_json() -> dict[str, Any]:
    return {"flow_gpm": 200.0, "wob_klbf": 4.0, "f_exc_hz": 20.0,
            "sensor": {"x1_peak_mean_g": [1.0, 0.1, 5]}, "full": {}, "z": {"impact": 1.0},
            "scenario": 1, "phase_sd": {}, "rate_hz": 1024.0, "error": ""}


@settings(FUZZ, max_examples=400)
@given(kind=st.sampled_from(["value", "field", "bytes", "recompress"]), value=JSONISH,
       field_=st.sampled_from(sorted(_sim_json())), cut=st.integers(0, 200),
       blob=st.binary(max_size=40))
def test_fuzz_cache_entries(kind: str, value: Any, field_: str, cut: int, blob: bytes) -> None:
    """Entries with a valid checksum and any structure, or damaged bytes: a miss, removed, or
    an event simulation; never an exception."""
    folder = _folder()
    try:
        store = ResultCache(folder)
        key = store.key("fuzz")
        good = _sim_json()
        if kind == "field":
            good[field_] = value
        store.put(key, value if kind == "value" else good)
        path = store.folder / key[:2] / f"{key}.json.z"
        if kind == "bytes":
            data = path.read_bytes()
            path.write_bytes(data[:cut] + blob + data[cut:])
        elif kind == "recompress":
            body = zlib.compress(blob)
            path.write_bytes(b"vadsim-cache-1\n" + hashlib.sha256(body).hexdigest().encode()
                             + body)
        try:
            got = store.get(key, parse=EventSimulation.from_json_entry)
        except Exception as exc:  # noqa: BLE001
            _count("cache_entries", "traceback")
            raise AssertionError(f"{type(exc).__name__}: {exc!r}") from exc
        if got is None:
            # a miss is what it must be: the entry gone (or a stored failed run)
            _count("cache_entries", "named" if not path.exists() or store.hits else
                   "wrong_name")
        else:
            assert isinstance(got, EventSimulation)
            _count("cache_entries", "ok")
        assert TALLY["cache_entries"]["wrong_name"] == 0
    finally:
        shutil.rmtree(folder)


# ------------------------------------------------------------------------------ simulate()

ARGUMENTS = ["model", "flow_gpm", "cycles", "analyse_cycles", "overrides", "wob_klbf", "law",
             "extras", "method", "rtol", "atol", "max_step", "record", "output_rate_hz",
             "summary_rate_hz", "initial_state", "max_steps", "max_events",
             "accelerations_only"]
BAD = st.one_of(
    st.sampled_from([None, "", "abc", b"1", "4.7e5", [1], [("kS", 1.0)], (), {}, True,
                     math.nan, math.inf, -math.inf, -1, 0, 10**400, 1e308, 1e-308,
                     np.float64(3.0), np.int64(5), object(), {"kS": "x"}, {"k6": 10**400},
                     {"kS": 4.7e5}, {"nope": 1.0}, {1: 2.0}, {"kS": None}, "bdf",
                     "window", "hunt_crossley", "7in-rc", [0.0] * 14]),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**30, 10**30),
    st.text(max_size=5))


def _names(argument: str, value: Any) -> tuple[str, ...]:
    """What a correct error about ``argument = value`` may name."""
    out = [argument]
    if argument == "overrides":
        out += ["parameter", *(str(k) for k in value)] if isinstance(value, dict) else []
    if argument == "model":
        out += ["preset", "parameter"]
    if argument == "law":
        out += ["contact law"]
    if argument in ("flow_gpm", "wob_klbf", "model", "overrides"):
        out += ["flow_gpm", "parameter", "wob"]
    return tuple(out)


@settings(FUZZ, max_examples=600)
@given(argument=st.sampled_from(ARGUMENTS), value=BAD)
def test_fuzz_simulate_arguments(argument: str, value: Any) -> None:
    """Issue 36: 68 of 1,500 fuzzed simulate() calls named the wrong argument or none."""
    kwargs: dict[str, Any] = {"cycles": 20, "analyse_cycles": 10, "record": "none",
                              "max_steps": 200_000, "max_events": 20_000}
    model: Any = "7in-cde"
    flow: Any = 200.0
    if argument == "model":
        model = value
    elif argument == "flow_gpm":
        flow = value
    else:
        kwargs[argument] = value
    if argument in ("cycles", "analyse_cycles", "output_rate_hz") and isinstance(
            value, (int, float)) and not isinstance(value, bool) and 1e3 < abs(value) < 1e300:
        kwargs[argument] = value = 1e9 if value > 0 else -1e9  # long: a budget stops it
    try:
        vadsim.simulate(model, flow, **kwargs)
    except ValueError as exc:
        text = str(exc)
        _count("simulate", "named" if any(n in text for n in _names(argument, value))
               else "wrong_name")
        assert TALLY["simulate"]["wrong_name"] == 0, f"{argument} = {value!r}: {text}"
        return
    except vadsim.SolverError:
        _count("simulate", "named")
        return
    except Exception as exc:  # noqa: BLE001
        _count("simulate", "traceback")
        raise AssertionError(f"{argument} = {value!r}: {type(exc).__name__}: {exc!r}") from exc
    _count("simulate", "ok")


# ------------------------------------------------------------------------------ the tallies


def test_fuzz_tallies() -> None:
    """Every suite ran its cases; none gave a traceback or a wrong name. Written to
    ``$VADSIM_FUZZ_REPORT`` with the peak memory when that is set."""
    expected = {"campaigns", "campaign_bytes", "event_csvs", "presets", "store_chunks",
                "cache_entries", "simulate"}
    ran = set(TALLY)
    totals = Counter[str]()
    for tally in TALLY.values():
        totals.update(tally)
    report = {"suites": {k: dict(v) for k, v in sorted(TALLY.items())}, "total": dict(totals),
              "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
    if os.environ.get("VADSIM_FUZZ_REPORT"):
        Path(os.environ["VADSIM_FUZZ_REPORT"]).write_text(json.dumps(report, indent=2))
    if ran != expected:  # run alone (-k): nothing to check
        pytest.skip(f"only {sorted(ran)} ran")
    assert totals["traceback"] == 0 and totals["wrong_name"] == 0, report
    assert all(t["cases"] >= 200 for t in TALLY.values()), report
    assert totals["named"] >= 1000, report
