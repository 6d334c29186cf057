"""Tests of vadsim.signals.labels on constructed signals whose labels are known analytically."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from vadsim.signals.labels import (
    SCENARIO_NONE,
    SCENARIO_SPRING_ONLY,
    Z_EQ_TOL,
    impact_frequency,
    impacts_per_cycle,
    impulse_per_second,
    onset_times,
    peak_stats,
    periodicity,
    poincare_period,
    regime_name,
    scenario,
    surface_state,
    window_peaks,
)

RATE = 1024.0

# --------------------------------------------------------------------------------------------
# Impacts per cycle
# --------------------------------------------------------------------------------------------


def test_impacts_per_cycle_counts_half_open_window() -> None:
    f = 21.3
    onsets = np.arange(401) / f  # one onset at the start of every cycle
    t0, t1 = 200 / f, 400 / f
    # [t0, t1) holds onsets 200..399 but not the one at t1 itself.
    assert impacts_per_cycle(onsets, t0, t1, f) == pytest.approx(1.0)
    assert impacts_per_cycle(onsets[::2], t0, t1, f) == pytest.approx(0.5)
    assert impacts_per_cycle([], t0, t1, f) == 0.0
    # Order does not matter.
    assert impacts_per_cycle(onsets[::-1], t0, t1, f) == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("args", "name"),
    [
        (([0.1], 1.0, 1.0, 10.0), "t0"),
        (([0.1], 2.0, 1.0, 10.0), "t0"),
        (([0.1], 0.0, 1.0, 0.0), "f_exc_hz"),
        (([0.1], 0.0, 1.0, -5.0), "f_exc_hz"),
        (([math.nan], 0.0, 1.0, 5.0), "onset_times"),
    ],
)
def test_impacts_per_cycle_rejects_bad_arguments(args: tuple, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        impacts_per_cycle(*args)


def test_onset_times_are_upward_zero_crossings() -> None:
    f = 7.0
    t = np.linspace(0.0, 3.0, 30001)
    # The small phase lag makes d start just below 0, so k = 0 is an onset too.
    lag = 1e-6
    onsets = onset_times(t, np.sin(2 * np.pi * f * t - lag))
    expected = (np.arange(21) + lag / (2 * np.pi)) / f
    # Linear interpolation of a sine near its zero crossing: error O(dt^3 f^2), far below 1e-9.
    np.testing.assert_allclose(onsets, expected, rtol=0, atol=1e-9)


def test_onset_times_ignores_contact_open_at_start() -> None:
    t = np.arange(5.0)
    assert onset_times(t, [1.0, 2.0, -1.0, 1.0, 1.0]).tolist() == [2.5]


# --------------------------------------------------------------------------------------------
# Surface states and scenarios
# --------------------------------------------------------------------------------------------

# regimes_7in.csv: the dissertation's five regimes of the 7in flow sweep (surface1, surface2).
REGIMES_7IN = [
    (1, "regular", "regular"),
    (2, "intermittent", "regular"),
    (3, "intermittent", "intermittent"),
    (4, "none", "intermittent"),
    (5, "none", "regular"),
]
Z_OF_STATE = {"regular": 1.0, "intermittent": 0.5, "none": 0.0}


@pytest.mark.parametrize(("code", "s1", "s2"), REGIMES_7IN)
def test_scenario_reproduces_regimes_7in(code: int, s1: str, s2: str) -> None:
    assert scenario(Z_OF_STATE[s1], Z_OF_STATE[s2]) == code
    assert surface_state(Z_OF_STATE[s1]) == s1
    assert surface_state(Z_OF_STATE[s2]) == s2


@pytest.mark.parametrize(
    ("z1", "z2", "code"),
    [
        (1.0, 1.0, 1),
        (0.43, 1.0, 2),
        (0.43, 0.79, 3),
        (0.0, 0.79, 4),
        (0.0, 1.0, 5),
        (1.0, 2 / 3, 6),
        (0.0, 0.0, SCENARIO_NONE),
        (1.0, 0.0, SCENARIO_SPRING_ONLY),
        (0.5, 0.0, SCENARIO_SPRING_ONLY),
        # Tolerance edges, Z over 200 cycles.
        (199 / 200, 199 / 200, 1),  # one missed impact each is still regular
        (196 / 200, 1.0, 1),  # four missed: the documented limit
        (195 / 200, 1.0, 2),  # five missed: intermittent
        (1 / 200, 1.0, 5),  # one stray spring impact counts as none
        (4 / 200, 1.0, 5),
        (5 / 200, 1.0, 2),
        (1 / 2, 2 / 3, 3),  # the 7in model's rational Z are intermittent
        (0.0, 7 / 8, 4),
        (0.0, 48 / 49, 4),
        # Z > 1: two impacts every cycle is regular, a 1/2 mix is not.
        (2.0, 2.0, 1),
        (399 / 200, 1.0, 1),
        (1.5, 1.0, 2),
        (0.0, 1.5, 4),
    ],
)
def test_scenario_table_and_tolerance(z1: float, z2: float, code: int) -> None:
    assert scenario(z1, z2) == code


def test_tolerance_is_an_argument() -> None:
    # Over 20 cycles one missed impact is 0.95; a looser tolerance can call it regular.
    assert surface_state(19 / 20) == "intermittent"
    assert surface_state(19 / 20, tol=0.05) == "regular"
    assert scenario(19 / 20, 1.0, tol=0.05) == 1
    assert surface_state(Z_EQ_TOL) == "none"
    assert surface_state(1.0, tol=0.0) == "regular"
    assert surface_state(0.999, tol=0.0) == "intermittent"


@given(st.floats(min_value=0.0, max_value=10.0, allow_nan=False))
def test_surface_state_partitions_z(z: float) -> None:
    state = surface_state(z)
    near_int = abs(z - round(z)) <= Z_EQ_TOL + 1e-9
    if z <= Z_EQ_TOL + 1e-9:
        assert state == "none"
    elif near_int:
        assert state == "regular"
    else:
        assert state == "intermittent"


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"z_spring": -0.1, "z_impact": 1.0}, "z_spring"),
        ({"z_spring": 1.0, "z_impact": math.nan}, "z_impact"),
        ({"z_spring": 1.0, "z_impact": 1.0, "tol": 0.5}, "tol"),
        ({"z_spring": 1.0, "z_impact": 1.0, "tol": -0.01}, "tol"),
    ],
)
def test_scenario_rejects_bad_arguments(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        scenario(**kwargs)


def test_regime_names() -> None:
    names = [regime_name(code) for code in range(8)]
    assert len(set(names)) == 8
    assert all(isinstance(n, str) and n for n in names)
    assert "intermittent" in regime_name(3)
    with pytest.raises(ValueError, match="scenario"):
        regime_name(8)
    with pytest.raises(ValueError, match="scenario"):
        regime_name("x")  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------
# Impulse per second
# --------------------------------------------------------------------------------------------


def test_impulse_of_half_sine_pulse_train() -> None:
    # Pulses A sin(pi s / tau) for 0 <= s < tau in every period T: impulse 2 A tau / pi each.
    amplitude, tau, period = 300.0, 2e-3, 1 / 21.3
    t = np.linspace(0.0, 50 * period, 500_001)
    s = np.mod(t, period)
    force = np.where(s < tau, amplitude * np.sin(np.pi * s / tau), 0.0)
    expected = 2 * amplitude * tau / (np.pi * period)
    mean, mean_positive = impulse_per_second(t, force)
    assert mean == pytest.approx(expected, rel=1e-4)
    assert mean_positive == pytest.approx(expected, rel=1e-4)


def test_impulse_positive_part_excludes_tension() -> None:
    # A full sine: the plain mean is 0, the positive part averages A / pi.
    amplitude, f = 50.0, 10.0
    t = np.linspace(0.0, 20 / f, 200_001)
    mean, mean_positive = impulse_per_second(t, amplitude * np.sin(2 * np.pi * f * t))
    assert mean == pytest.approx(0.0, abs=1e-9)
    assert mean_positive == pytest.approx(amplitude / np.pi, rel=1e-6)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=2, max_size=50),
)
def test_impulse_positive_mean_bounds(values: list[float]) -> None:
    force = np.asarray(values)
    t = np.arange(force.size) * 1e-3
    mean, mean_positive = impulse_per_second(t, force)
    assert mean_positive >= max(mean, 0.0) - 1e-9
    assert mean_positive <= max(force.max(), 0.0) + 1e-9


def test_impulse_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="force"):
        impulse_per_second([0.0, 1.0], [1.0, math.nan])
    with pytest.raises(ValueError, match="t must be strictly increasing"):
        impulse_per_second([0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="differ in length"):
        impulse_per_second([0.0, 1.0, 2.0], [1.0, 1.0])


# --------------------------------------------------------------------------------------------
# Window peaks
# --------------------------------------------------------------------------------------------


def test_window_peaks_of_known_signal() -> None:
    n = int(1.1 * RATE)  # five full 200 ms windows and a partial one
    a = np.zeros(n)
    t = np.arange(n) / RATE
    expected = np.array([3.0, 7.0, 1.0, 9.0, 4.0])
    for i, peak in enumerate(expected):
        k = np.flatnonzero((t >= 0.2 * i) & (t < 0.2 * (i + 1)))
        a[k[len(k) // 2]] = peak * (-1) ** i  # |a| counts, whatever the sign
        a[k[len(k) // 3]] = 0.5 * peak
    a[-10] = 100.0  # in the dropped partial window
    np.testing.assert_array_equal(window_peaks(a, RATE), expected)
    mean, std = peak_stats(a, RATE)
    assert mean == pytest.approx(expected.mean())
    assert std == pytest.approx(expected.std(ddof=0))


def test_window_edges_follow_time_not_a_rounded_sample_count() -> None:
    # 200 ms at 1024 Hz is 204.8 samples: sample 204 (t = 0.1992 s) is in window 0,
    # sample 205 (t = 0.2002 s) in window 1.
    a = np.zeros(1024)
    a[204] = 5.0
    np.testing.assert_array_equal(window_peaks(a, RATE), [5.0, 0.0, 0.0, 0.0, 0.0])
    a[204], a[205] = 0.0, 5.0
    np.testing.assert_array_equal(window_peaks(a, RATE), [0.0, 5.0, 0.0, 0.0, 0.0])


def test_window_peaks_of_sine() -> None:
    t = np.arange(int(2 * RATE)) / RATE
    peaks = window_peaks(30.0 * np.sin(2 * np.pi * 21.3 * t), RATE)
    assert peaks.size == 10
    # Sampled at 1024 Hz a 21.3 Hz sine's crest is missed by at most half a sample.
    assert np.all(peaks <= 30.0)
    assert np.all(peaks >= 30.0 * np.cos(np.pi * 21.3 / RATE))


def test_window_peaks_rejects_short_signal() -> None:
    with pytest.raises(ValueError, match="shorter than one window"):
        window_peaks(np.ones(100), RATE)
    with pytest.raises(ValueError, match="rate_hz"):
        window_peaks(np.ones(1000), 0.0)
    with pytest.raises(ValueError, match="window_s"):
        peak_stats(np.ones(1000), RATE, window_s=-0.2)


# --------------------------------------------------------------------------------------------
# Impact frequency
# --------------------------------------------------------------------------------------------


def spike_train(
    f: float,
    offsets: list[float],
    heights: list[float],
    cycles: int,
    noise_g: float,
    seed: int = 0,
) -> np.ndarray:
    """Impact-like spikes (a 1 ms Gaussian and a decaying 300 Hz ring) at given cycle phases."""
    t = np.arange(int(cycles / f * RATE)) / RATE
    a = np.zeros_like(t)
    for k in range(cycles + 1):
        for offset, height in zip(offsets, heights, strict=True):
            s = t - (k + offset) / f
            a += height * np.exp(-0.5 * (s / 1e-3) ** 2)
            ring = s > 0
            a[ring] += 0.3 * height * np.exp(-s[ring] / 3e-3) * np.sin(2 * np.pi * 300 * s[ring])
    return a + np.random.default_rng(seed).normal(0.0, noise_g, t.size)


@pytest.mark.parametrize("f", [8.9, 21.3, 64.0])
def test_impact_frequency_one_major_spike_per_cycle(f: float) -> None:
    # Three peaks per cycle, one major (the 7in field pattern): counts f.
    a = spike_train(f, [0.1, 0.4, 0.7], [60.0, 20.0, 15.0], cycles=200, noise_g=2.0)
    duration = a.size / RATE
    assert impact_frequency(a, RATE) == pytest.approx(f, abs=1.0 / duration + 1e-9)


@pytest.mark.parametrize("f", [21.3, 64.0])
def test_impact_frequency_two_equal_spikes_per_cycle(f: float) -> None:
    a = spike_train(f, [0.2, 0.7], [50.0, 50.0], cycles=200, noise_g=2.0, seed=1)
    duration = a.size / RATE
    assert impact_frequency(a, RATE) == pytest.approx(2 * f, abs=2.0 / duration + 1e-9)


def test_impact_frequency_robust_to_noise_seed() -> None:
    f = 26.7
    results = [
        impact_frequency(spike_train(f, [0.3], [40.0], cycles=100, noise_g=4.0, seed=s), RATE)
        for s in range(5)
    ]
    np.testing.assert_allclose(results, f, atol=1.0 / (100 / f))


def test_impact_frequency_of_silence_is_zero() -> None:
    assert impact_frequency(np.zeros(2048), RATE) == 0.0


def test_impact_frequency_rejects_bad_arguments() -> None:
    a = np.ones(2048)
    with pytest.raises(ValueError, match="height_frac"):
        impact_frequency(a, RATE, height_frac=0.0)
    with pytest.raises(ValueError, match="min_distance_s"):
        impact_frequency(a, RATE, min_distance_s=-1.0)
    with pytest.raises(ValueError, match="signal_g"):
        impact_frequency(np.r_[a, math.inf], RATE)


# --------------------------------------------------------------------------------------------
# Poincare sections
# --------------------------------------------------------------------------------------------


def periodic_section(period: int, n: int = 200, noise: float = 1e-9, seed: int = 0) -> np.ndarray:
    """Build a period-p orbit of 6 states of different scales and offsets, plus Gaussian noise.

    Each component visits p points equally spaced in phase on a cosine, so distinct points of
    the orbit differ by a good fraction of the component's spread; ``noise`` is relative to it.
    """
    c = np.arange(6)
    j = np.arange(period)[:, None]
    amplitude = 10.0 ** (c - 2)  # from 0.01 to 1000: the test must not depend on units
    base = amplitude * np.cos(2 * np.pi * j / period + c) + 3 * amplitude * c
    section = np.tile(base, (n // period + 1, 1))[:n]
    rng = np.random.default_rng(seed)
    return section + noise * amplitude * rng.normal(size=section.shape)


@pytest.mark.parametrize("period", [1, 2, 3, 5, 8])
def test_poincare_period_of_constructed_orbits(period: int) -> None:
    section = periodic_section(period)
    assert poincare_period(section) == period
    assert periodicity(section) == f"period-{period}"


def test_poincare_period_ignores_transient_before_the_tail() -> None:
    section = periodic_section(2)
    k = np.arange(section.shape[0])[:, None]
    # Decays to 1e-9 of the spread by row 100, where the default tail starts.
    section = section + 5.0 * 0.8**k
    assert poincare_period(section) == 2
    assert poincare_period(section, tail=1.0) is None


def test_poincare_period_respects_tolerance_and_max_period() -> None:
    # Noise of 1 % of the amplitude: beyond the default 1e-3 of the spread, within 0.1.
    assert poincare_period(periodic_section(3, noise=1e-2)) is None
    assert poincare_period(periodic_section(3, noise=1e-2), rtol=0.1) == 3
    assert poincare_period(periodic_section(3), max_period=2) is None
    # 9 > max_period = 8 is not found.
    assert poincare_period(periodic_section(9)) is None


def test_poincare_period_one_uses_a_magnitude_floor() -> None:
    # A period-1 orbit: the spread is roundoff only and must not become the yardstick.
    section = np.full((200, 3), [1.5, -20.0, 0.3])
    section *= 1.0 + 1e-12 * np.random.default_rng(3).normal(size=section.shape)
    assert poincare_period(section) == 1
    # An explicit scale works too, e.g. the trajectory's amplitude per component.
    assert poincare_period(section, scale=[0.1, 2.0, 0.05]) == 1
    with pytest.raises(ValueError, match="scale"):
        poincare_period(section, scale=[1.0, 0.0, 1.0])


def test_poincare_period_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="section"):
        poincare_period(np.ones((10, 2, 2)))
    with pytest.raises(ValueError, match="section"):
        poincare_period(np.full((10, 2), math.nan))
    with pytest.raises(ValueError, match="tail"):
        poincare_period(np.ones((10, 2)), tail=0.0)
    with pytest.raises(ValueError, match="max_period"):
        poincare_period(np.ones((10, 2)), max_period=0)
    with pytest.raises(ValueError, match="at least 3"):
        poincare_period(np.ones((4, 2)))


def invariant_circle(rotation: float, n: int = 200) -> np.ndarray:
    theta = 2 * np.pi * rotation * np.arange(n)
    return np.column_stack([np.cos(theta), np.sin(theta)])


@pytest.mark.parametrize("rotation", [math.sqrt(2), (math.sqrt(5) - 1) / 2, math.pi / 100])
def test_quasi_periodic_invariant_circle(rotation: float) -> None:
    circle = invariant_circle(rotation)
    assert poincare_period(circle) is None
    assert periodicity(circle) == "quasi-periodic"


def test_quasi_periodic_in_a_high_dimensional_state_with_noise() -> None:
    # A circle embedded in a 14-state section (7 dofs), shifted, skewed and slightly noisy.
    rng = np.random.default_rng(7)
    circle = invariant_circle(math.sqrt(3))
    section = circle @ rng.normal(size=(2, 14)) + 10.0 + 0.3 * circle[:, :1] ** 2
    section += 0.01 * rng.normal(size=section.shape)
    assert periodicity(section) == "quasi-periodic"


def test_quasi_periodic_scalar_section() -> None:
    k = np.arange(200)
    assert periodicity(np.cos(2 * np.pi * math.sqrt(2) * k)) == "quasi-periodic"


def test_quasi_periodic_chain_of_circles() -> None:
    # A torus after a period doubling: the section alternates between two circles.
    k = np.arange(200)
    theta = 2 * np.pi * math.sqrt(2) / 5 * k
    sign = (-1.0) ** k
    section = np.column_stack([np.cos(theta) + 3 * sign, np.sin(theta), sign * np.cos(theta)])
    assert poincare_period(section) is None
    assert periodicity(section) == "quasi-periodic"


def logistic(r: float, n: int, x0: float = 0.3) -> np.ndarray:
    x = np.empty(n)
    x[0] = x0
    for i in range(n - 1):
        x[i + 1] = r * x[i] * (1 - x[i])
    return x


def test_aperiodic_logistic_map() -> None:
    x = logistic(3.9, 200)
    assert periodicity(x) == "aperiodic"
    assert periodicity(np.column_stack([x[:-1], x[1:]])) == "aperiodic"


def test_periodic_logistic_map() -> None:
    # r = 3.2 settles on a period-2 orbit, r = 3.5 on period-4.
    assert periodicity(logistic(3.2, 400)) == "period-2"
    assert periodicity(logistic(3.5, 400)) == "period-4"


def test_aperiodic_random_and_henon() -> None:
    rng = np.random.default_rng(11)
    assert periodicity(rng.normal(size=(200, 4))) == "aperiodic"
    # Random points on a circle are on a closed curve but the map is not a rotation.
    theta = rng.uniform(0.0, 2 * np.pi, 200)
    assert periodicity(np.column_stack([np.cos(theta), np.sin(theta)])) == "aperiodic"
    h = np.zeros((1200, 2))
    h[0] = [0.1, 0.1]
    for i in range(1199):
        h[i + 1] = [1 - 1.4 * h[i, 0] ** 2 + h[i, 1], 0.3 * h[i, 0]]
    assert periodicity(h[1000:]) == "aperiodic"


def test_converging_focus_and_unresolved_arc_are_not_quasi_periodic() -> None:
    k = np.arange(200)[:, None]
    # A period-1 focus still converging by 0.5 % per cycle: rotates, but spirals in.
    spiral = 0.995**k * invariant_circle((math.sqrt(5) - 1) / 2)
    assert periodicity(spiral) == "aperiodic"
    # A slow drift over a third of a turn keeps the order but never closes.
    assert periodicity(invariant_circle(0.003)) == "aperiodic"
