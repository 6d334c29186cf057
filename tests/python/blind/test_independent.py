"""The independent campaign generator (vadsim.blind.independent): agreement with the core on
the nominal model, what each effect changes, the campaigns it writes, its independence from
vadsim's model and sensor layers, and its place in the blind benchmark. Budgets are cycle and
sample counts (tens of cycles, 1-2 s records), never wall-clock times."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import numpy as np
import pytest
import vadsim
from vadsim.blind import DEFAULT_SCENARIOS, class_counts, score, write_campaigns
from vadsim.blind.independent import (
    IndependentModel,
    IndependentSpec,
    build_effect,
    nearest_library,
    preset_params,
    record_event,
    run_summary,
    write_campaign,
)
from vadsim.blind.independent.model import settle
from vadsim.blind.independent.recording import OVERSAMPLING
from vadsim.blind.scenarios import INDEPENDENT_SCENARIOS, Scenario
from vadsim.campaigns import load_campaign

PACKAGE = Path(vadsim.__file__).resolve().parent / "blind" / "independent"
P7 = preset_params("7in-cde")

# ------------------------------------------------------------------- agreement with the core

CYCLES, ANALYSE = 60, 40


@pytest.mark.parametrize("flow", [200.0, 300.0, 600.0])
def test_the_nominal_model_agrees_with_the_core(flow):
    """Z of the impact face and spring, and J*, against vadsim.simulate over the same run
    (60 cycles from the static state, the last 40 analysed; both LSODA/CVODE at rtol 1e-6).

    Tolerances: these flows are periodic regimes (1 and 5), where MODEL.md expects correct
    integrators to agree to < 1 %; Z is an integer count over 40 cycles, so equal. J* within
    2 %: at 600 gal/min 60 cycles are not quite settled (the window still carries a decaying
    transient, which two integrators with different step sequences follow to ~1 %); at 200
    and 300 gal/min they agree to 0.05 %."""
    mine = run_summary(P7, flow, CYCLES, ANALYSE)
    core = vadsim.simulate("7in-cde", flow, cycles=CYCLES, analyse_cycles=ANALYSE,
                           record="none")
    assert mine["z"]["impact"] == pytest.approx(core.z["impact"], abs=1e-9)
    assert mine["z"]["spring"] == pytest.approx(core.z["spring"], abs=1e-9)
    assert mine["jstar_pos"] == pytest.approx(core.impulse_pos, rel=0.02)
    assert mine["jstar_mean"] == pytest.approx(core.impulse_mean, rel=0.02)


def test_the_static_state_is_at_rest():
    """MODEL.md's static on-bottom state under the WOB: no net force with the flow's force
    off (the excitation is the only force left at t with cos = 0)."""
    m = IndependentModel(P7, 200.0)
    t_quiet = (np.pi / 2 - P7["phi"]) / m.omega  # cos(omega t + phi) = 0
    f = m.forces(t_quiet, m.x_static.tolist(), [0.0] * 7)
    assert np.max(np.abs(f)) < 1e-6 * P7["wob"]


def test_the_settle_waits_for_a_slow_approach_to_steady_motion():
    """At 550 gal/min (near a period doubling) 100 cycles leave a period-2 transient that the
    1024 Hz fold sees; the settle runs on until the stroboscopic state stops drifting. At 650
    gal/min the motion settles within one more block."""
    slow = settle(IndependentModel(P7, 550.0), 100)
    fast = settle(IndependentModel(P7, 650.0), 100)
    assert slow[2] >= 2 and fast[2] <= 1
    assert slow[0] == pytest.approx((100 + 50 * slow[2]) / IndependentModel(P7, 550).f_exc_hz)


# ----------------------------------------------------------------------------------- effects

def _summary(flow, *effects, cycles=40, analyse=20):
    built = [build_effect(n, v, P7) for n, v in effects]
    return run_summary(P7, flow, cycles, analyse, effects=built)


def test_excitation_power_at_p0_factor1_is_the_nominal_model():
    nominal = _summary(300.0)
    same = _summary(300.0, ("excitation_power", {"factor": 1.0, "p": 0.0}))
    assert same["jstar_pos"] == pytest.approx(nominal["jstar_pos"], rel=1e-9)


def test_excitation_power_p05_changes_nothing_at_400_and_grows_with_flow():
    """Fo (Q/400)^0.5: the same force at 400 gal/min, 22 % more at 600."""
    m = IndependentModel(P7, 600.0)
    eff = build_effect("excitation_power", {"factor": 1.0, "p": 0.5}, P7)
    x, v = m.x_static.tolist(), [0.0] * 7
    gain = eff(0.0, x, v, 600.0)[1] / m.forces(0.0, x, v)[1]
    assert gain == pytest.approx((600 / 400) ** 0.5 - 1.0, rel=1e-9)
    assert eff(0.0, x, v, 400.0)[1] == pytest.approx(0.0, abs=1e-12)


def test_hertz_contact_changes_the_impact_peak_and_never_pulls():
    nominal = _summary(200.0)
    hertz = _summary(200.0, ("hertz_contact", {"stiffness": 2.0, "damping": 0.4}))
    assert abs(hertz["peak_x1_g"] / nominal["peak_x1_g"] - 1.0) > 0.05
    eff = build_effect("hertz_contact", {"stiffness": 1.0, "damping": 0.2}, P7)
    m = IndependentModel(P7, 200.0, [eff])
    x = m.x_static.copy()
    x[1] += 1e-4  # anvil 0.1 mm into the bit, separating fast
    v = [0.0, -5.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    kv = m.impact_force(x.tolist(), v)
    assert kv < 0  # Kelvin-Voigt pulls while separating fast...
    assert kv + eff(0.0, x.tolist(), v, 200.0)[0] == pytest.approx(0.0, abs=1e-9)  # Hertz no


@pytest.mark.parametrize("flow", [200.0, 300.0])
def test_the_hertz_face_is_the_library_member_it_is_scored_as(flow):
    """The generator's Hertz face (its own code: k_h d^1.5 (1 + 1.5 damping d') added as a
    correction to the Kelvin-Voigt face) and the core's ``contact_law[impact]`` at the point
    nearest_library names: the same run, while the face moves the bit's peak far from the
    nominal one. Regime-1 flows, periodic within 60 cycles. Measured: Z equal, the bit's peak
    33.08 vs 33.08 g at 200 gal/min and 78.42 vs 78.41 g at 300 (nominal 65.6 and 111.5 g);
    1 % allows for two integrators' step sequences (the core locates the face's lift-off as
    a root, the generator's LSODA steps across it). run_summary's J* is the Kelvin-Voigt
    face's impulse whatever the effect, so it is not compared."""
    from vadsim.fit.candidates import CANDIDATES
    from vadsim.model.settings import RunSettings

    effect = ("hertz_contact", {"stiffness": 2.0, "damping": 0.4})
    key, values, exact = nearest_library(*effect, (flow,), P7)
    assert exact
    settings = RunSettings("7in-cde", cycles=CYCLES, analyse_cycles=ANALYSE, steady="full")
    core = CANDIDATES[key].change(values).apply(settings, flow).run(flow, record="window")
    nominal = settings.run(flow, record="window")
    mine = _summary(flow, effect, cycles=CYCLES, analyse=ANALYSE)

    def bit_peak(r: vadsim.SimulationResult) -> float:
        return float(np.max(r.window_peaks_g[:, 0]))

    assert mine["z"] == pytest.approx(core.z, abs=1e-9)
    assert mine["peak_x1_g"] == pytest.approx(bit_peak(core), rel=0.01)
    assert abs(bit_peak(core) / bit_peak(nominal) - 1.0) > 0.2


