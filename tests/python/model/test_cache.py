"""The result cache: a hit is what a fresh computation gives, bit for bit; any change to the
inputs or the code is a miss; a damaged file is a miss, never a wrong result."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import CampaignEvaluator, EventSimulation
from vadsim.model import cache as cache_module
from vadsim.model.cache import ResultCache, Uncacheable, canonical, default_cache
from vadsim.model.change import ModelChange
from vadsim.model.settings import ExtraSpec, RunSettings

SMALL = dict(cycles=70, analyse_cycles=50, duration_s=1.0)
RUN = dict(cycles=70, analyse_cycles=50)
FLOWS = (250.0, 500.0)


@dataclass(frozen=True)
class _Point:
    x: float
    tags: tuple[str, ...]


def test_canonical_is_exact_and_independent_of_order():
    assert canonical({"b": 0.1, "a": 1}) == canonical({"a": 1, "b": 0.1})
    # a float is kept exactly: the next representable number is another key
    assert canonical(0.1) != canonical(math.nextafter(0.1, 1.0))
    assert canonical(np.float64(0.1)) == canonical(0.1)
    assert canonical(float("nan")) == "nan"
    assert canonical(_Point(1.5, ("x",))) == {"__type__": "_Point", "x": "1.5", "tags": ["x"]}
    with pytest.raises(Uncacheable, match="function"):
        canonical(lambda x: x)


def test_a_run_length_given_as_an_integer_or_a_float_is_one_key(tmp_path):
    """160 and 160.0 cycles are the same run: the command line reads floats, Python callers
    write integers, and the second diagnosis of a campaign must read the first one's runs."""
    c = ResultCache(tmp_path)
    as_int = RunSettings("7in-cde", cycles=160, analyse_cycles=100)
    as_float = RunSettings("7in-cde", cycles=160.0, analyse_cycles=100.0)
    assert as_int == as_float and isinstance(as_int.cycles, float)
    assert c.key("run", as_int) == c.key("run", as_float)
    assert c.key("run", as_int) != c.key("run", RunSettings("7in-cde", cycles=161))


def test_a_stored_value_comes_back_and_another_input_or_code_misses(tmp_path, monkeypatch):
    store = ResultCache(tmp_path / "c")
    key = store.key("run", {"flow": 200.0})
    assert store.get(key) is None and store.misses == 1
    store.put(key, {"x": [0.1, float("nan"), 3]})
    got = store.get(key)
    assert got["x"][0] == 0.1 and math.isnan(got["x"][1]) and got["x"][2] == 3
    assert store.hits == 1
    assert store.key("run", {"flow": 200.0 + 1e-12}) != key
    # other code: every key changes
    monkeypatch.setattr(cache_module, "code_fingerprint", lambda: "another version")
    assert store.key("run", {"flow": 200.0}) != key


