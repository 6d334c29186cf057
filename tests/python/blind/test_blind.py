"""The blind benchmark: scenario classes, concealed campaigns on disk, and the scoring rules
(on hand-written results and truths; no diagnosis runs here)."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import pytest
import vadsim.blind as blind
from vadsim.blind import (
    CLASSES,
    DEFAULT_SCENARIOS,
    FIVE_FLOWS,
    Scenario,
    blind_benchmark,
    class_counts,
    normalise_result,
    scenarios_of,
    score,
    write_campaigns,
)
from vadsim.fit.candidates import CANDIDATES
from vadsim.model.change import ModelChange, rest_phase
from vadsim.model.settings import RunSettings

# ------------------------------------------------------------------------------ hand-written

HYD = {"key": "hydraulic_force[anvil]", "id": "hydraulic_force",
       "values": {"f_ref": 60.0, "n": 2.0}}
FRI = {"key": "anvil_friction", "id": "anvil_friction", "values": {"force": 100.0}}


def _truth(cls: str, *truths: dict, nuisance: dict | None = None) -> dict:
    return {"class": cls, "ids": [t["id"] for t in truths], "keys": [t["key"] for t in truths],
            "truths": list(truths), "nuisance": nuisance or {}}


def _result(verdict: str, keys: list[str], params: dict | None = None, before: float = 4.0,
            after: float = 1.0, nuisance: dict | None = None) -> dict:
    ids = [k.partition("[")[0] for k in keys] or ["none"]
    return {"verdict": verdict, "missing_physics": ids,
            "missing_physics_keys": keys or ["none"], "parameters": params or {},
            "intervals": {}, "nuisance": {k: {"value": v, "interval": [v, v]}
                                          for k, v in (nuisance or {}).items()},
            "heldout_error_before": before, "heldout_error_after": after, "elapsed_s": 10.0}


def test_a_pair_is_correct_in_either_order_and_variants_are_scored_apart():
    truth = {"p1": _truth("pair", HYD, FRI), "p2": _truth("pair", HYD, FRI)}
    res = {"p1": _result("explained", ["anvil_friction", "hydraulic_force[anvil]"],
                         {"anvil_friction": {"force": 110.0},
                          "hydraulic_force": {"acts_on": "anvil", "f_ref": 45.0, "n": 2.0}}),
           "p2": _result("explained", ["hydraulic_force[bit]", "anvil_friction"])}
    sc = score(res, truth)
    r1, r2 = sc["campaigns"]
    assert r1["correct"] and r1["variant_correct"]
    assert r2["correct"] and r2["variant_correct"] is False  # right ids, wrong body
    assert r1["parameter_error"] == {"hydraulic_force.f_ref": pytest.approx(0.25),
                                     "hydraulic_force.n": pytest.approx(0.0),
                                     "anvil_friction.force": pytest.approx(0.1)}
    assert sc["classes"]["pair"]["identification_rate"] == 1.0
    assert sc["classes"]["pair"]["variant_rate"] == 0.5


def test_one_of_a_pair_is_a_miss_but_its_parameters_are_scored():
    sc = score({"p": _result("explained", ["hydraulic_force[anvil]"],
                             {"hydraulic_force": {"f_ref": 66.0, "n": 2.0}})},
               {"p": _truth("pair", HYD, FRI)})
    r = sc["campaigns"][0]
    assert not r["correct"]
    assert r["parameter_error"]["hydraulic_force.f_ref"] == pytest.approx(0.1)
    assert sc["identification_by_candidate"] == {"anvil_friction": 0.0, "hydraulic_force": 1.0}


def test_unexplained_is_a_false_alarm_on_a_null_and_a_miss_on_an_effect():
    truth = {"n1": _truth("null"), "n2": _truth("null"), "n3": _truth("null"),
             "e1": _truth("generic", FRI)}
    res = {"n1": _result("none", [], before=0.3, after=0.3),
           "n2": _result("unexplained", [], before=3.0, after=3.0),
           "n3": _result("explained", ["anvil_friction"]),
           "e1": _result("unexplained", ["anvil_friction"], {"anvil_friction": {"force": 90.0}})}
    sc = score(res, truth)
    rows = {r["campaign"]: r for r in sc["campaigns"]}
    assert rows["n1"]["correct"] and rows["n1"]["false_alarm"] is False
    assert rows["n2"]["false_alarm"] and rows["n3"]["false_alarm"]
    assert not rows["e1"]["correct"] and rows["e1"]["false_alarm"] is None
    assert sc["false_alarms"] == 2 and sc["null_campaigns"] == 3
    assert sc["classes"]["null"]["identification_rate"] == pytest.approx(1 / 3)
    crit = {c["criterion"]: c["status"] for c in sc["criteria"]}
    assert crit[blind.CRITERIA["false_alarms"]] == "FAIL"
    assert crit[blind.CRITERIA["identification"]] == "FAIL"


def test_old_format_results_and_truths_still_score():
    # the format of results/<name>.json and truth.json before classes (one id, flat values)
    truth = {"a": {"id": "hydraulic_force", "key": "hydraulic_force[anvil]",
                   "values": {"c": 4e-4}, "parameters": {}},
             "b": {"id": "sensor_chain", "values": {"f_res_hz": 400.0, "q": 5.0},
                   "parameters": {}},
             "n1": {"id": "none", "values": {}, "parameters": {}},
             "n2": {"id": "none", "values": {}, "parameters": {}}}
    res = {"a": {"missing_physics": "hydraulic_force", "parameters": {"acts_on": "anvil",
                                                                      "c": 5e-4},
                 "heldout_error_before": 4.0, "heldout_error_after": 1.0},
           "b": {"missing_physics": "none", "parameters": {},
                 "heldout_error_before": 2.0, "heldout_error_after": 2.0},
           "n1": {"missing_physics": "none", "parameters": {},
                  "heldout_error_before": 0.3, "heldout_error_after": 0.3},
           "n2": {"missing_physics": "contact_law", "parameters": {"hc_alpha": 1.0},
                  "heldout_error_before": 0.3, "heldout_error_after": 0.2}}
    norm = normalise_result(res["a"])
    assert norm["ids"] == ["hydraulic_force"] and norm["verdict"] == "explained"
    assert norm["parameters"] == {"hydraulic_force": {"acts_on": "anvil", "c": 5e-4}}
    assert norm["keys"] is None
    sc = score(res, truth)
    assert list(sc["classes"]) == ["default"]
    assert sc["identification_rate"] == 0.5
    assert sc["identification_by_candidate"] == {"hydraulic_force": 1.0, "sensor_chain": 0.0}
    assert sc["false_alarms"] == 1 and sc["null_campaigns"] == 2
    assert sc["parameter_error_median"]["hydraulic_force.c"] == pytest.approx(0.25)
    assert sc["heldout_improvement_min"] == pytest.approx(0.0)  # the missed sensor chain
    assert sc["campaigns"][0]["variant_correct"] is None  # no keys: unknown


def test_per_class_rates_gains_nuisance_and_criteria():
    truth = {"a": _truth("nuisance_effect", FRI, nuisance={"wob_scale": 1.1}),
             "b": _truth("nuisance_effect", HYD, nuisance={"wob_scale": 0.9}),
             "c": _truth("nuisance_null", nuisance={"wob_scale": 1.1, "theta0": 3.1}),
             "d": _truth("null")}
    res = {"a": _result("explained", ["anvil_friction"], {"anvil_friction": {"force": 100.0}},
                        before=5.0, after=1.0, nuisance={"wob_scale": 1.05}),
           "b": _result("explained", ["hydraulic_force[anvil]"],
                        {"hydraulic_force": {"f_ref": 60.0, "n": 0.0}}, before=4.0, after=3.0),
           "c": _result("none", [], nuisance={"wob_scale": 1.12, "theta0": 0.05}),
           "d": _result("none", [], nuisance={"wob_scale": 1.0})}
    sc = score(res, truth, class_order=list(CLASSES))
    assert list(sc["classes"]) == ["null", "nuisance_null", "nuisance_effect"]
    ne = sc["classes"]["nuisance_effect"]
    assert ne["identification_rate"] == 1.0 and ne["effect_campaigns"] == 2
    assert ne["heldout_improvement_median"] == pytest.approx((0.8 + 0.25) / 2)
    assert ne["heldout_improvement_min"] == pytest.approx(0.25)
    assert ne["parameter_error_median"]["hydraulic_force.n"] == pytest.approx(1.0)
    assert ne["wob_scale_error_median"] == pytest.approx(0.05)  # |1.05-1.1|, b has none
    rows = {r["campaign"]: r for r in sc["campaigns"]}
    # theta0 is periodic in pi: 0.05 is pi - 3.05 from 3.1
    assert rows["c"]["theta0_error"] == pytest.approx(math.pi - 3.05, abs=1e-9)
    assert rows["d"]["wob_scale_error"] == pytest.approx(0.0)
    assert sc["overall"]["false_alarms"] == 0
    crit = {c["criterion"]: c for c in sc["criteria"]}
    assert crit[blind.CRITERIA["identification"]]["status"] == "PASS"
    assert crit[blind.CRITERIA["false_alarms"]]["status"] == "PASS"
    assert crit[blind.CRITERIA["heldout"]]["status"] == "FAIL"  # b improved 25 % only
    assert "1 of 2" in crit[blind.CRITERIA["heldout"]]["detail"]


def test_interval_coverage_counts_true_values_inside_their_reported_intervals():
    """A found effect's true parameters and the true WOB scale (1 unless set) are scored
    against the reported 95 % intervals; a missed effect's parameters are not scored."""
    truth = {"a": _truth("nuisance_effect", HYD, nuisance={"wob_scale": 0.9}),
             "b": _truth("single", FRI),
             "c": _truth("null")}
    a = _result("explained", ["hydraulic_force[anvil]"],
                {"hydraulic_force": {"f_ref": 61.0, "n": 2.3}}, nuisance={"wob_scale": 0.95})
    a["intervals"] = {"hydraulic_force": {"f_ref": [55.0, 65.0], "n": [2.1, 2.5]}}
    a["nuisance"]["wob_scale"]["interval"] = [0.88, 0.97]
    b = _result("none", [], nuisance={"wob_scale": 1.02})  # friction missed
    b["nuisance"]["wob_scale"]["interval"] = [1.01, 1.03]
    c = _result("none", [], nuisance={"wob_scale": 0.99})
    c["nuisance"]["wob_scale"]["interval"] = [0.95, 1.04]
    sc = score({"a": a, "b": b, "c": c}, truth)
    rows = {r["campaign"]: r for r in sc["campaigns"]}
    assert rows["a"]["interval_covers"] == {"hydraulic_force.f_ref": True,
                                            "hydraulic_force.n": False, "wob_scale": True}
    assert rows["b"]["interval_covers"] == {"wob_scale": False}
    assert rows["c"]["interval_covers"] == {"wob_scale": True}
    assert (sc["overall"]["intervals_covering"], sc["overall"]["intervals_scored"]) == (3, 5)