@pytest.mark.parametrize("force,static,v_s,v0", [(100.0, 160.0, 0.05, 0.005),
                                                  (140.0, 200.0, 0.1, 0.01)])
def test_the_stribeck_friction_is_near_its_library_member(force, static, v_s, v0):
    """The generator's Stribeck friction (algebraic regularisation v / sqrt(v^2 + v0^2)) and
    the library's ``anvil_friction[stribeck]`` at the point nearest_library names (tanh(v /
    1 mm/s)) at 300 gal/min: the same regime and the bit's peak closer than Coulomb friction
    at the kinetic level alone (the peak is physics the library holds; the regularisation
    is not). Measured: generator 44.31 g, member 43.64, Coulomb 45.15 (the first truth);
    28.21, 26.29, 30.85 (the second); nominal 111.5."""
    from vadsim.fit.candidates import CANDIDATES
    from vadsim.model.settings import RunSettings

    flow = 300.0
    effect = ("friction_stribeck", {"force": force, "static": static, "v_s": v_s, "v0": v0})
    key, values, exact = nearest_library(*effect, (flow,), P7)
    assert key == "anvil_friction[stribeck]" and not exact
    assert values == pytest.approx({"force": force, "peak": static / force, "v_s": v_s})
    settings = RunSettings("7in-cde", cycles=CYCLES, analyse_cycles=ANALYSE, steady="full")
    member = CANDIDATES[key].change(values).apply(settings, flow).run(flow, record="window")
    coulomb = CANDIDATES["anvil_friction"].change({"force": force}).apply(settings, flow).run(
        flow, record="window")
    mine = _summary(flow, effect, cycles=CYCLES, analyse=ANALYSE)

    def bit_peak(r: vadsim.SimulationResult) -> float:
        return float(np.max(r.window_peaks_g[:, 0]))

    assert mine["z"] == pytest.approx(member.z, abs=1e-9)
    near = abs(bit_peak(member) / mine["peak_x1_g"] - 1.0)
    assert near < 0.1 and near < abs(bit_peak(coulomb) / mine["peak_x1_g"] - 1.0)


