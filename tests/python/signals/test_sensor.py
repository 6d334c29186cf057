"""Tests of vadsim.signals.sensor: the sensor chain on signals with known outputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from vadsim.signals.sensor import sensor_chain

RATE = 1024.0
FINE = 20 * RATE  # 20480 Hz: every sensor sample at phase 0 falls on a fine sample


def fine_grid(duration_s: float, fine_rate: float = FINE, t0: float = 0.0) -> np.ndarray:
    return t0 + np.arange(round(duration_s * fine_rate) + 1) / fine_rate


def tone_amplitude(t: np.ndarray, a: np.ndarray, f: float) -> tuple[float, float]:
    """Least-squares amplitude and phase of a tone of known frequency f in a."""
    design = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
    (s, c), *_ = np.linalg.lstsq(design, a, rcond=None)
    return math.hypot(s, c), math.atan2(c, s)


# --------------------------------------------------------------------------------------------
# Sampling
# --------------------------------------------------------------------------------------------


def test_plain_sampling_picks_the_fine_samples() -> None:
    t = fine_grid(1.0)
    a = np.random.default_rng(0).normal(0.0, 10.0, t.size)
    t_s, a_s, clipped = sensor_chain(t, a)
    assert t_s.size == 1025  # 0, 1/1024, ..., 1.0 s inclusive
    np.testing.assert_allclose(t_s, np.arange(1025) / RATE, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a_s, a[::20], rtol=0, atol=1e-9)
    assert not clipped.any()


@pytest.mark.parametrize("phase", [0.0, 0.25, 0.5, 0.999])
def test_sampling_phase_shifts_the_sample_times(phase: float) -> None:
    t = fine_grid(0.5, t0=3.0)
    # A ramp is interpolated exactly: the output shows where the samples were taken.
    t_s, a_s, _ = sensor_chain(t, 2.0 * (t - 3.0) + 1.0, phase=phase)
    assert t_s[0] == pytest.approx(3.0 + phase / RATE, abs=1e-12)
    np.testing.assert_allclose(np.diff(t_s), 1.0 / RATE, rtol=1e-9)
    np.testing.assert_allclose(a_s, 2.0 * (t_s - 3.0) + 1.0, rtol=0, atol=1e-9)
    assert t_s[-1] <= t[-1] + 1e-12
    assert t_s[-1] + 1.0 / RATE > t[-1]  # every sample that fits is taken
    assert t_s.size == (513 if phase == 0.0 else 512)


def test_sampling_phase_on_a_sine() -> None:
    f = 37.0
    t = fine_grid(1.0)
    a = 100.0 * np.sin(2 * np.pi * f * t)
    t_s, a_s, _ = sensor_chain(t, a, phase=0.37)
    expected = 100.0 * np.sin(2 * np.pi * f * (np.arange(t_s.size) + 0.37) / RATE)
    # Linear interpolation error: (pi f dt)^2 / 2 of the amplitude at most.
    bound = 100.0 * (np.pi * f / FINE) ** 2 / 2
    np.testing.assert_allclose(a_s, expected, rtol=0, atol=bound * 1.01)


# --------------------------------------------------------------------------------------------
# Low-pass
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("f", [50.0, 200.0, 350.0])
def test_lowpass_gain_matches_butterworth(f: float) -> None:
    corner = 400.0
    t = fine_grid(1.0)
    _, a_s, _ = sensor_chain(t, np.sin(2 * np.pi * f * t), lowpass_hz=corner)
    t_s = np.arange(a_s.size) / RATE
    steady = t_s >= 0.5  # the start-up transient decays within a few corner periods
    amplitude, _ = tone_amplitude(t_s[steady], a_s[steady], f)
    # Analog 4th-order Butterworth: |H(f)| = 1 / sqrt(1 + (f / fc)^8). The digital filter on
    # a 20 kHz grid is its bilinear image, within 1e-3 below the corner.
    gain = 1.0 / math.sqrt(1.0 + (f / corner) ** 8)
    assert amplitude == pytest.approx(gain, rel=2e-3)


def test_lowpass_is_causal() -> None:
    # A step at 0.25 s must not show before it (a zero-phase filter would ring ahead of it).
    t = fine_grid(0.5)
    step = np.where(t >= 0.25, 100.0, 0.0)
    t_s, a_s, _ = sensor_chain(t, step, lowpass_hz=400.0)
    before = t_s < 0.25
    assert np.all(a_s[before] == 0.0)
    assert a_s[~before][-1] == pytest.approx(100.0, rel=1e-6)  # unit DC gain


def test_lowpass_delays_a_tone_by_the_butterworth_phase() -> None:
    f, corner = 100.0, 400.0
    t = fine_grid(1.0)
    _, a_s, _ = sensor_chain(t, np.sin(2 * np.pi * f * t), lowpass_hz=corner)
    t_s = np.arange(a_s.size) / RATE
    steady = t_s >= 0.5
    _, phase = tone_amplitude(t_s[steady], a_s[steady], f)
    # Phase of the analog Butterworth at f: sum over its 4 poles.
    poles = corner * np.exp(1j * np.pi * (2 * np.arange(1, 5) + 3) / 8)
    expected = -np.sum(np.angle(1j * f - poles) - np.angle(-poles))
    assert phase == pytest.approx(expected, abs=5e-3)


def test_lowpass_starts_from_the_first_value() -> None:
    # A constant input passes unchanged: the filter starts in its steady state.
    t = fine_grid(0.2)
    _, a_s, _ = sensor_chain(t, np.full(t.size, -3.5), lowpass_hz=300.0)
    np.testing.assert_allclose(a_s, -3.5, rtol=1e-9)


# --------------------------------------------------------------------------------------------
# Clipping
# --------------------------------------------------------------------------------------------


def test_clipping_flags_exactly_the_samples_beyond_the_range() -> None:
    t = fine_grid(0.5)
    a = 300.0 * np.sin(2 * np.pi * 21.3 * t)
    t_s, a_s, clipped = sensor_chain(t, a, range_g=250.0)
    assert t_s.size == 513
    raw = a[::20]  # phase 0: the samples fall on the fine grid
    np.testing.assert_array_equal(clipped, np.abs(raw) >= 250.0)
    assert 0 < clipped.sum() < clipped.size
    np.testing.assert_array_equal(a_s[clipped], 250.0 * np.sign(raw[clipped]))
    np.testing.assert_allclose(a_s[~clipped], raw[~clipped], rtol=0, atol=1e-9)


def test_sample_at_the_rail_is_flagged() -> None:
    t = fine_grid(0.01)
    a = np.zeros(t.size)
    a[40] = 250.0  # t = 40 / 20480 s = 2 / 1024 s: sample 2
    _, a_s, clipped = sensor_chain(t, a, range_g=250.0)
    assert clipped.tolist() == [False, False, True] + [False] * (a_s.size - 3)


@settings(max_examples=60, deadline=None)
@given(
    values=hnp.arrays(
        np.float64,
        st.integers(8, 80),
        elements=st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False),
    ),
    range_g=st.floats(1.0, 500.0),
    phase=st.floats(0.0, 0.999),
    oversampling=st.integers(4, 9),
)
def test_clipping_invariants(
    values: np.ndarray, range_g: float, phase: float, oversampling: int
) -> None:
    rate = 100.0
    t = np.arange(values.size) / (oversampling * rate)
    t_raw, raw, never = sensor_chain(t, values, rate_hz=rate, range_g=1e9, phase=phase)
    t_s, a_s, clipped = sensor_chain(t, values, rate_hz=rate, range_g=range_g, phase=phase)
    assert not never.any()
    np.testing.assert_array_equal(t_s, t_raw)
    assert np.all(np.abs(a_s) <= range_g)
    np.testing.assert_array_equal(clipped, np.abs(raw) >= range_g)
    np.testing.assert_array_equal(a_s[~clipped], raw[~clipped])
    np.testing.assert_array_equal(np.abs(a_s[clipped]), range_g)
    np.testing.assert_array_equal(np.sign(a_s[clipped]), np.sign(raw[clipped]))


# --------------------------------------------------------------------------------------------
# Noise
# --------------------------------------------------------------------------------------------


def test_noise_has_the_requested_std_and_is_reproducible() -> None:
    t = fine_grid(20.0, fine_rate=4 * RATE)
    zero = np.zeros(t.size)
    _, a_s, _ = sensor_chain(t, zero, noise_g=2.0, rng=42)
    n = a_s.size
    # std of a normal sample: relative standard error 1 / sqrt(2 n) = 0.5 %; allow 4 sigma.
    assert np.std(a_s) == pytest.approx(2.0, rel=4 / math.sqrt(2 * n))
    assert abs(np.mean(a_s)) < 4 * 2.0 / math.sqrt(n)
    _, again, _ = sensor_chain(t, zero, noise_g=2.0, rng=42)
    np.testing.assert_array_equal(a_s, again)
    _, from_generator, _ = sensor_chain(t, zero, noise_g=2.0, rng=np.random.default_rng(42))
    np.testing.assert_array_equal(a_s, from_generator)


def test_noise_is_clipped_too() -> None:
    t = fine_grid(1.0)
    _, a_s, clipped = sensor_chain(t, np.full(t.size, 9.0), range_g=10.0, noise_g=1.0, rng=1)
    assert np.all(a_s <= 10.0)
    # P(9 + N(0, 1) >= 10) = 15.9 %
    assert clipped.mean() == pytest.approx(0.159, abs=0.05)


# --------------------------------------------------------------------------------------------
# Bad arguments
# --------------------------------------------------------------------------------------------

T_OK = fine_grid(0.1)
A_OK = np.zeros(T_OK.size)


def _with(index: int, value: float, base: np.ndarray) -> np.ndarray:
    out = base.copy()
    out[index] = value
    return out


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"rate_hz": 0.0}, "rate_hz"),
        ({"rate_hz": -1024.0}, "rate_hz"),
        ({"rate_hz": math.nan}, "rate_hz"),
        ({"rate_hz": 8000.0}, "rate_hz"),  # fine grid 20480 Hz < 4 x 8000 Hz
        ({"range_g": 0.0}, "range_g"),
        ({"range_g": -250.0}, "range_g"),
        ({"range_g": math.inf}, "range_g"),
        ({"lowpass_hz": 0.0}, "lowpass_hz"),
        ({"lowpass_hz": -400.0}, "lowpass_hz"),
        ({"lowpass_hz": FINE / 2}, "lowpass_hz"),
        ({"lowpass_hz": 2 * FINE}, "lowpass_hz"),
        ({"phase": 1.0}, "phase"),
        ({"phase": -0.1}, "phase"),
        ({"phase": math.nan}, "phase"),
        ({"phase": "early"}, "phase"),
        ({"noise_g": -1.0}, "noise_g"),
        ({"noise_g": math.nan}, "noise_g"),
        ({"t": _with(10, T_OK[10] + 0.3 / FINE, T_OK)}, "uniform"),
        ({"t": T_OK[::-1]}, "strictly increasing"),
        ({"t": _with(5, T_OK[4], T_OK)}, "strictly increasing"),
        ({"t": _with(3, math.nan, T_OK)}, "t has a non-finite"),
        ({"t": T_OK[:1], "a_g": A_OK[:1]}, "t needs at least 2"),
        ({"t": np.ones((2, 3)), "a_g": np.ones((2, 3))}, "t must be one-dimensional"),
        ({"a_g": _with(7, math.nan, A_OK)}, "a_g has a non-finite"),
        ({"a_g": A_OK[:-1]}, "a_g must have the length of t"),
    ],
)
def test_bad_arguments_name_the_argument(kwargs: dict, name: str) -> None:
    call = {"t": T_OK, "a_g": A_OK} | kwargs
    with pytest.raises(ValueError, match=name):
        sensor_chain(**call)


def test_error_message_carries_the_bad_value() -> None:
    with pytest.raises(ValueError, match=r"rate_hz.*-3\.0"):
        sensor_chain(T_OK, A_OK, rate_hz=-3.0)
    with pytest.raises(ValueError, match=r"lowpass_hz=12000\.0.*10240"):
        sensor_chain(T_OK, A_OK, lowpass_hz=12000.0)


def test_one_filtered_signal_serves_every_phase_and_the_fold_bit_for_bit() -> None:
    """A measurement filters a run once and samples it at several phases (with noise drawn
    in turn from one generator) and clips it for the fold: each must be what the one-shot
    chains give, to the bit, or a diagnosis would change with the refactoring."""
    from vadsim.signals.sensor import FilteredSignal, analog_chain

    t = np.arange(0, 0.5, 1.0 / 20480.0)
    a = 30.0 * np.sin(2 * np.pi * 37.0 * t) + 200.0 * np.exp(-((t % 0.047) / 4e-4) ** 2)
    filtered = FilteredSignal(t, a, lowpass_hz=400.0)
    rng_a, rng_b = np.random.default_rng(3), np.random.default_rng(3)
    for phase in (0.0, 0.25, 0.5, 0.75):
        got = filtered.sample(1024.0, 60.0, phase, 0.5, rng_a)
        want = sensor_chain(t, a, rate_hz=1024.0, range_g=60.0, lowpass_hz=400.0,
                            phase=phase, noise_g=0.5, rng=rng_b)
        assert np.any(want[2])  # the range clips some samples, so clipping is compared too
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w)
    # every phase from one interpolation, each with its own draw, as one call per phase
    phases = (0.0, 0.25, 0.5, 0.75)
    rng_c, rng_d = np.random.default_rng(4), np.random.default_rng(4)
    draws = [rng_c.normal(0.0, 0.5, size=filtered.sample_times(1024.0, p).size)
             for p in phases]
    together = filtered.sample_phases(1024.0, 60.0, phases, draws)
    for phase, (a_s, clip) in zip(phases, together, strict=True):
        _, want_s, want_clip = filtered.sample(1024.0, 60.0, phase, 0.5, rng_d)
        assert np.array_equal(a_s, want_s) and np.array_equal(clip, want_clip)
    with pytest.raises(ValueError, match="2 draws for 4 phases"):
        filtered.sample_phases(1024.0, 60.0, phases, draws[:2])
    with pytest.raises(ValueError, match="phase must be in"):
        filtered.sample_phases(1024.0, 60.0, (1.5,), [None])
    got_a, got_m = filtered.analog(60.0)
    want_a, want_m = analog_chain(t, a, lowpass_hz=400.0, range_g=60.0)
    assert np.array_equal(got_a, want_a) and np.array_equal(got_m, want_m)
