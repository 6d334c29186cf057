"""Calibration recovers l0 and wob from recordings the model wrote itself (CI-sized).

A small version of ``bench/bench_calibrate.py``: recordings of the 7in preset (l0 = 0.7 m,
wob = 1000 N/kg) through the field sensor chain (1024 Hz, 250 g, 0.3 g noise) at low WOB
(0.5 and 1 klbf, where the bit and the on-bottom shoulder open and ``wob`` shows), then a
calibration that is not told the truth. To stay cheap (about 40-80 s on 2 cores) the search
ranges are narrowed to l0 = 0.66-0.74 m, which still holds 9 excitation-phase aliases
(half-period 0.0083 m, 1.2 % of l0), and wob = 700-1400 N/kg; the calibration therefore
starts at a corner of them, l0 = 0.74 and wob = 700, instead of l0 = 1.0 and wob = 500
(which ``bench/bench_calibrate.py`` uses, over the default ranges l0 = 0.4-1.4 and
wob = 200-2500).
"""

from __future__ import annotations

import math

import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.calibrate import calibrate
from vadsim.fit.calibration_targets import calibration_cost

TRUTH = {"l0": 0.7, "wob": 1000.0}
FLOWS = (150.0, 150.0, 250.0, 250.0, 350.0, 350.0)
WOBS = (0.5, 1.0, 0.5, 1.0, 0.5, 1.0)
CYCLES, ANALYSE = 120, 60


@pytest.fixture(scope="module")
def campaign():
    return synthetic_campaign("7in-cde", FLOWS, wob_klbf=WOBS, duration_s=4.0, noise_g=0.3,
                              seed=5)


def test_cost_is_lowest_at_the_truth_among_its_aliases(campaign):
    """Identifiability: the truth fits better than its phase aliases with another wob."""
    half = math.pi / (95.2 * (4.06 - 0.07 - 0.01))  # beta (L3 - LI - LOn), Table 2.1
    truth, table = calibration_cost(campaign, TRUTH, cycles=CYCLES, analyse_cycles=ANALYSE)
    assert table.shape[0] == len(FLOWS)
    for k, wob in ((0, 850.0), (0, 1150.0), (-2, 1000.0), (4, 850.0)):
        alias, _ = calibration_cost(campaign, {"l0": 0.7 + k * half, "wob": wob},
                                    cycles=CYCLES, analyse_cycles=ANALYSE)
        assert alias > truth, (k, wob, alias, truth)


@pytest.mark.slow
def test_calibration_recovers_l0_and_wob_within_5_percent(campaign):
    res = calibrate(campaign, ("l0", "wob"), start={"l0": 0.74, "wob": 700.0},
                    bounds={"l0": (0.66, 0.74), "wob": (700.0, 1400.0)}, n_global=16,
                    n_starts=2, alias_stripes=2, alias_grid=14, alias_refine=9, max_nfev=5,
                    cycles=CYCLES, analyse_cycles=ANALYSE,
                    interval_method="profile")  # the bootstrap is tested below
    err = {n: res.estimates[n] / TRUTH[n] - 1 for n in TRUTH}
    assert all(abs(e) <= 0.05 for e in err.values()), (res.summary(), err)
    assert res.cost_after < res.cost_before


@pytest.fixture(scope="module")
def fo_campaign():
    """The README's example: three flows recorded with Fo = 380 N/kg (the preset's 400)."""
    return synthetic_campaign("7in-cde", (200, 450, 600), overrides={"Fo": 380.0})


@pytest.mark.slow
def test_the_readme_interval_holds_the_truth_with_a_measured_threshold(fo_campaign):
    """The README's calibration: its 95 % interval holds the true Fo = 380 without spanning
    the whole search range, and its threshold is the bootstrap's (measured on campaigns the
    fitted model writes), never below the independent-residual rule's chi2(1) s^2."""
    res = calibrate(fo_campaign, ["Fo"], bounds={"Fo": (200, 600)}, n_global=32,
                    progress=False, n_boot=30)
    assert res.interval_method == "bootstrap"
    lo, hi = res.interval["Fo"]
    assert lo <= 380.0 <= hi, res.summary()
    assert lo <= res.estimates["Fo"] <= hi
    assert hi - lo < 0.5 * (600 - 200), res.summary()
    assert res.threshold["Fo"] >= 3.841458820694124
    assert "bootstrap" in res.summary()


def test_the_bootstrap_needs_recordings_and_names_what_is_wrong(fo_campaign):
    with pytest.raises(ValueError, match="interval_method = 'bootstrap' draws recordings"):
        calibrate("thesis:7in-cde", ["Fo"], interval_method="bootstrap", progress=False)
    with pytest.raises(ValueError, match="interval_method = 'jackknife'"):
        calibrate(fo_campaign, ["Fo"], interval_method="jackknife", progress=False)
    with pytest.raises(ValueError, match="n_boot = 1 "):
        calibrate(fo_campaign, ["Fo"], n_boot=1, progress=False)
    with pytest.raises(ValueError, match="noise_g = -0.1"):
        calibrate(fo_campaign, ["Fo"], noise_g=-0.1, progress=False)