def test_hydraulic_and_friction_change_the_run_where_they_should():
    """The quadratic force with its onset at 450 gal/min is nearly nothing at 200 and
    changes J* at 600; Stribeck friction changes J* at 200 (short strokes)."""
    hyd = ("hydraulic_quadratic", {"f400": 45.0, "q_on": 450.0, "width": 40.0})
    low = _summary(200.0, hyd)["jstar_pos"] / _summary(200.0)["jstar_pos"]
    high = _summary(600.0, hyd)["jstar_pos"] / _summary(600.0)["jstar_pos"]
    assert abs(low - 1.0) < 0.01 and abs(high - 1.0) > 0.05
    fri = ("friction_stribeck", {"force": 140.0, "static": 200.0, "v_s": 0.1, "v0": 0.01})
    assert abs(_summary(200.0, fri)["jstar_pos"] / _summary(200.0)["jstar_pos"] - 1) > 0.05


def test_friction_opposes_sliding_with_its_stribeck_peak():
    eff = build_effect("friction_stribeck", {"force": 100.0, "static": 160.0, "v_s": 0.05,
                                             "v0": 0.005}, P7)
    x = [0.0] * 7

    def on_anvil(w: float) -> float:
        return float(eff(0.0, x, [0.0, w, 0.0, 0, 0, 0, 0], 300.0)[1])

    assert on_anvil(1.0) == pytest.approx(-100.0, rel=1e-3)  # kinetic level
    assert -on_anvil(0.02) > 130.0  # near the static peak
    assert on_anvil(-1.0) == pytest.approx(100.0, rel=1e-3) and on_anvil(0.0) == 0.0


def test_scoring_values_of_the_effects():
    assert nearest_library("excitation_power", {"factor": 1.0, "p": 0.5}, (200.0,)) == (
        "excitation_amplitude", {"factor": 1.0, "p": 0.5}, True)
    key, vals, exact = nearest_library(
        "hydraulic_quadratic", {"f400": 60.0, "q_on": 350.0, "width": 50.0},
        (200.0, 400.0, 650.0))
    assert key == "hydraulic_force[anvil]" and not exact and 1.0 <= vals["n"] <= 3.0
    key, vals, exact = nearest_library("hertz_contact", {"stiffness": 2.0, "damping": 0.4},
                                       (300.0,))
    # 1.5 x 0.4 s/m x 2 x kI 120000 x 1 mm / cI 469 (Table 2.1's 7in impact face)
    assert (key, exact) == ("contact_law[impact]", True)
    assert vals == pytest.approx({"stiffness": 2.0, "factor": 0.6 * 2 * 120.0 / 469.0})


# -------------------------------------------------------------------------- written campaign

