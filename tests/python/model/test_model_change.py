"""ModelChange: how candidates, nuisance constants and concealed truths change a run."""

import math

import pytest
from vadsim.model.change import ModelChange, rest_phase
from vadsim.model.settings import RunSettings


@pytest.fixture(scope="module")
def base():
    return RunSettings("7in-cde")


def test_rest_phase_matches_model_md(base):
    # MODEL.md: l0 = 0.7 m gives theta0 = 2.264 for the 7in tool
    assert rest_phase(base) == pytest.approx(2.264, abs=5e-4)


def test_theta0_is_held_whatever_the_other_changes_do_to_the_rest_state(base):
    changed = ModelChange(scales={"wob": 1.1, "l0": 1.01}, theta0=2.553).apply(base)
    assert changed.param("theta0") == 2.553 and rest_phase(changed) == pytest.approx(2.553)
    # without theta0 the same scales keep the preset's phase at rest (it is held too)...
    kept = ModelChange(scales={"wob": 1.1, "l0": 1.01}).apply(base)
    assert rest_phase(kept) == pytest.approx(rest_phase(base), abs=1e-12)
    # ...while the dissertation's parameterisation (theta0 unset) moves it by beta dl0 (L3 -
    # LI - LOn) + beta dwob / kOn: 379 rad per metre of l0
    free = ModelChange(scales={"l0": 1.01}).apply(base.with_changes(overrides={"theta0": math.nan}))
    moved = (rest_phase(free) - rest_phase(base) + math.pi / 2) % math.pi - math.pi / 2
    assert moved == pytest.approx((0.007 * 95.2 * 3.98 + math.pi / 2) % math.pi - math.pi / 2,
                                  abs=1e-6)


def test_flow_power_and_slope_at_event_flow(base):
    ch = ModelChange(flow_powers={"Fo": 0.5}, flow_slopes={"theta0": 0.3})
    at_ref = ch.apply(base, 400.0)
    assert at_ref.param("Fo") == pytest.approx(base.param("Fo"))
    assert at_ref.param("theta0") == pytest.approx(base.param("theta0"))
    at_800 = ch.apply(base, 800.0)
    assert at_800.param("Fo") == pytest.approx(base.param("Fo") * math.sqrt(2.0))
    assert at_800.param("theta0") == pytest.approx(base.param("theta0") + 0.3)
    # a slope on an unset phase at rest starts from the phase psi gives, not from nan
    unset = base.with_changes(overrides={"theta0": math.nan})
    assert ch.apply(unset, 800.0).param("theta0") == pytest.approx(base.param("theta0") + 0.3)
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
