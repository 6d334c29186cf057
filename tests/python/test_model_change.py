"""ModelChange: how candidates, nuisance constants and concealed truths change a run."""

import math

import pytest
from vadsim.model.change import ModelChange, psi_for_theta0, rest_phase
from vadsim.model.settings import RunSettings


@pytest.fixture(scope="module")
def base():
    return RunSettings("7in-cde")


def test_rest_phase_matches_model_md(base):
    # MODEL.md: l0 = 0.7 m gives theta0 = 2.264 for the 7in tool
    assert rest_phase(base) == pytest.approx(2.264, abs=5e-4)


def test_theta0_sets_psi_in_the_changed_model(base):
    changed = ModelChange(scales={"wob": 1.1}, theta0=2.553).apply(base)
    assert rest_phase(changed) == pytest.approx(2.553, abs=1e-9)
    # psi is computed after the WOB scale: the rest gap depends on wob / kOn
    assert changed.param("psi") == pytest.approx(psi_for_theta0(changed, 2.553))


def test_flow_power_and_slope_at_event_flow(base):
    ch = ModelChange(flow_powers={"Fo": 0.5}, flow_slopes={"psi": 0.3})
    at_ref = ch.apply(base, 400.0)
    assert at_ref.param("Fo") == pytest.approx(base.param("Fo"))
    assert at_ref.param("psi") == pytest.approx(base.param("psi"))
    at_800 = ch.apply(base, 800.0)
    assert at_800.param("Fo") == pytest.approx(base.param("Fo") * math.sqrt(2.0))
    assert at_800.param("psi") == pytest.approx(base.param("psi") + 0.3)
    with pytest.raises(ValueError, match="needs the event's flow"):
        ch.apply(base)


def test_combine_multiplies_scales_and_adds_powers(base):
    a = ModelChange(scales={"kI": 2.0}, flow_powers={"Fo": 0.2})
    b = ModelChange(scales={"kI": 1.5, "m2": 0.5}, flow_powers={"Fo": 0.3})
    c = a.combine(b)
    assert c.scales == {"kI": 3.0, "m2": 0.5}
    assert c.flow_powers["Fo"] == pytest.approx(0.5)
    assert c.apply(base, 400.0).param("kI") == pytest.approx(3.0 * base.param("kI"))


def test_combine_refuses_conflicts():
    with pytest.raises(ValueError, match="contact law"):
        ModelChange(law="hunt_crossley").combine(ModelChange(law="kelvin_voigt"))
    with pytest.raises(ValueError, match="theta0"):
        ModelChange(theta0=1.0).combine(ModelChange(theta0=2.0))
    with pytest.raises(ValueError, match="override"):
        ModelChange(overrides={"kR": 1.0}).combine(ModelChange(overrides={"kR": 2.0}))


def test_measurements_compose_in_order():
    import numpy as np

    add = ModelChange(measurement=lambda n, a, fs: a + 1.0)
    dbl = ModelChange(measurement=lambda n, a, fs: a * 2.0)
    both = add.combine(dbl)
    assert both.measurement is not None
    assert both.measurement("x1", np.zeros(3), 1.0).tolist() == [2.0, 2.0, 2.0]
    assert not both.changes_run


def test_empty_change_is_the_base_model(base):
    assert ModelChange().apply(base) is base
    assert not ModelChange(scales={"kI": 1.0}, flow_powers={"Fo": 0.0}).changes_run