def test_the_written_campaign_loads_with_its_sensors_noise_and_clipping(tmp_path):
    spec = IndependentSpec(flows=(300.0, 600.0), duration_s=1.0, noise_g=0.3,
                           settle_cycles=20)
    write_campaign(tmp_path / "c", spec, seed=3, name="t")
    camp = load_campaign(tmp_path / "c")
    assert [e.flow_gpm for e in camp.events] == [300.0, 600.0]
    assert {k: (s.dof, s.rate_hz, s.range_g, s.lowpass_hz) for k, s in camp.sensors.items()} \
        == {"x1": (1, 1024.0, 250.0, 400.0), "x5": (5, 1024.0, 250.0, 400.0)}
    for ev in camp.events:
        assert len(ev.data) == 1024
        assert np.allclose(np.diff(ev.data["time_s"]), 1 / 1024, rtol=1e-6)
        assert ev.data[["x1_g", "x5_g"]].abs().to_numpy().max() <= 250.0
    # same seed, same campaign; the noise is what a noise-free record lacks
    write_campaign(tmp_path / "d", spec, seed=3, name="t")
    assert (tmp_path / "c" / "e01.csv").read_text() == (tmp_path / "d" / "e01.csv").read_text()
    clean = record_event(IndependentSpec(**{**spec.__dict__, "noise_g": 0.0}), 300.0,
                         np.random.default_rng(3))[1]
    noisy = record_event(spec, 300.0, np.random.default_rng(3))[1]
    assert np.std(noisy["x5"] - clean["x5"]) == pytest.approx(0.3, rel=0.1)


def test_the_sensor_clips_at_its_range():
    """A 1 g range clips the impact peaks: no sample beyond it."""
    spec = IndependentSpec(flows=(200.0,), duration_s=0.5, range_g=1.0, settle_cycles=10,
                           noise_g=0.0)
    rec = record_event(spec, 200.0, np.random.default_rng(0))[1]
    assert np.max(np.abs(rec["x1"])) == 1.0 and np.mean(np.abs(rec["x1"]) == 1.0) > 0.01


def test_records_sample_the_run_at_the_sampling_phase():
    """The 16 solver points per sample: a record is the filtered run at its phase."""
    assert OVERSAMPLING == 16
    spec = IndependentSpec(flows=(600.0,), duration_s=0.25, noise_g=0.0, settle_cycles=10)
    a = record_event(spec, 600.0, np.random.default_rng(1))[1]["x1"]
    b = record_event(spec, 600.0, np.random.default_rng(2))[1]["x1"]
    assert a.shape == b.shape == (256,) and not np.allclose(a, b)  # another phase


@pytest.mark.parametrize("flow", [200.0, 600.0])
def test_the_sensor_chain_records_what_vadsims_chain_records(flow):
    """The same sensors (400 Hz corner) through vadsim's chain (digital Butterworth on a
    20 kHz grid, linear interpolation) and this one (analog filter discretised exactly,
    samples at solver points): the records' RMS agree within 2 % (measured: 0.4 %) at these
    periodic flows; 1 s each, no noise, after 100 settling cycles both."""
    from vadsim.campaigns import Sensor
    from vadsim.campaigns.synthetic import synthetic_campaign

    sensors = {k: Sensor(k, d, 1024.0, 250.0, 400.0) for k, d in (("x1", 1), ("x5", 5))}
    core = synthetic_campaign("7in-cde", (flow,), sensors=sensors, duration_s=1.0,
                              cycles=130, analyse_cycles=30, noise_g=0.0, seed=1)
    mine = record_event(IndependentSpec(flows=(flow,), noise_g=0.0, duration_s=1.0), flow,
                        np.random.default_rng(1))[1]
    for k in ("x1", "x5"):
        assert np.std(mine[k]) == pytest.approx(core.events[0].data[f"{k}_g"].std(), rel=0.02)


# ------------------------------------------------------------------------------ architecture

FORBIDDEN = ("vadsim.model", "vadsim._core", "vadsim.signals", "vadsim.campaigns",
             "vadsim.compare", "vadsim.fit")


@pytest.mark.parametrize("path", sorted(PACKAGE.glob("*.py")), ids=lambda p: p.name)
def test_the_generator_imports_none_of_vadsims_model_or_sensor_layers(path):
    bad = []
    for node in ast.walk(ast.parse(path.read_text())):
        names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                 [node.module or ""] + [f"{node.module}.{a.name}" for a in node.names]
                 if isinstance(node, ast.ImportFrom) else [])
        if isinstance(node, ast.ImportFrom) and node.module == "vadsim":
            names += [f"vadsim.{a.name}" for a in node.names]
        bad += [n for n in names if n.startswith(FORBIDDEN)]
    assert not bad, f"{path.name} imports {bad}"


