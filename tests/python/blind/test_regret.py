"""Regret against the truth (vadsim.blind.truth_regret): the chosen model's training cost minus the
true model's, with the noise that separates a search failure from a fit within the noise."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from vadsim.blind import Scenario, write_campaigns
from vadsim.blind.truth_regret import (
    NOISE_SIGMAS,
    chosen_point,
    regret,
    regret_of,
    truth_point,
)
from vadsim.fit.nuisance import DEFAULT_NUISANCE, resolve_nuisance
from vadsim.model.presets import get_preset
from vadsim.model.settings import RunSettings

SMALL = dict(duration_s=1.0, cycles=60, analyse_cycles=40)
FRICTION = Scenario("x", (("anvil_friction", {"force": 150.0}),), {"wob_scale": 1.1},
                    flows=(300.0, 500.0))


def _result(keys: list[str], params: dict, wob: float) -> dict:
    return {"verdict": "explained" if keys else "none", "missing_physics_keys": keys or ["none"],
            "parameters": params, "nuisance": {"wob_scale": {"value": wob,
                                                             "interval": [wob, wob]}}}


@pytest.fixture(scope="module")
def friction_campaign(tmp_path_factory):
    folder = tmp_path_factory.mktemp("blind")
    path, = write_campaigns(folder, (FRICTION,), **SMALL)
    return path, json.loads((folder / "truth.json").read_text())[path.name]


def test_truth_and_chosen_points_read_values_and_nuisance_by_name():
    nuis = resolve_nuisance(tuple(DEFAULT_NUISANCE), RunSettings(get_preset("7in-cde")))
    truth = {"truths": [{"key": "hydraulic_force[anvil]", "id": "hydraulic_force",
                         "values": {"n": 2.0, "f_ref": 60.0}}], "nuisance": {"wob_scale": 1.1}}
    hyp, point = truth_point(truth, nuis)
    assert hyp.keys == ("hydraulic_force[anvil]",)
    assert dict(zip([s.name for s in hyp.specs], point, strict=True))["f_ref"] == 60.0
    theta0 = next(s.null for s in nuis if s.name == "theta0")
    assert point[-2:] == hyp.round([60.0, 2.0, 1.1, theta0])[-2:]
    result = _result(["hydraulic_force[anvil]"],
                     {"hydraulic_force": {"acts_on": "anvil", "f_ref": 60.0, "n": 2.0}}, 1.1)
    assert chosen_point(result, nuis) == (hyp, point)
    hyp0, point0 = chosen_point(_result([], {}, 0.9), nuis)
    assert hyp0.keys == () and point0 == hyp0.round([0.9, theta0])


def test_an_independent_truth_carries_the_phase_at_rest_of_its_concealed_wob():
    """The independent generator runs MODEL.md's phase at rest beta (x2 - x3) + psi, which a
    lighter WOB moves by beta 0.1 wob / kOn (the on-bottom shoulder compresses less); vadsim's
    preset holds its phase. The regret's truth point carries the generator's phase: at the
    preset's WOB it is the preset's own."""
    nuis = resolve_nuisance(tuple(DEFAULT_NUISANCE), RunSettings(get_preset("7in-cde")))
    names = [s.name for s in nuis]
    p = get_preset("7in-cde").params
    at = {}
    for wob in (1.0, 0.9):
        truth = {"truths": [], "nuisance": {"wob_scale": wob} if wob != 1.0 else {},
                 "generator": "independent", "preset": "7in-cde"}
        hyp, point = truth_point(truth, nuis)
        at[wob] = dict(zip(names, point[-len(names):], strict=True))["theta0"]
    assert at[1.0] == pytest.approx(p["theta0"] % math.pi, abs=1e-5)  # points keep 6 digits
    shift = p["beta"] * 0.1 * p["wob"] / p["kOn"]  # 0.0071 rad
    assert at[0.9] - at[1.0] == pytest.approx(shift, abs=2e-5)
    vadsim_truth = {"truths": [], "nuisance": {"wob_scale": 0.9}}
    assert truth_point(vadsim_truth, nuis)[1][-1] == pytest.approx(at[1.0], abs=1e-5)


def test_the_noise_of_a_regret_scales_with_the_residuals_variance():
    """n residuals of variance s^2 give an RSS that scatters by sqrt(2 n) s^2 (s^2 times a
    chi-square of n degrees of freedom): measured on draws, and the regret's noise is two of
    those, with s^2 from the better of the two models."""
    rng = np.random.default_rng(3)
    n, s = 700, 0.12  # the blind benchmark's size and residual scale
    rss = np.sum((s * rng.standard_normal((4000, n))) ** 2, axis=1)
    assert rss.std() == pytest.approx(math.sqrt(2 * n) * s ** 2, rel=0.05)
    got = regret_of(float(rss[0]), float(rss[0]) + 3.0, n)
    assert got["residual_variance"] == pytest.approx(rss[0] / n)
    assert got["noise"] == pytest.approx(NOISE_SIGMAS * math.sqrt(2 * n) * rss[0] / n)
    assert got["search_failure"]  # 3 is beyond 2 sqrt(2 n) s^2 = 1.07 here
    assert not regret_of(float(rss[0]), float(rss[0]) + 0.5, n)["search_failure"]
    # a truth whose run lands on another response: the chosen model's RSS sets the scale
    assert regret_of(1383.0, 27.8, 709)["residual_variance"] == pytest.approx(27.8 / 709)
    with pytest.raises(ValueError, match="n = 0"):
        regret_of(1.0, 1.0, 0)


def test_the_truth_itself_has_no_regret_and_none_on_an_effect_is_a_search_failure(
        friction_campaign):
    path, truth = friction_campaign
    kw = dict(cycles=SMALL["cycles"], analyse_cycles=SMALL["analyse_cycles"], workers=1)
    at_truth = regret(path, truth, _result(["anvil_friction"],
                                           {"anvil_friction": {"force": 150.0}}, 1.1), **kw)
    assert at_truth["regret"] == 0.0 and not at_truth["search_failure"]
    s2 = at_truth["rss_truth"] / at_truth["n"]
    assert at_truth["residual_variance"] == pytest.approx(s2)
    assert at_truth["noise"] == pytest.approx(NOISE_SIGMAS * math.sqrt(2 * at_truth["n"]) * s2)
    assert at_truth["rms_truth"] < 1.5  # the recording noise alone
    missed = regret(path, truth, _result([], {}, 1.0), **kw)
    assert missed["rss_truth"] == pytest.approx(at_truth["rss_truth"])
    assert missed["regret"] > missed["noise"] and missed["search_failure"]
