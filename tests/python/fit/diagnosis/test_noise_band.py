""""none" only within the noise: the calibrated base model's RMS on a campaign against the
band of its RMS on campaigns it writes itself (a parametric bootstrap from its own runs)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.fit.bootstrap import rms_draws
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis.policy import Policy, unexplained, verdict, within_noise
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.fit.scoring import aicc
from vadsim.model.change import ModelChange
from vadsim.model.settings import RunSettings
from vadsim.report.text import verdict_text

FLOWS = (200.0, 300.0, 400.0, 500.0, 600.0, 650.0)
SMALL = dict(cycles=160, analyse_cycles=100, duration_s=3.0, noise_g=0.3)


def _fit(rms_all: float, heldout_rms: float = 1.0, n: int = 400) -> HypothesisFit:
    """A fitted "none" with the given all-event RMS (rss / n) and held-out RMS."""
    return HypothesisFit(keys=(), nuisance_specs=(), point=(), k=2, intervals=[],
                         rss=rms_all ** 2 * n, n=n, heldout_rms=heldout_rms,
                         heldout_rms_lofo=heldout_rms, heldout_rms_block=heldout_rms,
                         score=aicc(n, heldout_rms ** 2, 2))


def test_none_is_given_inside_the_band_and_not_one_and_a_half_times_above_it():
    pol = Policy()
    draws = np.linspace(0.20, 0.40, 20)  # a right model's RMS on 20 campaigns it wrote
    band = float(np.quantile(draws, pol.noise_quantile))
    inside = _fit(float(np.median(draws)))
    got = within_noise(inside, draws, pol)
    assert got["within"] and got["band"] == pytest.approx(band) and got["draws"] == 20
    assert verdict(None, inside, pol, got) == "none"
    # 1.5 x above the band, still far below max_rms: a mismatch beyond the noise, not "none"
    above = _fit(1.5 * band, heldout_rms=0.5)
    got = within_noise(above, draws, pol)
    assert not got["within"] and got["rms"] == pytest.approx(1.5 * band)
    assert above.heldout_rms <= pol.max_rms
    assert verdict(None, above, pol, got) == "unexplained"
    # the band is the stated quantile: at it is inside, just above is not
    assert within_noise(_fit(band), draws, pol)["within"]
    assert not within_noise(_fit(band * 1.001), draws, pol)["within"]
    # effects chosen: the band does not decide; no bootstrap (None): max_rms alone
    assert verdict(above, above, pol, got) == "explained"
    assert verdict(None, above, pol, None) == "none"


def test_an_explained_verdict_names_a_remainder_beyond_the_noise_and_where_it_is():
    """A chosen model that holds out within max_rms but lies above the band of the campaigns
    it writes itself is still "explained", and its verdict says what is left and where; one
    inside its band says nothing more."""
    pol = Policy()
    draws = np.linspace(0.20, 0.40, 20)
    band = float(np.quantile(draws, pol.noise_quantile))
    base = _fit(3.0, heldout_rms=3.0)
    chosen = HypothesisFit(keys=("hydraulic_force[anvil]",), nuisance_specs=(),
                           point=(64.0, 2.0), k=4, intervals=[(60.0, 68.0), (1.9, 2.1)],
                           rss=1.2 ** 2 * 400, n=400, heldout_rms=1.3, heldout_rms_lofo=1.3,
                           heldout_rms_block=1.3, score=aicc(400, 1.3 ** 2, 4))
    chosen.heldout = {"e1": {"x1_q99_g": 2.5, "x5_q99_g": 1.5}, "e2": {"x1_q99_g": 0.1}}
    flows = {"e1": 500.0, "e2": 300.0}

    def diag(noise: dict) -> SimpleNamespace:
        return SimpleNamespace(
            none_fit=base, uncalibrated=base, noise=noise, chosen=chosen, final=chosen,
            verdict=verdict(chosen, chosen, pol, noise), settings={"max_rms": pol.max_rms},
            unexplained=unexplained(chosen, flows, pol, noise), operating_point=[])

    above = within_noise(chosen, draws, pol)
    d = diag(above)
    assert d.verdict == "explained" and not above["within"]
    assert [u["event"] for u in d.unexplained] == ["e1"]  # e2 lies inside the band
    text = verdict_text(d)
    assert text.startswith("missing physics: hydraulic_force (f_ref=64, n=2)")
    assert f"a remainder beyond the noise: RMS z 1.20 on the campaign, above {band:.2f}" in text
    assert "worst at 500 gal/min (x1_q99_g, x5_q99_g)" in text
    inside = within_noise(_fit(0.25), draws, pol)
    d = diag(inside)
    assert d.unexplained == [] and "remainder" not in verdict_text(d)


def test_noise_band_options_are_refused_by_name():
    for bad in (1, -2, 2.5, True):
        with pytest.raises(ValueError, match="noise_draws"):
            Policy(noise_draws=bad)
    for bad in (0.2, 1.0, math.nan):
        with pytest.raises(ValueError, match="noise_quantile"):
            Policy(noise_quantile=bad)
    assert Policy(noise_draws=0).noise_draws == 0  # 0 turns the bootstrap off


@pytest.fixture(scope="module")
def null_evaluator():
    camp = synthetic_campaign("7in-cde", FLOWS, seed=12, **SMALL)
    settings = RunSettings("7in-cde", cycles=SMALL["cycles"],
                           analyse_cycles=SMALL["analyse_cycles"])
    with CampaignEvaluator(camp, settings, phases=2, workers=1) as ev:
        yield ev


def _rms(ev: CampaignEvaluator, name: str, change: ModelChange | None) -> float:
    got = ev.evaluate([(name, change)])  # the evaluator keeps results by name
    z = np.concatenate([v.z for v in got.values()])
    return float(np.sqrt(np.mean(np.square(z))))


def test_the_model_that_wrote_a_campaign_lies_inside_its_own_draws(null_evaluator):
    """The draws are recorded from the very runs the evaluator measures the model from
    (sampling phase and noise vary), so the model that wrote the campaign sits among them,
    and the draws are reproducible from their seed."""
    ev = null_evaluator
    draws = rms_draws(ev, ModelChange(), n_boot=12)
    assert draws.shape == (12,) and np.all(np.isfinite(draws)) and np.all(draws > 0)
    rms = _rms(ev, "base", None)
    assert draws.min() * 0.5 < rms <= np.quantile(draws, 0.95), (rms, draws)
    np.testing.assert_array_equal(draws, rms_draws(ev, ModelChange(), n_boot=12))
    assert not np.array_equal(draws, rms_draws(ev, ModelChange(), n_boot=12, seed=2))


def test_a_model_that_misses_physics_lies_far_above_its_own_draws(null_evaluator):
    """A model with a hydraulic force the campaign does not hold fits most campaigns it
    writes as well as the right one fits its own, but lies far above its band on this
    campaign. (Its band is wide: at one event it runs a period-2 orbit whose two impacts per
    orbit are nearly equal at x5, and a record folded over one cycle finds the peak at
    either, so the folded lag moves by half a cycle in some draws: the band measures that
    too.)"""
    ev = null_evaluator
    wrong = CANDIDATES["hydraulic_force[anvil]"].change({"f_ref": 64.0, "n": 2.0})
    draws = rms_draws(ev, wrong, n_boot=8)
    assert draws.min() < 0.5
    assert _rms(ev, "hydraulic", wrong) > 1.5 * np.quantile(draws, 0.975)


def test_rms_draws_refuses_bad_sizes_by_name(null_evaluator):
    for bad in (1, 0, 2.0, True):
        with pytest.raises(ValueError, match="n_boot"):
            rms_draws(null_evaluator, ModelChange(), n_boot=bad)