def test_criteria_without_campaigns_to_judge_are_not_applicable():
    sc = score({"n": _result("none", [])}, {"n": _truth("null")})
    status = {c["criterion"]: c["status"] for c in sc["criteria"]}
    assert status[blind.CRITERIA["heldout"]] == "n/a"
    assert status[blind.CRITERIA["false_alarms"]] == "PASS"


def test_criteria_of_size_false_alarms_regret_and_coverage_at_their_limits():
    """One false alarm passes among 10 null-like campaigns and fails among 9; regret within
    the noise must hold in 95 % of the scored campaigns; coverage must lie in 90-98 %; the
    benchmark must hold 40 campaigns, 12 of them independent."""
    def run(n_null: int, alarms: int, failures: int, covered: int, independent: int) -> dict:
        truth, res = {}, {}
        for i in range(n_null):
            name = f"n{i:02d}"
            truth[name] = {**_truth("null"), "generator": ("independent" if i < independent
                                                            else "vadsim")}
            r = _result("unexplained" if i < alarms else "none", [], before=0.3, after=0.3,
                        nuisance={"wob_scale": 1.0})
            r["nuisance"]["wob_scale"]["interval"] = [0.9, 1.1] if i < covered else [1.2, 1.3]
            r["regret"] = {"regret": 5.0, "noise": 1.0, "search_failure": i < failures}
            res[name] = r
        return {c["criterion"]: c for c in score(res, truth)["criteria"]}

    crit = run(10, alarms=1, failures=0, covered=9, independent=3)
    assert crit[blind.CRITERIA["false_alarms"]]["status"] == "PASS"
    assert crit[blind.CRITERIA["regret"]]["status"] == "PASS"
    assert crit[blind.CRITERIA["coverage"]]["status"] == "PASS"  # 90 %
    assert crit[blind.CRITERIA["size"]]["status"] == "FAIL"
    assert crit[blind.CRITERIA["size"]]["detail"] == (
        "10 campaigns, 3 from the independent generator")
    crit = run(9, alarms=1, failures=1, covered=9, independent=0)
    assert crit[blind.CRITERIA["false_alarms"]]["status"] == "FAIL"
    assert crit[blind.CRITERIA["regret"]]["status"] == "FAIL"  # 8 of 9 within the noise
    assert crit[blind.CRITERIA["coverage"]]["status"] == "FAIL"  # 100 %: too wide
    crit = run(40, alarms=0, failures=2, covered=37, independent=12)
    assert crit[blind.CRITERIA["size"]]["status"] == "PASS"
    assert crit[blind.CRITERIA["regret"]]["status"] == "PASS"  # 38 of 40 = 95 %
    assert crit[blind.CRITERIA["coverage"]]["detail"] == "37 of 40 true values (92 %)"


