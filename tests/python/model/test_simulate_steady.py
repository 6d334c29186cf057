"""The steady-state engine: ``simulate(steady="auto")`` stops at a confirmed periodic orbit
and builds the rest of the run from it; the comparison engine measures a periodic window from
its orbit and starts changed models from the base model's steady state (warm starts) -- and
none of it may change what a result is: a function of its inputs, equal to the literal run
within the orbit's own repeat."""

from __future__ import annotations

import numpy as np
import pytest
import vadsim
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import (
    ORBIT_OVERSAMPLING,
    CampaignEvaluator,
    WarmStart,
    fine_series,
    measure_event,
    run_event,
)
from vadsim.model.change import ModelChange
from vadsim.model.result import Orbit
from vadsim.model.settings import ExtraSpec, RunSettings
from vadsim.signals.fold_features import has_quantiles

SHORT = dict(cycles=160, analyse_cycles=80)


def _pair(flow, **kw):
    full = vadsim.simulate("7in-cde", flow, steady="full", **SHORT, **kw)
    auto = vadsim.simulate("7in-cde", flow, **SHORT, **kw)
    return full, auto


def test_auto_is_the_default_and_the_result_says_what_happened():
    full, auto = _pair(200.0, record="none")
    assert auto.steady_info.mode == "auto" and auto.steady_info.periodic
    assert auto.steady_info.period == 1
    assert auto.steady_info.residual <= auto.steady_info.tolerance == pytest.approx(1e-3)
    assert auto.steady_info.stopped_cycle < 40  # measured: 12
    assert auto.stats["steps"] < full.stats["steps"] / 3
    assert full.steady_info.mode == "full" and not full.steady_info.periodic
    assert "period-1 orbit" in str(auto.steady_info)
    assert "steady state" in auto._repr_html_()


@pytest.mark.parametrize("kw, name", [
    (dict(steady="yes"), "steady"), (dict(steady=1), "steady"), (dict(steady=None), "steady"),
    (dict(orbit_replaces_window="no"), "orbit_replaces_window"),
    (dict(orbit_rate_hz=-5.0), "orbit_rate_hz"), (dict(orbit_rate_hz="fast"), "orbit_rate_hz"),
])
def test_bad_steady_options_are_refused_by_name(kw, name):
    with pytest.raises(ValueError, match=name):
        vadsim.simulate("7in-cde", 200.0, cycles=10, analyse_cycles=5, **kw)


# Regimes 1 (200 gal/min, period 1) and 5 (600, period 1; 510, period 2). Tolerances: Z* and
# the window's events exactly (times to 1e-5 s), J* to 1e-3, the bit's 200 ms peaks to 1 %
# (the orbit repeats to 1e-3 of each state's amplitude), every grid of the same size and time.
@pytest.mark.parametrize("flow, period", [(200.0, 1), (600.0, 1), (510.0, 2)])
def test_a_periodic_run_equals_its_full_run(flow, period):
    full, auto = _pair(flow)
    assert auto.steady_info.period == period
    assert auto.z == full.z and auto.scenario == full.scenario
    assert auto.impulse_pos == pytest.approx(full.impulse_pos, rel=1e-3)
    assert auto.impulse_mean == pytest.approx(full.impulse_mean, rel=1e-3)
    assert auto.peak_stats(1)[0] == pytest.approx(full.peak_stats(1)[0], rel=1e-2)
    assert auto.window_peaks_g.shape == full.window_peaks_g.shape
    np.testing.assert_array_equal(auto.t, full.t)
    assert auto.x.shape == full.x.shape and auto.poincare.shape == full.poincare.shape
    w = full.window[0]
    ef, ea = full.events[full.events.time_s >= w], auto.events[auto.events.time_s >= w]
    assert len(ef) == len(ea)
    assert (ef.kind.to_numpy() == ea.kind.to_numpy()).all()
    assert (ef.surface.to_numpy() == ea.surface.to_numpy()).all()
    assert np.abs(ef.time_s.to_numpy() - ea.time_s.to_numpy()).max() < 1e-5
    span = np.ptp(full.x, axis=0)
    assert (np.abs(auto.x - full.x).max(axis=0) <= 1e-2 * span).all()


def test_an_intermittent_point_falls_back_to_the_full_run_bit_for_bit():
    full, auto = _pair(350.0)
    assert not auto.steady_info.periodic and auto.scenario == 3
    assert auto.steady_info.stopped_cycle == pytest.approx(SHORT["cycles"])
    assert auto.stats == full.stats
    for name in ("t", "x", "v", "a", "poincare", "window_peaks_g", "y_end"):
        np.testing.assert_array_equal(getattr(auto, name), getattr(full, name), err_msg=name)
    assert auto.events.equals(full.events)
    assert auto.impulse_pos == full.impulse_pos


# ------------------------------------------------------------------ the measurement of an orbit

