"""Validation and calibration on small synthetic campaigns (the model writes the recordings)."""

import math

import numpy as np
import pytest
from vadsim import RunSettings
from vadsim.campaigns import load_campaign, save_campaign
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import event_residuals, simulate_event
from vadsim.fit.calibrate import calibrate
from vadsim.fit.calibration_targets import thesis_targets
from vadsim.fit.validate import validate
from vadsim.report.validation import findings
from vadsim.report.validation import write_validation_report as write_report

SHORT = dict(cycles=80, analyse_cycles=50)


@pytest.fixture(scope="module")
def campaign():
    return synthetic_campaign("7in-cde", (200.0, 450.0, 600.0), noise_g=0.3, seed=7, **SHORT)


def test_synthetic_campaign_is_in_the_recordings_format(campaign, tmp_path):
    folder = save_campaign(campaign, tmp_path / "c")
    back = load_campaign(folder)
    assert [e.id for e in back.events] == ["e01", "e02", "e03"]
    assert set(back.events[0].data.columns) == {"time_s", "x1_g", "x5_g"}
    dt = np.diff(back.events[0].data["time_s"].to_numpy())
    assert np.allclose(dt, 1 / 1024, rtol=1e-4)


def test_the_true_model_matches_its_own_recordings(campaign):
    res = validate(campaign, **SHORT)
    z = res.residuals.to_numpy(float)
    z = z[np.isfinite(z)]
    assert z.size > 20
    # Noise and sampling phase only: residuals of the true model stay within a few spreads.
    assert np.sqrt(np.mean(z ** 2)) < 1.5
    assert np.max(np.abs(z)) < 5


def test_a_changed_model_is_located(campaign, tmp_path):
    res = validate(campaign, overrides={"Fo": 450.0}, **SHORT)
    z = res.residuals.abs()
    assert z.max().max() > 3  # a 50 % stronger excitation shows in the features
    report = write_report(res, tmp_path / "rep")
    text = report.read_text()
    assert "## Findings" in text and "x1_peak_mean_g" in text
    assert (tmp_path / "rep" / "peaks_vs_flow.png").stat().st_size > 1000
    assert (tmp_path / "rep" / "mismatch_heatmap.png").stat().st_size > 1000
    html = write_report(res, tmp_path / "rep", fmt="html")
    assert html.read_text().startswith("<!doctype html>")
    assert any("over-predicts" in line for line in findings(res))


def test_residuals_combine_recorded_and_phase_spreads(campaign):
    ev = campaign.events[2]  # 600 gal/min: 16.0 samples per excitation cycle at 1024 Hz
    sim = simulate_event(campaign, ev, RunSettings("7in-cde", **SHORT))
    assert sim.phase_sd["x1_peak_mean_g"] > 0
    from vadsim.signals.features import Feature

    rec = {"x1_peak_mean_g": Feature(sim.sensor["x1_peak_mean_g"].value + 1.0, 0.5, 10)}
    z = event_residuals(sim, rec)["x1_peak_mean_g"]
    assert z == pytest.approx(-1.0 / math.hypot(0.5, sim.phase_sd["x1_peak_mean_g"]))
    assert event_residuals(sim, rec, "full")  # full resolution uses the recorded spread only


def test_thesis_campaign_validates_and_shows_high_flow_overprediction(tmp_path):
    res = validate("thesis:7in-cde", **SHORT)
    full = res.residuals_full["x1_peak_mean_g"]
    flows = np.array([e.flow_gpm for e in res.campaign.events])
    # What the dissertation saw at full resolution: the model over-predicts at high flow.
    assert full[flows >= 450].mean() > 2
    assert abs(full[flows == 200].iloc[0]) < 2


def test_calibration_recovers_a_changed_excitation(campaign):
    truth = 380.0
    camp = synthetic_campaign("7in-cde", (200.0, 450.0, 600.0), overrides={"Fo": truth},
                              noise_g=0.3, seed=7, **SHORT)
    res = calibrate(camp, ["Fo"], start={"Fo": 300.47}, bounds={"Fo": (200.0, 600.0)},
                    n_global=24, n_starts=2, interval_method="profile", **SHORT)
    assert res.estimates["Fo"] == pytest.approx(truth, rel=0.05)
    assert res.cost_after < res.cost_before
    assert math.isfinite(res.stderr["Fo"])


def test_thesis_targets_and_bad_input():
    from vadsim.campaigns import thesis_campaigns

    t = thesis_targets(thesis_campaigns()["9.5in-pdc"])
    assert all("z_impact" in v for v in t.values())  # every 9.5in event: 1 impact/cycle
    assert t["e01"]["x1_peak_mean_g"].value == 13
    with pytest.raises(ValueError, match="unknown parameter"):
        calibrate("thesis:7in-cde", ["l00"])
    with pytest.raises(ValueError, match="outside its bounds"):
        calibrate("thesis:7in-cde", ["l0"], start={"l0": 3.0})
    with pytest.raises(ValueError, match="resolution"):
        calibrate("thesis:7in-cde", ["l0"], resolution="fine")


def test_validation_of_a_clipped_sensor_says_what_was_not_compared(tmp_path) -> None:
    """A 5 g sensor at the bit clips every window: the report is written and says why the
    peak features were not compared (it used to raise KeyError in the report)."""
    import warnings

    from vadsim.campaigns import Sensor

    sensors = {"x1": Sensor("x1", 1, 1024.0, 5.0), "x5": Sensor("x5", 5, 1024.0, 250.0)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        camp = synthetic_campaign("7in-cde", (200.0, 600.0), sensors=sensors, **SHORT)
        res = validate(camp, **SHORT)
    missing = res.not_compared()
    peak = missing[missing.feature == "x1_peak_mean_g"]
    assert len(peak) == 2 and peak.reason.str.contains("clipped at its 5 g range").all()
    assert "x1_peak_mean_g" not in res.residuals.columns
    assert any("x1_peak_mean_g could not be compared at 2 event(s)" in f for f in findings(res))
    report = write_report(res, tmp_path / "rep")
    assert "could not be compared" in report.read_text()