# --------------------------------------------------------------------------------- scenarios

def test_default_classes_and_counts():
    counts = class_counts()
    assert counts == {"null": 3, "nuisance_null": 4, "nuisance_effect": 4, "pair": 4,
                      "generic": 5, "one_sensor": 3, "rc_bit": 3, "five_events": 3,
                      "noise_1g": 3, "indep_null": 3, "indep_excitation": 3,
                      "indep_hydraulic": 2, "indep_friction": 2, "indep_contact": 2}
    assert sum(counts.values()) >= 30 and set(counts) == set(CLASSES)
    by = {c: scenarios_of([c]) for c in counts}
    assert all(s.is_null for s in by["null"] + by["nuisance_null"] + by["indep_null"])
    assert all(s.nuisance for s in by["nuisance_null"] + by["nuisance_effect"])
    assert all(len(s.truths) == 2 for s in by["pair"])
    assert all(s.preset == "7in-rc" for s in by["rc_bit"])
    assert all(s.flows == FIVE_FLOWS for s in by["five_events"])
    assert all(s.noise_g == 1.0 for s in by["noise_1g"])
    for c in ("rc_bit", "five_events", "noise_1g"):
        assert sum(s.is_null for s in by[c]) == 1
    with pytest.raises(ValueError, match="unknown blind class"):
        scenarios_of(["pairs"])


