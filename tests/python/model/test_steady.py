"""Steady runs (vadsim.model.steady) and the model's measurement noise (vadsim.compare): what a
comparison adds so that the model is measured like a recording of steady drilling."""

from __future__ import annotations

import math

import numpy as np
import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import CampaignEvaluator, recorded_noise_g
from vadsim.model.change import ModelChange
from vadsim.model.settings import RunSettings
from vadsim.model.steady import DRIFT_TOL, steady_run, window_drift
from vadsim.signals.fold_features import noise_floor_g

# The 7in tool with its phase at rest at 1.964 rad, 500 gal/min: after 100 settling cycles the
# window still holds the transient from intermittent impacts to one impact per cycle.
TRANSIENT = ModelChange(theta0=1.964)
FLOW = 500.0


def _settings(cycles: float = 300) -> RunSettings:
    return TRANSIENT.apply(RunSettings("7in-cde", cycles=cycles, analyse_cycles=200), FLOW)


def test_a_periodic_window_does_not_drift():
    r = RunSettings("7in-cde", cycles=120, analyse_cycles=60).run(200.0, record="none")
    assert r.z["impact"] == pytest.approx(1.0)
    assert window_drift(r) == 0.0


def test_a_transient_is_continued_until_it_settles_and_equals_the_longer_run():
    s = _settings()
    plain = s.run(FLOW, record="none")
    assert window_drift(plain) > DRIFT_TOL  # measured 0.29
    r = steady_run(s, FLOW, record="none")
    n = r.stats["steady_extensions"]
    assert n >= 1
    assert window_drift(r) <= DRIFT_TOL
    assert r.z["impact"] == pytest.approx(1.0) and r.z["spring"] == 0.0
    # The excitation is periodic in time, so continuing a run of whole cycles from its end
    # state is the longer run, to the integrator's tolerance (measured 2e-4 on J*).
    longer = s.with_changes(cycles=300 * (n + 1)).run(FLOW, record="none")
    assert r.z == longer.z
    assert r.impulse_mean == pytest.approx(longer.impulse_mean, rel=1e-3)


def test_a_fraction_of_a_cycle_is_not_continued_and_zero_extensions_is_a_plain_run():
    r = steady_run(_settings(300.5), FLOW, record="none")
    assert r.stats["steady_extensions"] == 0
    plain = steady_run(_settings(), FLOW, record="none", max_extensions=0)
    assert plain.stats["steady_extensions"] == 0
    assert window_drift(plain) > DRIFT_TOL


@pytest.mark.parametrize("kw, name", [
    (dict(max_extensions=-1), "max_extensions"), (dict(max_extensions=True), "max_extensions"),
    (dict(drift_tol=0.0), "drift_tol"), (dict(drift_tol=math.nan), "drift_tol"),
    (dict(initial_displacement=np.zeros(3)), "initial_displacement"),
])
def test_bad_options_are_refused_by_name(kw, name):
    with pytest.raises(ValueError, match=name):
        steady_run(_settings(), FLOW, record="none", **kw)


# ---------------------------------------------------------------------- the model's noise

@pytest.fixture(scope="module")
def noisy():
    """Two 4 s events of the 7in tool with 1 g of sensor noise (its own model wrote them)."""
    return synthetic_campaign("7in-cde", [250.0, 550.0], duration_s=4.0, noise_g=1.0,
                              cycles=160, analyse_cycles=100, seed=11)


def test_the_noise_of_a_record_is_read_from_its_fold(noisy):
    got = recorded_noise_g(noisy, RunSettings("7in-cde"))
    assert set(got) == {"x1", "x5"}
    for v in got.values():
        assert v == pytest.approx(1.0, rel=0.08)  # measured 0.99-1.02 on 8 s records
    ev = noisy.events[0]
    one = noise_floor_g({"x1": ev.data["x1_g"].to_numpy()}, 1024.0,
                        RunSettings("7in-cde").f_exc_hz(ev.flow_gpm))
    assert one["x1"] == pytest.approx(1.0, rel=0.08)


def test_measuring_the_model_with_the_records_noise_explains_a_noisy_campaign(noisy):
    settings = RunSettings("7in-cde", cycles=160, analyse_cycles=100)

    def rms(noise):
        with CampaignEvaluator(noisy, settings, workers=2, noise=noise, cache=False) as ev:
            z = np.concatenate([e.z for e in ev.base().values()])
            return float(np.sqrt(np.mean(z ** 2))), ev.noise_g

    without, none = rms(False)
    with_noise, est = rms(None)
    assert none == {} and set(est) == {"x1", "x5"}
    # The window features of signal plus 1 g of noise are not those of the signal alone
    # (measured: event RMS z 0.43 and 0.67 without, 0.29 and 0.39 with).
    assert with_noise < 0.8 * without
    assert with_noise < 1.0


def test_a_bad_noise_option_is_refused_by_name(noisy):
    settings = RunSettings("7in-cde", cycles=60, analyse_cycles=40)
    for bad, name in (({"x9": 0.3}, "x9"), ({"x1": -1.0}, "x1"), ({"x1": math.inf}, "x1"),
                      (0.3, "noise")):
        with pytest.raises(ValueError, match=name):
            CampaignEvaluator(noisy, settings, noise=bad)


def test_a_full_resolution_comparison_estimates_no_noise(noisy):
    """It measures no sensor, so the noise a sensor adds is not estimated (nor used)."""
    settings = RunSettings("7in-cde", cycles=60, analyse_cycles=40)
    with CampaignEvaluator(noisy, settings, resolution="full", cache=False) as ev:
        assert ev.noise_g == {}
    with CampaignEvaluator(noisy, settings, cache=False) as ev:
        assert set(ev.noise_g) == {"x1", "x5"}
