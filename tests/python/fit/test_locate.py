"""Locating a mismatch: no flag when the true model wrote the recordings, a trend with flow
when a concealed flow-dependent force did."""

import numpy as np
import pandas as pd
import pytest
import vadsim
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.locate import locate
from vadsim.fit.validate import validate

FLOWS = (200.0, 280.0, 360.0, 440.0, 520.0, 600.0)
S = dict(cycles=100, analyse_cycles=60)


def _located(**kw):
    camp = synthetic_campaign("7in-cde", FLOWS, noise_g=0.3, **S, **kw)
    res = validate(camp, **S)
    return locate(res.residuals, {e.id: e.flow_gpm for e in camp.events})


@pytest.mark.parametrize("seed", [1, 2])
def test_no_false_alarm_when_the_model_wrote_the_recordings(seed):
    assert _located(seed=seed) == []


def test_concealed_hydraulic_force_is_located_as_a_trend_with_flow():
    found = _located(seed=1, extras=[vadsim.extra_force("hydraulic", acts_on="anvil",
                                                         c=3e-4)])
    assert found
    top = found[0]
    assert "trend" in top.kind and top.slope_ci[1] < 0
    assert "e06" in top.events  # the highest flow is among the mismatched events


def test_rule_on_constructed_residuals():
    flows = {f"e{i}": q for i, q in enumerate(np.linspace(200, 650, 10))}
    rng = np.random.default_rng(0)
    noise = pd.DataFrame({"a": rng.normal(0, 1, 10)}, index=list(flows))
    assert locate(noise, flows) == []
    offset = noise + 3
    assert [m.kind for m in locate(offset, flows)] == ["offset"]
    trend = pd.DataFrame({"a": np.linspace(-4, 4, 10)}, index=list(flows))
    (m,) = locate(trend, flows)
    assert m.kind == "trend" and m.slope_per_100gpm == pytest.approx(8 / 4.5)
    with pytest.raises(ValueError, match="level"):
        locate(noise, flows, level=2)