def test_theta0_truths_are_03_rad_from_the_rest_phase():
    rest = rest_phase(RunSettings("7in-cde"))
    shifts = sorted(s.nuisance["theta0"] - rest for s in DEFAULT_SCENARIOS
                    if "theta0" in s.nuisance)
    assert shifts == [pytest.approx(-0.3, abs=0.01), pytest.approx(0.3, abs=0.01)]


def test_scenario_ids_and_refusals():
    s = Scenario("pair", (("hydraulic_force[anvil]", {"f_ref": 60}), ("contact_law", {})))
    assert s.ids == ["hydraulic_force", "contact_law"]
    assert s.keys == ["hydraulic_force[anvil]", "contact_law"]
    with pytest.raises(ValueError, match="nuisance"):
        Scenario("x", nuisance={"wob": 1.1})
    with pytest.raises(ValueError, match="one id twice"):
        Scenario("x", (("hydraulic_force[anvil]", {}), ("hydraulic_force[bit]", {})))


def test_the_truth_change_goes_through_the_library_and_adds_the_nuisance():
    seen = []

    class Stub:
        def __init__(self, key):
            self.key = key

        def change(self, values):
            seen.append((self.key, dict(values)))
            return ModelChange(scales={"kI": values["factor"]})

    lib = {"contact_stiffness[impact]": Stub("i"), "mass[anvil]": Stub("m")}
    s = Scenario("x", (("contact_stiffness[impact]", {"factor": 2.0}),
                       ("mass[anvil]", {"factor": 1.5})), {"wob_scale": 1.1, "theta0": 2.5})
    ch = s.change(lib)
    assert seen == [("i", {"factor": 2.0}), ("m", {"factor": 1.5})]
    assert ch.scales == {"kI": pytest.approx(3.0), "wob": 1.1} and ch.theta0 == 2.5
    assert Scenario("null").change(lib).changes_run is False
    with pytest.raises(ValueError, match="not in the candidate library"):
        Scenario("x", (("rock_stiffness", {"factor": 0.4}),)).change(lib)