def _sawtooth(tau):
    """Slope 1 with a jump of +5 at 0.43 and of -6 at 0.97: periodic over 1 s."""
    tau = np.mod(tau, 1.0)
    return tau + 5.0 * (tau >= 0.43) - 6.0 * (tau >= 0.97)


def test_an_orbit_table_with_its_corners_is_exact_for_a_piecewise_linear_signal():
    grid = np.arange(10) / 10.0
    column = np.zeros((10, 7))
    column[:, 2] = _sawtooth(grid) * vadsim.G
    corners = np.array([0.43, 0.97])
    before = np.zeros((2, 7))
    after = np.zeros((2, 7))
    before[:, 2] = np.array([0.43, 5.97]) * vadsim.G
    after[:, 2] = _sawtooth(corners) * vadsim.G
    orbit = Orbit(t=2.0 + grid, a=column, period_s=1.0, cycles=1, corner_t=2.0 + corners,
                  corner_before=before, corner_after=after)
    # Times off the corners themselves (at a corner, rounding decides the side).
    times = 2.0 + np.concatenate([np.linspace(0.0, 3.0, 3001)[:-1], corners - 1e-9,
                                  corners + 1e-9, corners + 1.0 + 1e-9])
    times = times[np.min(np.abs(np.mod(times[:, None] - 2.0, 1.0) - corners), axis=1) > 1e-10]
    np.testing.assert_allclose(orbit.at(times, 3), _sawtooth(times - 2.0), atol=1e-9)
    # several bodies at once read each body as alone, to the bit
    both = orbit.at_bodies(times, (3, 1))
    assert np.array_equal(both[3], orbit.at(times, 3)) and not np.any(both[1])
    with pytest.raises(ValueError, match="dof = 8"):
        orbit.at_bodies(times, (3, 8))
    # Without its corners the table smears both jumps over a grid spacing.
    uniform = Orbit(t=2.0 + grid, a=column, period_s=1.0, cycles=1)
    assert np.abs(uniform.at(times, 3) - _sawtooth(times - 2.0)).max() > 1.0


@pytest.fixture(scope="module")
def small_campaign():
    return synthetic_campaign("7in-cde", (200.0, 350.0, 600.0), duration_s=3.0, noise_g=0.3,
                              seed=5, **SHORT)


def test_a_periodic_event_is_measured_from_its_orbit(small_campaign):
    settings = RunSettings("7in-cde", **SHORT)
    ev = small_campaign.events[0]
    r = run_event(small_campaign, ev, settings)
    assert r.steady_info.periodic and r.t.size == 0 and r.orbit is not None
    rate = 20 * 1024.0
    assert r.orbit.t.size == round(r.orbit.period_s * ORBIT_OVERSAMPLING * rate)
    window = settings.run(ev.flow_gpm, wob_klbf=ev.wob_klbf, record="window",
                          output_rate_hz=rate, summary_rate_hz=0.0, accelerations_only=True)
    t, a = fine_series(r, rate, (1, 5))
    np.testing.assert_array_equal(t, window.t)
    for dof in (1, 5):
        ref = window.a[:, dof - 1] / vadsim.G
        # The corners are exact, so not even a sample next to a contact's jump is off.
        assert np.abs(a[dof] - ref).max() <= 1e-2 * np.ptp(ref)
        assert a[dof].max() == pytest.approx(ref.max(), rel=1e-3)
    from_orbit = measure_event(small_campaign, ev, r, phases=2, noise_g=0.3, seed=1)
    # without the quantiles (a recording that folded has none): the rest to the bit
    folded_only = measure_event(small_campaign, ev, r, phases=2, noise_g=0.3, seed=1,
                                quantiles=False)
    dropped = set(from_orbit.sensor) - set(folded_only.sensor)
    assert dropped and has_quantiles(dropped) and not has_quantiles(folded_only.sensor)
    assert all(repr(folded_only.sensor[k]) == repr(from_orbit.sensor[k])
               for k in folded_only.sensor)
    from_window = measure_event(small_campaign, ev, window, phases=2, noise_g=0.3, seed=1)
    assert from_orbit.sensor.keys() == from_window.sensor.keys()
    for key, f in from_window.sensor.items():
        g = from_orbit.sensor[key]
        tol = max(0.02 * abs(f.value), 0.25 * f.spread if np.isfinite(f.spread) else 0, 1e-6)
        assert g.value == pytest.approx(f.value, abs=tol), key


# ------------------------------------------------------------------------------ warm starts

def _evaluate(camp, items, eids, **kw):
    with CampaignEvaluator(camp, RunSettings("7in-cde", **SHORT), phases=2, cache=False,
                           **kw) as ev:
        got = ev.evaluate(items, eids)
        return {k: v.z.copy() for k, v in got.items()}, ev.warm_starts()


