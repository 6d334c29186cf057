"""Tests of vadsim.signals.features on constructed signals whose features are known analytically."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest
from vadsim.compare import residual_table
from vadsim.signals.bands import DEFAULT_BANDS, band_edges_for, band_key
from vadsim.signals.features import (
    REL_SPREAD_FLOOR,
    SPREAD_FLOORS,
    Feature,
    features_table,
    summary_features,
)
from vadsim.signals.labels import (
    IMPACT_HEIGHT_FRAC,
    impact_frequency,
    peak_stats,
    window_bounds,
    window_peaks,
)
from vadsim.signals.window_features import event_features, phase_features, sensor_features

RATE = 1024.0
BAND_KEYS = [band_key(lo, hi) for lo, hi in DEFAULT_BANDS]


def spike_train(
    f_hz: float, height: float, duration_s: float, phases=(0.5,), heights=None
) -> np.ndarray:
    """Single-sample spikes at ``(k + phase) / f_hz``; ``heights`` scales each phase's spikes.

    The default phase keeps a spike off sample 0, where ``find_peaks`` sees no peak.
    """
    n = round(duration_s * RATE)
    a = np.zeros(n)
    heights = [1.0] * len(phases) if heights is None else heights
    for phase, scale in zip(phases, heights, strict=True):
        idx = np.round((np.arange(math.ceil(duration_s * f_hz) + 1) + phase) * RATE / f_hz)
        idx = idx[idx < n].astype(int)
        a[idx] = scale * height
    return a


def floor(value: float, kind: str) -> float:
    return max(REL_SPREAD_FLOOR * abs(value), SPREAD_FLOORS[kind])


# --------------------------------------------------------------------------------------------
# Feature record
# --------------------------------------------------------------------------------------------


def test_feature_is_frozen_and_validated() -> None:
    f = Feature(1, 2, 3)
    assert (f.value, f.spread, f.n) == (1.0, 2.0, 3)
    with pytest.raises(AttributeError):
        f.value = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="spread"):
        Feature(1.0, -1.0, 3)
    with pytest.raises(ValueError, match="n must"):
        Feature(1.0, 1.0, -1)
    with pytest.raises(ValueError, match="value"):
        Feature("x", 1.0, 1)  # type: ignore[arg-type]
    assert math.isnan(Feature(math.nan, math.nan, 0).value)


# --------------------------------------------------------------------------------------------
# Spike trains: peaks, impact rate, impacts per cycle
# --------------------------------------------------------------------------------------------


def test_spike_train_integer_period() -> None:
    f, h = 32.0, 80.0  # 32 samples per cycle: every window holds the same spikes up to one
    a = spike_train(f, h, 4.0)
    feats = sensor_features(a, RATE, f_exc_hz=f)
    assert feats["peak_mean_g"] == Feature(h, floor(h, "g"), 20)
    assert feats["peak_std_g"] == Feature(0.0, SPREAD_FLOORS["g"], 20)
    assert feats["impact_hz"].value == pytest.approx(f)
    assert feats["impact_hz"].spread == pytest.approx(floor(f, "hz"))  # no 5 Hz quantisation
    assert feats["impacts_per_cycle"].value == pytest.approx(1.0)
    assert feats["impacts_per_cycle"].spread == pytest.approx(SPREAD_FLOORS["ratio"])
    assert feats["clipped_windows"] == Feature(0.0, SPREAD_FLOORS["ratio"], 20)


@pytest.mark.parametrize("f", [21.3, 47.1, 64.0])
def test_spike_train_matches_labels(f: float) -> None:
    a = spike_train(f, 50.0, 10.0)
    feats = sensor_features(a, RATE, f_exc_hz=f)
    duration = a.size / RATE
    assert feats["impact_hz"].value == impact_frequency(a, RATE)
    assert feats["impact_hz"].value == pytest.approx(f, abs=1.0 / duration)
    # Rounded spike times jitter the intervals by one sample only: the spread stays at the floor
    # instead of the ~2 Hz that whole-peak counts per 200 ms window would give.
    assert feats["impact_hz"].spread == pytest.approx(floor(f, "hz"))
    assert feats["impacts_per_cycle"].value == pytest.approx(1.0, abs=1.0 / (duration * f))
    mean, std = peak_stats(a, RATE)
    assert feats["peak_mean_g"].value == mean
    assert feats["peak_std_g"].value == std


def _beating_spikes(f: float, duration_s: float, low: float, high: float) -> np.ndarray:
    """One spike per cycle whose height climbs from ``low`` to ``high`` over 24 cycles and
    starts again (a spike's sampled height beating with the sampling), and a 10 g rebound
    half a cycle later."""
    n = round(duration_s * RATE)
    a = np.zeros(n)
    cycles = np.arange(math.ceil(duration_s * f))
    idx = np.round((cycles + 0.5) * RATE / f).astype(int)
    keep = idx < n
    a[idx[keep]] = (low + (high - low) * (cycles % 24) / 23.0)[keep]
    rebound = np.round((cycles + 1.0) * RATE / f).astype(int)
    a[rebound[rebound < n]] = 10.0
    return a


def test_an_impact_count_whose_threshold_sits_among_the_spikes_is_uncertain() -> None:
    """The threshold (half the median window peak, 23.7 g) sits just below the lowest
    spikes (24 g): every window counts one per cycle, so the windows' spread is at its floor,
    while a threshold 10 % higher drops the lowest spikes. The count's spread holds half its
    change over that +-10 % move (blind-05's record at 200 gal/min); where the heights leave
    a gap around the threshold, the spread is the windows' alone."""
    f = 21.3
    a = _beating_spikes(f, 8.0, 24.0, 60.0)
    feats = sensor_features(a, RATE, f_exc_hz=f)
    reference = float(np.median(window_peaks(a, RATE)))
    counts = [np.count_nonzero(a > s * IMPACT_HEIGHT_FRAC * reference) for s in (0.9, 1.1)]
    moved = 0.5 * (counts[0] - counts[1]) * RATE / a.size
    assert moved > 0.5  # the construction puts spikes on both sides of the moved threshold
    assert feats["impact_hz"].spread >= moved
    assert feats["impacts_per_cycle"].spread == pytest.approx(feats["impact_hz"].spread / f)
    gap = sensor_features(_beating_spikes(f, 8.0, 60.0, 80.0), RATE, f_exc_hz=f)
    assert gap["impacts_per_cycle"].value == pytest.approx(1.0, abs=0.02)
    assert gap["impact_hz"].spread == pytest.approx(floor(f, "hz"))


def test_two_spikes_per_cycle() -> None:
    f = 21.3
    a = spike_train(f, 100.0, 10.0, phases=(0.5, 0.9), heights=(1.0, 0.8))
    feats = sensor_features(a, RATE, f_exc_hz=f)
    assert feats["impacts_per_cycle"].value == pytest.approx(2.0, abs=2.0 / (10.0 * f))
    assert feats["impact_hz"].value == pytest.approx(2 * f, abs=0.2)
    # Unequal intervals (0.4 and 0.6 of a cycle) average out over a window of four cycles.
    assert feats["impact_hz"].spread < 0.05 * 2 * f
    assert feats["peak_mean_g"].value == pytest.approx(100.0)


def test_silent_signal() -> None:
    feats = sensor_features(np.zeros(2048), RATE)
    assert feats["impact_hz"] == Feature(0.0, SPREAD_FLOORS["hz"], 10)
    assert feats["peak_mean_g"] == Feature(0.0, SPREAD_FLOORS["g"], 10)
    for key in BAND_KEYS:
        assert feats[key] == Feature(0.0, SPREAD_FLOORS["g"], 10)


def test_signal_falling_silent_shows_in_the_rate_spread() -> None:
    a = spike_train(32.0, 80.0, 4.0)
    a[a.size // 2 :] = 0.0
    rate_feature = sensor_features(a, RATE)["impact_hz"]
    assert rate_feature.value == pytest.approx(16.0, abs=0.5)
    assert rate_feature.spread > 10.0


# --------------------------------------------------------------------------------------------
# Amplitude-modulated spikes: dispersion of the window peaks
# --------------------------------------------------------------------------------------------


def modulated_spikes(window_heights: np.ndarray, f: float = 32.0) -> np.ndarray:
    """Spikes at f Hz whose height is ``window_heights[i]`` in 200 ms window i."""
    n_windows = window_heights.size
    bounds = window_bounds(round(n_windows * 0.2 * RATE) + 1, RATE, 0.2)[: n_windows + 1]
    a = np.zeros(bounds[-1])
    idx = np.round((np.arange(0, a.size * f / RATE) + 0.5) * RATE / f).astype(int)
    idx = idx[idx < a.size]
    a[idx] = window_heights[np.searchsorted(bounds, idx, side="right") - 1]
    return a


def test_peak_std_of_alternating_windows() -> None:
    h, m = 100.0, 0.2
    heights = h * (1 + m * np.tile([1.0, -1.0], 10))
    feats = sensor_features(modulated_spikes(heights), RATE)
    assert feats["peak_mean_g"].value == pytest.approx(h)
    assert feats["peak_std_g"].value == pytest.approx(h * m)
    # Spread of the peaks: std (ddof=1) of +-20 over 20 windows.
    assert feats["peak_mean_g"].spread == pytest.approx(h * m * math.sqrt(20 / 19))
    # Every squared deviation is the same: no sampling spread of the dispersion, only the floor.
    assert feats["peak_std_g"].spread == pytest.approx(floor(h * m, "g"))


def test_peak_std_spread_of_random_window_peaks() -> None:
    rng = np.random.default_rng(1)
    sigma = 10.0
    heights = 100.0 + sigma * rng.standard_normal(400)
    feats = sensor_features(modulated_spikes(heights), RATE)
    assert feats["peak_mean_g"].value == pytest.approx(np.mean(heights))
    assert feats["peak_std_g"].value == pytest.approx(np.std(heights))
    assert feats["peak_mean_g"].spread == pytest.approx(np.std(heights, ddof=1))
    d = (heights - heights.mean()) ** 2
    expected = np.std(d, ddof=1) / (2 * np.std(heights))
    assert feats["peak_std_g"].spread == pytest.approx(expected)
    # For normal peaks that one-window sampling sd is sigma / sqrt(2); not a standard error.
    assert feats["peak_std_g"].spread == pytest.approx(sigma / math.sqrt(2), rel=0.15)


# --------------------------------------------------------------------------------------------
# Bands
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("freq", "band"),
    [(25.0, 0), (75.0, 1), (77.3, 1), (151.7, 2), (275.0, 3), (430.2, 4)],
)
def test_sine_band_rms(freq: float, band: int) -> None:
    amp = 12.0
    t = np.arange(round(4.0 * RATE)) / RATE
    a = amp * np.sin(2 * np.pi * freq * t + 0.3) + 3.0  # an offset must not count
    feats = sensor_features(a, RATE)
    for j, key in enumerate(BAND_KEYS):
        if j == band:
            assert feats[key].value == pytest.approx(amp / math.sqrt(2), rel=0.02)
            assert feats[key].spread == pytest.approx(floor(feats[key].value, "g"))
        else:
            assert feats[key].value < 0.005 * amp


def test_white_noise_spreads_and_parseval() -> None:
    rng = np.random.default_rng(2)
    sigma = 5.0
    a = sigma * rng.standard_normal(round(10.0 * RATE))
    feats = sensor_features(a, RATE)
    total = math.sqrt(sum(feats[k].value ** 2 for k in BAND_KEYS))
    assert total == pytest.approx(sigma, rel=0.05)
    peaks = window_peaks(a, RATE)
    assert feats["peak_mean_g"].spread == pytest.approx(np.std(peaks, ddof=1))
    for key, f in feats.items():
        assert f.n == 50
        assert f.spread > 0.0
        kind = "g" if key.endswith("_g") else "hz" if key.endswith("_hz") else "ratio"
        assert f.spread >= floor(f.value, kind)
    assert feats["impact_hz"].spread > SPREAD_FLOORS["hz"]  # noise peaks are irregular
    # the same rule as vadsim.signals.labels
    assert feats["impact_hz"].value == impact_frequency(a, RATE)


def test_tiny_noise_spreads_are_floored() -> None:
    rng = np.random.default_rng(3)
    a = 0.01 * rng.standard_normal(round(4.0 * RATE))
    feats = sensor_features(a, RATE)
    for key in ["peak_mean_g", "peak_std_g", *BAND_KEYS]:
        assert feats[key].spread == SPREAD_FLOORS["g"]


def test_band_edges_for() -> None:
    assert band_edges_for(1024) == DEFAULT_BANDS
    assert band_edges_for(500) == ((0, 50), (50, 100), (100, 200), (200, 250))
    assert band_edges_for(2048)[-1] == (512.0, 1024.0)
    assert band_edges_for(200, [(10, 40), (90, 120), (100, 200)]) == ((10, 40), (90, 100))
    assert band_key(350, 511.5) == "band_350_511p5_g"
    feats = sensor_features(np.zeros(1000), 500.0)
    assert [k for k in feats if k.startswith("band_")][-1] == "band_200_250_g"


# --------------------------------------------------------------------------------------------
# Clipping
# --------------------------------------------------------------------------------------------


def test_clipped_windows_are_excluded_and_counted() -> None:
    heights = np.full(20, 100.0)
    heights[[3, 7, 8]] = 400.0
    a = np.clip(modulated_spikes(heights), -250.0, 250.0)
    clipped = np.abs(a) >= 250.0
    feats = sensor_features(a, RATE, clipped=clipped)
    assert feats["peak_mean_g"] == Feature(100.0, floor(100.0, "g"), 17)
    assert feats["peak_std_g"].value == 0.0
    assert feats["clipped_windows"].value == pytest.approx(3 / 20)
    assert feats["clipped_windows"].n == 20
    assert feats["clipped_windows"].spread == pytest.approx(np.std([1] * 3 + [0] * 17, ddof=1))
    # Without the mask the clipped peaks (250 g, a lower bound) would pull the mean up.
    assert sensor_features(a, RATE)["peak_mean_g"].value > 100.0
    # Impact rate and bands use every window.
    assert feats["impact_hz"].n == 20


def test_all_windows_clipped_gives_nan_with_a_warning() -> None:
    a = spike_train(32.0, 300.0, 2.0).clip(-250.0, 250.0)
    with pytest.warns(RuntimeWarning, match="all 10 windows"):
        feats = sensor_features(a, RATE, clipped=np.abs(a) >= 250.0)
    for key in ["peak_mean_g", "peak_std_g"]:
        assert math.isnan(feats[key].value) and math.isnan(feats[key].spread)
        assert feats[key].n == 0
    assert feats["clipped_windows"].value == 1.0
    assert feats["impact_hz"].value == pytest.approx(32.0)


def test_one_unclipped_window_has_nan_spread() -> None:
    heights = np.full(5, 400.0)
    heights[2] = 100.0
    a = np.clip(modulated_spikes(heights), -250.0, 250.0)
    with pytest.warns(RuntimeWarning, match="only 1 of 5"):
        feats = sensor_features(a, RATE, clipped=np.abs(a) >= 250.0)
    assert feats["peak_mean_g"].value == 100.0
    assert math.isnan(feats["peak_mean_g"].spread)


# --------------------------------------------------------------------------------------------
# Events and the x5/x1 ratio
# --------------------------------------------------------------------------------------------


def test_event_features_prefixes_and_ratio() -> None:
    rng = np.random.default_rng(4)
    x1 = spike_train(32.0, 80.0, 4.0) + rng.normal(0.0, 1.0, round(4.0 * RATE))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        feats = event_features({"x1": x1, "x5": 0.6 * x1}, RATE, f_exc_hz=32.0)
    ratio = feats["x5_x1_peak_ratio"]
    assert ratio.value == pytest.approx(0.6)
    assert (ratio.spread, ratio.n) == (pytest.approx(SPREAD_FLOORS["ratio"]), 20)
    assert feats["x5_peak_mean_g"].value == pytest.approx(0.6 * feats["x1_peak_mean_g"].value)
    assert feats["x1_impacts_per_cycle"].value == pytest.approx(1.0)
    assert feats["x5_band_50_100_g"].value == pytest.approx(0.6 * feats["x1_band_50_100_g"].value)
    assert set(feats) == {f"x1_{k}" for k in sensor_features(x1, RATE, 32.0)} | {
        f"x5_{k}" for k in sensor_features(x1, RATE, 32.0)
    } | {"x5_x1_peak_ratio"}
    assert "x5_x1_peak_ratio" not in event_features({"x1": x1}, RATE)


def test_ratio_uses_windows_unclipped_in_both_sensors() -> None:
    heights = np.full(20, 100.0)
    heights[5] = 400.0
    x1 = np.clip(modulated_spikes(heights), -250.0, 250.0)
    x5 = 0.5 * modulated_spikes(heights)  # x5 does not clip, but window 5 is out of the ratio
    feats = event_features({"x1": x1, "x5": x5}, RATE, clipped={"x1": np.abs(x1) >= 250.0})
    assert feats["x5_x1_peak_ratio"].value == pytest.approx(0.5)
    assert feats["x5_x1_peak_ratio"].n == 19
    assert feats["x1_clipped_windows"].value == pytest.approx(1 / 20)
    assert feats["x5_clipped_windows"].value == 0.0


@pytest.mark.parametrize("sizes", [(4096,) * 4, (4097, 4096, 4096, 4096), (4096, 4300, 4305, 3000)])
def test_phase_features_equal_each_record_alone(sizes: tuple[int, ...]) -> None:
    # The measurement's batched path must give each sampling phase exactly what event_features
    # gives it: windows, spectra and impact peaks reduced row by row, ragged ends included
    # (3000 samples hold fewer windows than the rest: a group of its own).
    rng = np.random.default_rng(11)
    records, masks = [], []
    for k, n in enumerate(sizes):
        x1 = np.resize(spike_train(32.0, 80.0 + 5.0 * k, 5.0), n) + rng.normal(0.0, 1.0, n)
        x5 = 0.4 * np.roll(x1, 3) + rng.normal(0.0, 0.5, n)
        records.append({"x1": x1, "x5": x5})
        masks.append({"x1": rng.random(n) < 0.002, "x5": np.zeros(n, dtype=bool)})
    alone = [event_features(r, RATE, 32.0, clipped=m) for r, m in zip(records, masks, strict=True)]
    together = phase_features({s: [r[s] for r in records] for s in ("x1", "x5")}, RATE, 32.0,
                              {s: [m[s] for m in masks] for s in ("x1", "x5")})
    assert len(together) == len(alone)
    assert all(0.0 < f["x1_clipped_windows"].value < 1.0 for f in alone)  # some windows out
    for one, batch in zip(alone, together, strict=True):
        assert list(one) == list(batch)
        for key in one:
            a, b = one[key], batch[key]
            assert np.array_equal([a.value, a.spread, a.n], [b.value, b.spread, b.n],
                                  equal_nan=True), key


def test_phase_features_refuses_mismatched_records() -> None:
    x = np.zeros(4096)
    with pytest.raises(ValueError, match="same number of records"):
        phase_features({"x1": [x, x], "x5": [x]}, RATE)
    with pytest.raises(ValueError, match=r"signals\['x5'\]\[1\] has 4000 samples"):
        phase_features({"x1": [x, x], "x5": [x, x[:4000]]}, RATE)
    with pytest.raises(ValueError, match=r"signals\['x1'\]\[0\]"):
        phase_features({"x1": [np.full(4096, np.nan)]}, RATE)


# --------------------------------------------------------------------------------------------
# Tables and residuals
# --------------------------------------------------------------------------------------------


def test_features_table_layout() -> None:
    table = features_table(
        {"e01": {"a_g": Feature(1.0, 0.5, 3)}, "e02": {"b_hz": Feature(2.0, 0.6, 4)}}
    )
    assert list(table.index) == ["e01", "e02"]
    assert table.index.name == "event"
    assert list(table.columns) == [
        ("a_g", "value"),
        ("a_g", "spread"),
        ("b_hz", "value"),
        ("b_hz", "spread"),
    ]
    assert table.loc["e01", ("a_g", "spread")] == 0.5
    assert math.isnan(table.loc["e01", ("b_hz", "value")])
    assert isinstance(features_table({}), pd.DataFrame)


def test_residual_table() -> None:
    a = spike_train(32.0, 80.0, 4.0)
    rec = {"e01": event_features({"x1": a, "x5": 0.5 * a}, RATE)}
    same = residual_table(rec, rec)
    assert same.shape == (1, len(rec["e01"]))
    assert np.all(same.to_numpy() == 0.0)

    shift = {"x1_peak_mean_g": 3.0, "x1_impact_hz": -1.5, "x5_x1_peak_ratio": 0.1}
    sim = {
        "e01": {k: Feature(f.value + shift.get(k, 0.0), 99.0, 1) for k, f in rec["e01"].items()},
        "e02": {"x1_peak_mean_g": Feature(1.0, 1.0, 1)},
    }
    res = residual_table(sim, rec, keys=list(shift))
    for k, d in shift.items():
        # The recording's spread standardises, not the simulation's.
        assert res.loc["e01", k] == pytest.approx(d / rec["e01"][k].spread)
    assert list(res.index) == ["e01", "e02"]
    assert res.loc["e02"].isna().all()

    summary = {"e01": summary_features({"x1_peak_mean_g": 70.0, "x1_impact_hz": 30.0})}
    res = residual_table(rec, summary)
    assert list(res.columns) == ["x1_peak_mean_g", "x1_impact_hz"]
    assert res.loc["e01", "x1_peak_mean_g"] == pytest.approx((80.0 - 70.0) / 7.0)
    assert res.loc["e01", "x1_impact_hz"] == pytest.approx((32.0 - 30.0) / 3.0)


def test_residual_is_nan_where_recorded_spread_cannot_standardise() -> None:
    sim = {"e": {"a_g": Feature(1.0, 1.0, 1), "b_g": Feature(1.0, 1.0, 1)}}
    rec = {"e": {"a_g": Feature(0.0, 0.0, 1), "b_g": Feature(math.nan, math.nan, 0)}}
    assert residual_table(sim, rec).isna().all().all()


def test_summary_features_default_spreads() -> None:
    feats = summary_features(
        {
            "x1_peak_mean_g": 68.0,
            "x1_peak_std_g": 3.0,
            "x1_impact_hz": 24.0,
            "x1_impacts_per_cycle": 0.1,
        }
    )
    assert feats["x1_peak_mean_g"].value == 68.0
    assert feats["x1_peak_mean_g"].spread == pytest.approx(6.8)
    assert feats["x1_peak_mean_g"].n == 0
    assert feats["x1_peak_std_g"] == Feature(3.0, 0.5, 0)  # 10 % is below the 0.5 g floor
    assert feats["x1_impact_hz"].spread == pytest.approx(2.4)
    assert feats["x1_impacts_per_cycle"].spread == 0.02
    assert summary_features({"x1_impact_hz": 24.0}, rel_spread=0.5)["x1_impact_hz"].spread == 12.0
    assert summary_features({"x_g": 1.0}, floors={"g": 2.0})["x_g"].spread == 2.0


# --------------------------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------------------------

_GOOD = np.zeros(2048)


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: sensor_features(np.zeros((2, 1024)), RATE), "a_g"),
        (lambda: sensor_features(np.r_[_GOOD, np.nan], RATE), "a_g"),
        (lambda: sensor_features(np.zeros(300), RATE), "a_g"),
        (lambda: sensor_features(_GOOD, 0.0), "rate_hz"),
        (lambda: sensor_features(_GOOD, "fast"), "rate_hz"),
        (lambda: sensor_features(_GOOD, RATE, f_exc_hz=-1.0), "f_exc_hz"),
        (lambda: sensor_features(_GOOD, RATE, window_s=math.inf), "window_s"),
        (lambda: sensor_features(_GOOD, RATE, window_s=0.002), "window_s"),
        (lambda: sensor_features(_GOOD, RATE, bands=[(50, 10)]), "bands"),
        (lambda: sensor_features(_GOOD, RATE, bands=[(1, 2)]), "bands"),
        (lambda: sensor_features(_GOOD, RATE, bands=[(600, 700)]), "bands"),
        (lambda: sensor_features(_GOOD, RATE, bands=5), "bands"),
        (lambda: sensor_features(_GOOD, RATE, clipped=np.zeros(10, bool)), "clipped"),
        (lambda: sensor_features(_GOOD, RATE, clipped=np.full(2048, 0.5)), "clipped"),
        (lambda: event_features({}, RATE), "signals"),
        (lambda: event_features({"x1": _GOOD, "x5": _GOOD[:-1]}, RATE), "signals"),
        (lambda: event_features({"x1": np.r_[_GOOD, np.inf]}, RATE), r"signals\['x1'\]"),
        (lambda: event_features({"x1": _GOOD}, RATE, clipped={"x5": _GOOD > 0}), "clipped"),
        (
            lambda: event_features({"x1": _GOOD}, RATE, clipped={"x1": _GOOD[:5] > 0}),
            r"clipped\['x1'\]",
        ),
        (lambda: summary_features([1.0]), "values"),
        (lambda: summary_features({"x1_peak_mean_g": math.nan}), "values"),
        (lambda: summary_features({"x1_peak_mean_g": 1.0}, rel_spread=0.0), "rel_spread"),
        (lambda: summary_features({"x1_peak_mean_g": 1.0}, floors={"m": 1.0}), "floors"),
        (lambda: summary_features({"x1_peak_mean_g": 1.0}, floors={"g": -1.0}), "floors"),
        (lambda: features_table({"e": {"a": 1.0}}), "features"),
        (lambda: residual_table({}, [], None), "rec"),
        (lambda: residual_table({}, {}, keys=["nope"]), "keys"),
        (lambda: residual_table({}, {}, keys="abc"), "keys"),
    ],
)
def test_bad_input_names_the_argument(call, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        call()