def _unavailable(key: str, values) -> str | None:
    """Why a truth cannot be built on this branch (None: it can)."""
    if key not in CANDIDATES:
        return f"{key} is not in this branch's candidate library"
    names = {p.name for p in CANDIDATES[key].params}
    if names != set(values):
        return f"{key} has parameters {sorted(names)} here, the truth {sorted(values)}"
    return None


@pytest.mark.parametrize("scenario", DEFAULT_SCENARIOS,
                         ids=[f"{s.class_name}-{'+'.join(s.keys) or 'none'}"
                              for s in DEFAULT_SCENARIOS])
def test_every_default_truth_builds_a_valid_change(scenario):
    if scenario.generator == "independent":  # scored as library keys at in-bound values
        for k, v in scenario.truths:
            assert k in CANDIDATES and (not v or CANDIDATES[k].check(v))
        return
    why = [w for k, v in scenario.truths if (w := _unavailable(k, v))]
    if why:
        pytest.skip("; ".join(why) + " (the new library is built on another branch; this "
                    "runs fully once it is merged)")
    ch = scenario.change()
    assert ch.changes_run or ch.measurement is not None or scenario.is_null
    ch.apply(RunSettings(scenario.preset), scenario.flows[0])


def test_detectability_is_noise_for_a_null_and_large_for_friction():
    flows = (300.0, 500.0)
    kw = dict(duration_s=2.0, cycles=120, analyse_cycles=80, phases=2, workers=1)
    null = blind.detectability(Scenario("null", flows=flows), **kw)
    fric = blind.detectability(Scenario("x", (("anvil_friction", {"force": 150.0}),),
                                        {"wob_scale": 1.1}, flows=flows), **kw)
    assert list(null) == list(flows) and max(null.values()) < 1.0
    assert min(fric.values()) > 2.0


# ------------------------------------------------------------------------- campaigns on disk

SMALL = dict(duration_s=1.0, cycles=60, analyse_cycles=40)
FLOWS3 = (300.0, 400.0, 500.0)
TOY = (Scenario("null", flows=FLOWS3),
       Scenario("nuisance_effect", (("anvil_friction", {"force": 100.0}),), {"wob_scale": 1.1},
                flows=FLOWS3),
       Scenario("null", flows=FLOWS3),
       Scenario("rc_bit", (("anvil_friction", {"force": 80.0}),), preset="7in-rc",
                flows=FLOWS3))


def test_written_campaigns_conceal_their_class_and_truth(tmp_path):
    paths = write_campaigns(tmp_path, TOY, classes=["null", "nuisance_effect"], **SMALL)
    assert [p.name for p in paths] == sorted(p.name for p in paths)
    assert all(p.name.startswith("blind-0") for p in paths) and len(paths) == 3
    truth = json.loads((tmp_path / "truth.json").read_text())
    assert sorted(truth) == [p.name for p in paths]
    assert sorted(t["class"] for t in truth.values()) == ["nuisance_effect", "null", "null"]
    eff = next(t for t in truth.values() if t["class"] == "nuisance_effect")
    assert eff["keys"] == ["anvil_friction"] and eff["nuisance"] == {"wob_scale": 1.1}
    for p in paths:
        text = (p / "campaign.toml").read_text()
        for word in ("null", "nuisance", "friction", "wob_scale", "class"):
            assert word not in text
        assert "wob_klbf = 4.0" in text  # the stated WOB stays nominal
        assert sorted(f.name for f in p.iterdir()) == ["campaign.toml", "e01.csv", "e02.csv",
                                                       "e03.csv"]