def test_results_do_not_depend_on_order_workers_or_cache(small_campaign, tmp_path):
    items = [("a", ModelChange(scales={"wob": 1.03})), ("b", ModelChange(scales={"kI": 1.2}))]
    eids = [e.id for e in small_campaign.events]
    one, warm = _evaluate(small_campaign, items, eids, workers=1, warm_starts=True)
    assert set(warm) == {"e01", "e03"}  # the periodic events (200 and 600 gal/min)
    shuffled, _ = _evaluate(small_campaign, items[::-1], eids[::-1], workers=2,
                            warm_starts=True)
    given, _ = _evaluate(small_campaign, items, eids, workers=2, warm_starts=warm)
    for other in (shuffled, given):
        assert other.keys() == one.keys()
        for k in one:
            np.testing.assert_array_equal(other[k], one[k], err_msg=str(k))
    for _ in range(2):  # the second pass reads every result from the cache
        with CampaignEvaluator(small_campaign, RunSettings("7in-cde", **SHORT), phases=2,
                               cache=tmp_path, workers=2, warm_starts=True) as ev:
            cached = ev.evaluate(items, eids)
            for k, v in cached.items():
                np.testing.assert_array_equal(v.z, one[k], err_msg=str(k))


def test_a_changed_run_starts_warm_where_the_base_run_is_periodic(small_campaign):
    with CampaignEvaluator(small_campaign, RunSettings("7in-cde", **SHORT), phases=2,
                           cache=False, workers=1, warm_starts=True) as ev:
        ev.base()
        got = ev.evaluate([("w", ModelChange(scales={"wob": 1.02}))])
        starts = {e: got[("w", e)].sim.start for e in ev.event_ids}
        assert starts == {"e01": "warm", "e02": "rest", "e03": "warm"}  # 350: intermittent
        assert not any(got[("w", e)].sim.multistable for e in ev.event_ids)
    with CampaignEvaluator(small_campaign, RunSettings("7in-cde", **SHORT), phases=2,
                           cache=False, workers=1) as ev:  # the default: from rest
        got = ev.evaluate([("w", ModelChange(scales={"wob": 1.02}))])
        assert {got[("w", e)].sim.start for e in ev.event_ids} == {"rest"}


def test_a_warm_start_on_another_attractor_is_checked_against_rest():
    # 540 gal/min: from rest the 7in tool settles into regime 5 (one impact a cycle); from the
    # state of a 480 gal/min run into regime 3 (Z 1/4, 1/4). Two attractors.
    camp = synthetic_campaign("7in-cde", (540.0,), duration_s=2.0, noise_g=0.3, seed=3,
                              cycles=300, analyse_cycles=200)
    eid = camp.events[0].id
    other = vadsim.simulate("7in-cde", 480.0, cycles=300, analyse_cycles=200, record="none")
    settings = RunSettings("7in-cde", cycles=300, analyse_cycles=200)
    start = {eid: WarmStart(other.end_displacement, scenario=5)}
    # A change that runs the model but moves nothing: a hydraulic force of zero.
    nothing = ModelChange(extras=(ExtraSpec.of("hydraulic", acts_on="anvil", c=0.0),))
    assert nothing.changes_run
    with CampaignEvaluator(camp, settings, phases=1, cache=False, workers=1,
                           warm_starts=start) as ev:
        sim = ev.simulate(nothing, eid)
    assert sim is not None
    assert sim.multistable and sim.start == "rest" and sim.scenario == 5


def test_a_measurement_draws_its_noise_phase_by_phase_once_per_seed(small_campaign):
    """The noise of each sampling phase comes from the seed's generator in the order phase
    by phase, sensor by sensor (the order every earlier measurement drew it in), and the
    same seed and grid give the very same (read-only) draws without drawing again."""
    from vadsim.compare.events import _phase_noise
    from vadsim.signals.sensor import sample_count

    t = np.arange(0.0, 1.0, 1.0 / 20480.0)
    noise = {"x1": 0.3, "x5": 0.5}
    got = _phase_noise(small_campaign, t, 3, noise, 7)
    rng = np.random.default_rng(7)
    for k in range(3):
        for name in small_campaign.sensors:
            want = rng.normal(0.0, noise[name], size=sample_count(t, 1024.0, k / 3))
            assert np.array_equal(got[name][k], want)
            assert not got[name][k].flags.writeable
    again = _phase_noise(small_campaign, t, 3, noise, 7)
    assert all(a is b for n in got for a, b in zip(got[n], again[n], strict=True))
    assert not np.array_equal(_phase_noise(small_campaign, t, 3, noise, 8)["x1"][0],
                              got["x1"][0])
    with pytest.raises(ValueError, match=r"noise_g\['x1'\] must be a finite number >= 0"):
        _phase_noise(small_campaign, t, 3, {"x1": -1.0}, 7)