# ------------------------------------------------------------------------ in the benchmark

def test_the_benchmark_holds_twelve_independent_campaigns_of_44():
    indep = [s for s in DEFAULT_SCENARIOS if s.generator == "independent"]
    assert len(indep) >= 12 and len(DEFAULT_SCENARIOS) >= 40
    assert indep == list(INDEPENDENT_SCENARIOS)
    counts = class_counts()
    assert {c: counts[c] for c in counts if c.startswith("indep_")} == {
        "indep_null": 3, "indep_excitation": 3, "indep_hydraulic": 2, "indep_friction": 2,
        "indep_contact": 2}
    assert all(s.flows == INDEPENDENT_SCENARIOS[0].flows and len(s.flows) == 10
               and s.noise_g == 0.3 and s.duration_s == 8.0 for s in indep)
    issue = Scenario("indep_excitation", generator="independent",
                     effects=(("excitation_power", {"factor": 1.0, "p": 0.5}),))
    assert issue in indep and issue.library_point
    assert issue.keys == ["excitation_amplitude"]


def test_independent_scenarios_refuse_what_they_cannot_write():
    with pytest.raises(ValueError, match="independent generator only"):
        Scenario("x", effects=(("hertz_contact", {}),))
    with pytest.raises(ValueError, match="theta0"):
        Scenario("x", generator="independent", nuisance={"theta0": 2.0})
    with pytest.raises(ValueError, match="no vadsim model change"):
        INDEPENDENT_SCENARIOS[0].change()


TOY = (Scenario("null", flows=(300.0,)),
       Scenario("indep_excitation", generator="independent", flows=(300.0, 500.0),
                effects=(("excitation_power", {"factor": 1.0, "p": 0.5}),)),
       Scenario("indep_contact", generator="independent", flows=(300.0,),
                effects=(("hertz_contact", {"stiffness": 2.0, "damping": 0.4}),)),
       Scenario("indep_hydraulic", generator="independent", flows=(300.0,),
                effects=(("hydraulic_quadratic", {"f400": 60.0, "q_on": 350.0,
                                                  "width": 50.0}),)))


def test_write_campaigns_goes_through_the_generator_and_records_it(tmp_path):
    paths = write_campaigns(tmp_path, TOY, classes=["indep_excitation", "indep_contact",
                                                    "indep_hydraulic"],
                            duration_s=0.5, cycles=30, analyse_cycles=20)
    truth = json.loads((tmp_path / "truth.json").read_text())
    assert len(paths) == 3 and sorted(truth) == [p.name for p in paths]
    by_class = {t["class"]: t for t in truth.values()}
    exc, con = by_class["indep_excitation"], by_class["indep_contact"]
    assert exc["generator"] == con["generator"] == "independent"
    # both written apart in the generator's own form, both exact library points; the
    # nozzle law's onset is outside its family
    assert exc["library_point"] and con["library_point"]
    assert not by_class["indep_hydraulic"]["library_point"]
    assert exc["truths"] == [{"key": "excitation_amplitude", "id": "excitation_amplitude",
                              "values": {"factor": 1.0, "p": 0.5}}]
    assert con["effects"][0]["name"] == "hertz_contact" and con["ids"] == ["contact_law"]
    assert con["truths"][0]["key"] == "contact_law[impact]"
    for p in paths:
        camp = load_campaign(p)
        assert "independent" not in (p / "campaign.toml").read_text() and camp.events
    # scored per class as any other; the regret is n/a off the library
    res = {n: {"verdict": "explained", "missing_physics": t["ids"],
               "missing_physics_keys": t["keys"], "parameters": {}, "nuisance": {},
               "heldout_error_before": 2.0, "heldout_error_after": 1.0, "elapsed_s": 1.0}
           for n, t in truth.items()}
    sc = score(res, truth)
    assert sc["classes"]["indep_contact"]["identification_rate"] == 1.0
    rows = {r["class"]: r for r in sc["campaigns"]}
    assert rows["indep_hydraulic"]["regret_na"]
    assert not rows["indep_contact"]["regret_na"] and not rows["indep_excitation"]["regret_na"]