@pytest.mark.parametrize("damage", ["truncate", "flip", "foreign", "other_key"])
def test_a_damaged_file_is_a_miss_and_is_removed(tmp_path, damage):
    store = ResultCache(tmp_path)
    key, other = store.key("a"), store.key("b")
    store.put(key, {"v": 1.0})
    store.put(other, {"v": 2.0})
    path = store._path(key)
    blob = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(blob[: len(blob) // 2])
    elif damage == "flip":
        path.write_bytes(blob[:-1] + bytes([blob[-1] ^ 1]))
    elif damage == "foreign":
        path.write_bytes(b"import os; os.system('echo owned')")
    else:  # a valid file of another key copied over this one
        path.write_bytes(store._path(other).read_bytes())
    assert store.get(key) is None
    assert store.rejected == 1 and not path.exists()
    assert store.get(other) == {"v": 2.0}


def test_the_cache_is_off_unless_asked_for(tmp_path, monkeypatch):
    monkeypatch.delenv("VADSIM_CACHE", raising=False)
    assert default_cache() is None
    with pytest.raises(ValueError, match="VADSIM_CACHE"):
        default_cache(True)
    monkeypatch.setenv("VADSIM_CACHE", str(tmp_path / "env"))
    assert default_cache().folder == tmp_path / "env"
    assert default_cache(False) is None
    assert default_cache(tmp_path / "x").folder == tmp_path / "x"
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="is a file"):
        ResultCache(tmp_path / "file")


def test_an_event_simulation_survives_the_round_trip_exactly():
    camp = synthetic_campaign("7in-cde", FLOWS, seed=1, **SMALL)
    ev = CampaignEvaluator(camp, RunSettings("7in-cde", **RUN),
                           phases=2, workers=1, cache=False)
    with ev:
        sim = ev.simulate(None, "e01")
    back = EventSimulation.from_json("e01", sim.to_json())
    assert back == sim


def _evaluate(camp, store, change=None, noise=None):
    settings = RunSettings("7in-cde", **RUN)
    with CampaignEvaluator(camp, settings, phases=2, workers=2, cache=store,
                           noise=noise) as ev:
        base = ev.base()
        out = {e: v.z for e, v in base.items()}
        if change is not None:
            out.update({("changed", e): v.z for (_, e), v in
                        ev.evaluate([("changed", change)]).items()})
        return out, ev


def test_a_second_evaluation_reads_every_run_and_gives_the_same_residuals(tmp_path):
    camp = synthetic_campaign("7in-cde", FLOWS, seed=2, **SMALL)
    store = ResultCache(tmp_path)
    change = ModelChange(scales={"Fo": 1.1})
    fresh, _ = _evaluate(camp, False, change)
    first, _ = _evaluate(camp, store, change)
    assert store.hits == 0 and store.misses == 4
    second, ev = _evaluate(camp, store, change)
    assert store.hits == 4 and store.misses == 4
    for k in fresh:
        np.testing.assert_array_equal(first[k], fresh[k])
        np.testing.assert_array_equal(second[k], fresh[k])
    assert ev._runs == {}  # nothing ran


def test_another_campaign_at_the_same_points_shares_the_runs_but_not_the_residuals(tmp_path):
    """The key is the run's inputs and what is measured of it, not the recording: a second
    campaign at the same flows (other noise) reads the runs whose recordings folded at the
    same periods (the model folds only those) and compares them with its own recordings."""
    store = ResultCache(tmp_path)
    a = synthetic_campaign("7in-cde", FLOWS, seed=3, **SMALL)
    b = synthetic_campaign("7in-cde", FLOWS, seed=4, **SMALL)
    sensors = {"x1": 0.3, "x5": 0.3}  # the same sensors' noise
    za, ev_a = _evaluate(a, store, noise=sensors)
    zb, ev_b = _evaluate(b, store, noise=sensors)
    same = sum(ev_a.fold_periods[e] == ev_b.fold_periods[e] for e in zb)
    assert same >= 1 and store.hits == same
    zb_fresh, _ = _evaluate(b, False, noise=sensors)
    for e in zb:
        np.testing.assert_array_equal(zb[e], zb_fresh[e])
    assert not np.array_equal(za["e01"], zb["e01"])
    # The model is measured with the noise: another noise is another measurement.
    _evaluate(b, store, noise={"x1": 1.0, "x5": 1.0})
    assert store.hits == same and store.misses == 6 - same


def test_what_has_no_stable_description_is_not_cached(tmp_path):
    store = ResultCache(tmp_path)
    camp = synthetic_campaign("7in-cde", FLOWS, seed=5, **SMALL)
    measured = ModelChange(measurement=lambda name, a, fs: 1.1 * a)
    _evaluate(camp, store, measured)
    assert store.misses == 2  # the base runs only
    from vadsim import extra_force

    core_object = ModelChange(extras=[extra_force("hydraulic", acts_on="anvil", c=1e-6)])
    spec = ModelChange(extras=[ExtraSpec.of("hydraulic", acts_on="anvil", c=1e-6)])
    _evaluate(camp, store, core_object)
    assert store.misses == 2 and store.hits == 2
    _evaluate(camp, store, spec)
    assert store.misses == 4 and store.hits == 4


def test_a_second_diagnosis_reads_every_run_its_worker_processes_made(tmp_path):
    """The folder crosses to the diagnosis' worker processes: a second, identical diagnosis
    finds every run stored (no new file) and reaches the same result."""
    from vadsim.fit.diagnosis import diagnose

    camp = synthetic_campaign("7in-cde", (250.0, 400.0, 550.0), seed=6, **SMALL)
    kw = dict(candidates=["rock_stiffness"], phases=1, progress=False, workers=2,
              cache=tmp_path, **RUN)
    first = diagnose(camp, **kw)
    stored = sorted(p.name for p in tmp_path.rglob("*.json.z"))
    assert len(stored) > 20
    second = diagnose(camp, **kw)
    assert sorted(p.name for p in tmp_path.rglob("*.json.z")) == stored
    a, b = first.as_json(), second.as_json()
    a.pop("elapsed_s"), b.pop("elapsed_s")
    assert a == b


def test_folding_only_the_recordings_periods_changes_no_residual():
    """The model folds only the periods its recordings folded at; the compared residuals
    are the ones a measurement of every period gives."""
    camp = synthetic_campaign("7in-cde", FLOWS, seed=6, **SMALL)
    settings = RunSettings("7in-cde", **RUN)
    with CampaignEvaluator(camp, settings, phases=2, workers=1, cache=False) as narrow, \
            CampaignEvaluator(camp, settings, phases=2, workers=1, cache=False) as every:
        assert any(narrow.fold_periods.values())  # some recording folded
        every.fold_periods = {}
        np.testing.assert_array_equal(narrow.residuals("b", None), every.residuals("b", None))
        assert narrow.keys == every.keys
        sim_n, sim_e = narrow.simulate(None, "e01"), every.simulate(None, "e01")
        assert set(sim_n.sensor) < set(sim_e.sensor)  # fewer features were measured