def test_classes_written_later_get_the_names_of_a_full_write(tmp_path):
    write_campaigns(tmp_path / "a", TOY, classes=["rc_bit"], **SMALL)
    first = json.loads((tmp_path / "a" / "truth.json").read_text())
    write_campaigns(tmp_path / "a", TOY, **SMALL)
    write_campaigns(tmp_path / "b", TOY, classes=["rc_bit"], **SMALL)
    later = json.loads((tmp_path / "a" / "truth.json").read_text())
    assert len(later) == 4 and all(later[n] == t for n, t in first.items())
    name = next(iter(first))
    csv = (tmp_path / "a" / name / "e01.csv").read_text()
    assert csv == (tmp_path / "b" / name / "e01.csv").read_text()
    with pytest.raises(ValueError, match="other settings"):
        write_campaigns(tmp_path / "a", TOY, seed=1, **SMALL)


def test_benchmark_resumes_passes_diagnose_kwargs_and_writes_scores(tmp_path, monkeypatch):
    calls = []

    def fake_diagnose(camp, **kw):
        calls.append((camp.name, kw))
        js = _result("none", [], before=0.3, after=0.3, nuisance={"wob_scale": 1.0})
        return SimpleNamespace(as_json=lambda: js, elapsed_s=1.0)

    monkeypatch.setattr(blind, "diagnose", fake_diagnose)
    kw = dict(scenarios=TOY, progress=False, diagnose_kwargs={"max_effects": 2}, **SMALL)
    sc = blind_benchmark(tmp_path, ["null", "nuisance_effect"], **kw)
    assert len(calls) == 3 and calls[0][1]["max_effects"] == 2
    assert calls[0][1]["progress"] is False and calls[0][1]["cycles"] == 60
    assert list(sc["classes"]) == ["null", "nuisance_effect"]
    assert sc["classes"]["nuisance_effect"]["identification_rate"] == 0.0
    md = (tmp_path / "scores.md").read_text()
    assert "**FAIL**: identification >= 90 % in every class" in md
    assert "**PASS**: false alarms in at most 1 of 10 null-like campaigns" in md
    assert "**FAIL**: at least 40 campaigns" in md
    assert "Class `nuisance_effect`" in md and "anvil_friction (force=100)" in md
    assert json.loads((tmp_path / "scores.json").read_text())["overall"]["campaigns"] == 3
    sc = blind_benchmark(tmp_path, None, **kw)  # reuses 3 results, diagnoses the rc_bit one
    assert len(calls) == 4 and sc["overall"]["campaigns"] == 4


def test_an_earlier_benchmark_folder_is_scored_as_it_is(tmp_path, monkeypatch):
    """A folder of the benchmark before classes (truth.json with one id, no benchmark.json)
    is neither rewritten nor diagnosed again: its results score in class "default"."""
    camp = tmp_path / "campaigns"
    (camp / "blind-01").mkdir(parents=True)
    (camp / "blind-01" / "campaign.toml").write_text("name = 'blind-01'\n")
    (camp / "truth.json").write_text(json.dumps(
        {"blind-01": {"id": "anvil_friction", "key": "anvil_friction",
                      "values": {"force": 60.0}, "parameters": {"force": 60.0}}}))
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "blind-01.json").write_text(json.dumps(
        {"missing_physics": "anvil_friction", "parameters": {"force": 63.0},
         "heldout_error_before": 5.0, "heldout_error_after": 1.0, "elapsed_s": 90.0}))
    monkeypatch.setattr(blind, "diagnose", lambda *a, **k: pytest.fail("diagnosed again"))
    sc = blind_benchmark(tmp_path, progress=False)
    assert sc["classes"]["default"]["identification_rate"] == 1.0
    assert sc["parameter_error_median"]["anvil_friction.force"] == pytest.approx(0.05)
    assert not (camp / "benchmark.json").exists()
    assert "Class `default`" in (tmp_path / "scores.md").read_text()


def test_a_score_sheet_of_nulls_only_renders():
    from vadsim.report.blind import blind_markdown

    sc = score({"n": _result("none", [])}, {"n": _truth("null")}, list(CLASSES))
    md = blind_markdown(sc, {}, CLASSES)
    assert "**n/a**: held-out error down" in md and "Found, per true candidate" not in md