def test_the_issue_case_is_explained_by_its_library_member(tmp_path):
    """The issue's case: the flow force Fo (Q/400)^0.5 written by the independent generator.
    vadsim's model at that library point (excitation_amplitude factor 1, p 0.5) explains the
    campaign to about the noise, the base model does not: the truth a diagnosis must find is
    in its library, as seen through vadsim's own simulator and chain. Three events of 2 s
    away from 400 gal/min (where p changes nothing), 2 sampling phases."""
    from vadsim.compare import CampaignEvaluator
    from vadsim.fit.candidates import CANDIDATES
    from vadsim.model.change import ModelChange
    from vadsim.model.settings import RunSettings

    flows = (250.0, 550.0, 650.0)
    spec = IndependentSpec(flows=flows, duration_s=2.0,
                           effects=(("excitation_power", {"factor": 1.0, "p": 0.5}),))
    write_campaign(tmp_path / "c", spec, seed=5)
    camp = load_campaign(tmp_path / "c")
    settings = RunSettings("7in-cde", cycles=160, analyse_cycles=60)
    truth = CANDIDATES["excitation_amplitude"].change({"factor": 1.0, "p": 0.5})
    with CampaignEvaluator(camp, settings, phases=2, workers=1) as ev:
        got = ev.evaluate([("none", ModelChange()), ("truth", truth)])

    def rms(label: str) -> float:
        z = np.concatenate([got[(label, e.id)].z for e in camp.events])
        return float(np.sqrt(np.mean(np.square(z))))

    assert rms("truth") < 1.0 and rms("none") > 3.0 * rms("truth")  # 0.3 against 2.6


@pytest.mark.slow
def test_the_issue_case_written_by_the_independent_generator_is_found(tmp_path):
    """The flow force Fo (Q/400)^0.5, written by the independent generator, diagnosed with
    a short candidate list that still needs screening (6 variants, more than the 4 fitted
    from their probes). No probe point lies in the truth's narrow basin, so the first step
    fails on its probes alone; every candidate is then fitted fully before any pair, and
    excitation_amplitude is found at its values (before that rule: "unexplained", the
    candidate never fitted). Six 3 s events away from 450-550 gal/min, where 160 cycles do
    not settle to the generator's response."""
    from vadsim.fit.diagnosis import diagnose
    from vadsim.fit.diagnosis.policy import Policy

    flows = (200.0, 250.0, 300.0, 350.0, 600.0, 650.0)
    spec = IndependentSpec(flows=flows, duration_s=3.0,
                           effects=(("excitation_power", {"factor": 1.0, "p": 0.5}),))
    write_campaign(tmp_path / "c", spec, seed=5)
    said: list[str] = []
    d = diagnose(tmp_path / "c", candidates=["hydraulic_force", "excitation_phase",
                                             "excitation_amplitude", "rock_stiffness",
                                             "anvil_friction"],
                 cycles=160, analyse_cycles=100, phases=2, progress=said.append,
                 policy=Policy(interval_search="search"))  # reads no interval
    assert any(line.startswith("no candidate passes: fitting the") for line in said), said
    assert d.missing_physics == ["excitation_amplitude"], d.summary()
    assert d.verdict == "explained"
    assert d.chosen.values["factor"] == pytest.approx(1.0, abs=0.05)
    assert d.chosen.values["p"] == pytest.approx(0.5, abs=0.15)
    assert d.chosen.heldout_rms <= 0.5 * d.none_fit.heldout_rms
    first = {f.key: f for f in d.steps[0]}
    assert not first["excitation_amplitude"].probe  # fitted fully, not left at its probe
    assert not any(f.probe for f in d.steps[0])


def test_detectability_writes_an_independent_scenario_through_its_generator():
    """Friction in its own form shows at 300 gal/min as vadsim's own friction does (RMS z
    well above a null's); 1 s, 2 phases."""
    import vadsim.blind as blind

    sc = Scenario("indep_friction", generator="independent", flows=(300.0,),
                  effects=(("friction_stribeck", {"force": 140.0, "static": 200.0,
                                                  "v_s": 0.1, "v0": 0.01}),))
    got = blind.detectability(sc, duration_s=1.0, cycles=130, analyse_cycles=30, phases=2,
                              workers=1)
    assert list(got) == [300.0] and got[300.0] > 2.0
