"""Tests of vadsim.simulate (python/vadsim/simulate.py) against the installed package.

Covers the shape of a SimulationResult, physics sanity checks against the equations and static
state of MODEL.md, the summary (J*, 200 ms peaks) against the recorded time series, every kind
of bad input (ValueError naming it), solver budgets (SolverError), Ctrl-C during a run,
continuation, presets, parameter overrides, contact laws and extra forces.

Runs are short (20 cycles, 10 analysed) unless a test needs more.
"""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
import vadsim
from _children import SIGINT_PRELUDE
from vadsim import SURFACES, G

SHORT = dict(cycles=20, analyse_cycles=10)
TINY = dict(cycles=4, analyse_cycles=2, record="none", summary_rate_hz=2000)
STATS_KEYS = {"steps", "rhs_evals", "jac_evals", "lin_setups", "err_test_fails", "nonlin_iters",
              "nonlin_conv_fails", "root_evals", "reinits"}
EVENT_COLUMNS = ["time_s", "surface", "kind", "rel_velocity_mps"]
EVENT_KINDS = ["onset", "release", "lift", "relatch"]


@pytest.fixture(scope="module")
def r200(tiny_run):
    """The shared 20-cycle run at 200 gal/min (``SHORT``)."""
    return tiny_run


@pytest.fixture(scope="module")
def r200_all():
    """The whole run recorded from t = 0 at 10 kHz."""
    return vadsim.simulate("7in-cde", 200, **SHORT, record="all", output_rate_hz=10000)


def static_state(p: dict) -> np.ndarray:
    """MODEL.md "The run", step 1: static on-bottom positions (m)."""
    l0, w = p["l0"], p["wob"]
    x1 = (p["LR"] - p["L1"]) * l0 + w / p["kR"]
    x2 = x1
    x3 = x1 + (p["LI"] + p["LOn"] - p["L3"]) * l0 + w / p["kOn"]
    x4 = x3 + w / p["k3"]
    x5 = x4 + w / p["k4"]
    x6 = x5 + w / p["k5"]
    x7 = x6 + w / p["k6"]
    return np.array([x1, x2, x3, x4, x5, x6, x7])


def indentations(p: dict, x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MODEL.md contact table: indentation d and rate d' per surface, shape (n, 5)."""
    l0 = p["l0"]
    x1, x2, x3 = x[:, 0], x[:, 1], x[:, 2]
    v1, v2, v3 = v[:, 0], v[:, 1], v[:, 2]
    d = np.stack([
        (x3 + p["LS"] * l0) - (x2 - p["L2"] * l0),
        x2 - x1,
        (x1 + p["LI"] * l0) - (x3 + p["L3"] * l0),
        (x3 + p["L3"] * l0) - (x1 + (p["LI"] + p["LOn"]) * l0),
        (x1 + p["L1"] * l0) - p["LR"] * l0,
    ], axis=1)
    dd = np.stack([v3 - v2, v2 - v1, v1 - v3, v3 - v1, v1], axis=1)
    return d, dd


# --------------------------------------------------------------------------------------------
# API shape
# --------------------------------------------------------------------------------------------

def test_array_shapes(r200):
    n = r200.t.shape[0]
    assert n > 1000
    assert r200.t.shape == (n,)
    assert r200.x.shape == (n, 7)
    assert r200.v.shape == (n, 7)
    assert r200.a.shape == (n, 7)
    assert r200.accel_g.shape == (n, 7)
    assert r200.contact_forces.shape == (n, 5)
    assert r200.excitation_force.shape == (n,)
    assert r200.y_end.shape == (14,)
    for arr in (r200.t, r200.x, r200.v, r200.a, r200.contact_forces, r200.excitation_force,
                r200.y_end, r200.poincare):
        assert np.all(np.isfinite(arr))
    np.testing.assert_allclose(r200.accel_g, r200.a / G)


def test_time_grid_is_uniform_and_covers_the_window(r200):
    rate = 20000.0
    t0, t1 = r200.window
    period = 1.0 / r200.f_exc_hz
    assert r200.f_exc_hz == pytest.approx(r200.params["alpha"] * 200 / (2 * math.pi))
    assert r200.f_exc_hz == pytest.approx(21.3, abs=0.05)  # MODEL.md: 200 gal/min -> 21.3 Hz
    assert r200.period_s == pytest.approx(period)
    assert t1 == pytest.approx(20 * period, rel=1e-12)
    assert t0 == pytest.approx(10 * period, rel=1e-12)
    np.testing.assert_allclose(np.diff(r200.t), 1.0 / rate, rtol=1e-6)
    assert r200.t[0] == pytest.approx(t0, abs=1e-12)
    assert t1 - 1.0 / rate <= r200.t[-1] <= t1 + 1e-12
    assert r200.window_slice() == slice(0, len(r200.t))


def test_output_rate_and_record_modes():
    r = vadsim.simulate("7in-cde", 200, **SHORT, output_rate_hz=4000)
    np.testing.assert_allclose(np.diff(r.t), 1 / 4000, rtol=1e-6)
    assert r.t[0] == pytest.approx(r.window[0], abs=1e-12)
    ra = vadsim.simulate("7in-cde", 200, **SHORT, record="all", output_rate_hz=4000)
    assert ra.t[0] == 0.0
    assert ra.t[-1] == pytest.approx(ra.window[1], abs=1 / 4000)
    np.testing.assert_allclose(np.diff(ra.t), 1 / 4000, rtol=1e-6)
    sl = ra.window_slice()
    assert ra.t[sl][0] >= ra.window[0] - 1e-12
    assert ra.t[sl.start - 1] < ra.window[0]
    rn = vadsim.simulate("7in-cde", 200, **SHORT, record="none")
    assert rn.t.shape == (0,)
    assert rn.x.shape == (0, 7)
    assert rn.contact_forces.shape == (0, 5)
    # The summary does not depend on what is recorded.
    assert rn.impulse_pos == r.impulse_pos == ra.impulse_pos
    np.testing.assert_array_equal(rn.window_peaks_g, ra.window_peaks_g)
    assert rn.impacts == ra.impacts


def test_events_table(r200):
    ev = r200.events
    assert isinstance(ev, pd.DataFrame)
    assert list(ev.columns) == EVENT_COLUMNS
    assert list(ev["surface"].cat.categories) == list(SURFACES)
    assert list(ev["kind"].cat.categories) == EVENT_KINDS
    assert len(ev) > 0
    t = ev["time_s"].to_numpy()
    assert np.all(np.diff(t) >= 0)
    assert t[0] >= 0 and t[-1] <= r200.window[1]
    # Kelvin-Voigt law: only onsets and releases, alternating per surface.
    assert set(ev["kind"].astype(str)) <= {"onset", "release"}
    for s in SURFACES:
        kinds = ev.loc[ev["surface"] == s, "kind"].astype(str).tolist()
        assert all(a != b for a, b in zip(kinds[:-1], kinds[1:], strict=True)), s
    # Onsets approach (d' > 0), releases separate (d' < 0).
    onset = ev["kind"] == "onset"
    assert np.all(ev.loc[onset, "rel_velocity_mps"] > 0)
    assert np.all(ev.loc[~onset, "rel_velocity_mps"] < 0)
    # impacts = onsets inside the steady window, per surface.
    in_window = ev[onset & (ev["time_s"] >= r200.window[0])]
    for s in SURFACES:
        assert r200.impacts[s] == int((in_window["surface"] == s).sum()), s


def test_poincare_section(r200):
    assert r200.poincare.shape == (21, 14)  # cycles + 1 rows of [x; v]
    assert r200.poincare_t.shape == (21,)
    np.testing.assert_allclose(r200.poincare_t, np.arange(21) / r200.f_exc_hz, rtol=1e-12)
    np.testing.assert_allclose(r200.poincare[0, :7], static_state(r200.params), rtol=1e-13)
    np.testing.assert_array_equal(r200.poincare[0, 7:], 0.0)
    np.testing.assert_allclose(r200.poincare[-1], r200.y_end, rtol=1e-9, atol=1e-9)


def test_stats_z_scenario_peaks(r200):
    assert set(r200.stats) == STATS_KEYS
    assert all(isinstance(v, int) for v in r200.stats.values())
    assert r200.stats["steps"] > 0 and r200.stats["rhs_evals"] >= r200.stats["steps"]
    # CVODE is re-initialised at every root return (one or more events each).
    assert 0 < r200.stats["reinits"] <= len(r200.events)
    assert set(r200.z) == set(SURFACES)
    for s in SURFACES:
        assert r200.z[s] == r200.impacts[s] / 10
    assert r200.z["spring"] == 1.0 and r200.z["impact"] == 1.0
    assert r200.scenario == 1
    # 10 cycles at 21.3 Hz = 0.469 s: two full 200 ms windows.
    assert r200.window_peaks_g.shape == (2, 7)
    mean, std = r200.peak_stats(1)
    assert isinstance(mean, float) and isinstance(std, float)
    assert mean == pytest.approx(r200.window_peaks_g[:, 0].mean())
    assert std == pytest.approx(r200.window_peaks_g[:, 0].std())
    assert 40 < mean < 90  # MODEL.md reference: 65.1 g at 200 gal/min
    assert r200.peak_stats(5)[0] == pytest.approx(r200.window_peaks_g[:, 4].mean())
    for bad in (0, 8):
        with pytest.raises(ValueError, match="dof"):
            r200.peak_stats(bad)
    assert r200.impulse_pos >= r200.impulse_mean
    assert r200.preset == "7in-cde"
    assert r200.flow_gpm == 200.0
    assert r200.cycles == 20 and r200.analyse_cycles == 10
    assert r200.m_ref_kg == pytest.approx(4 * vadsim.model.presets.KLBF_N / 1000)


def test_no_full_window_gives_nan_peaks():
    r = vadsim.simulate("7in-cde", 600, cycles=8, analyse_cycles=4, record="none")
    assert r.window_peaks_g.shape == (0, 7)  # 4 cycles at 64 Hz < 200 ms
    assert all(math.isnan(x) for x in r.peak_stats(1))


# --------------------------------------------------------------------------------------------
# Physics sanity
# --------------------------------------------------------------------------------------------

def test_first_sample_is_the_static_state(r200_all):
    r = r200_all
    p = r.params
    assert r.t[0] == 0.0
    xs = static_state(p)
    np.testing.assert_allclose(r.x[0], xs, rtol=1e-14, atol=1e-14)
    x1 = (p["LR"] - p["L1"]) * p["l0"] + p["wob"] / p["kR"]
    assert r.x[0, 0] == pytest.approx(x1, rel=1e-15)
    assert r.x[0, 1] == r.x[0, 0]  # anvil resting on the bit
    np.testing.assert_array_equal(r.v[0], 0.0)
    # Anvil on the bit with zero force, spring gap open, bit on the on-bottom shoulder and on
    # the rock, each carrying the weight on bit.
    np.testing.assert_allclose(r.contact_forces[0], [0, 0, 0, p["wob"], p["wob"]],
                               rtol=1e-9, atol=1e-9)
    # The bit is in equilibrium; the string too (only the anvil feels the excitation).
    np.testing.assert_allclose(r.a[0, [0, 2, 3, 4, 5, 6]], 0.0, atol=1e-6)
    d, _ = indentations(p, r.x[:1], r.v[:1])
    # Spring gap: Eq. 5.1's L_gap, less the on-bottom shoulder's compression under the WOB.
    gap = vadsim.make_params("7in-cde").gap() * p["l0"] - p["wob"] / p["kOn"]
    assert d[0, 0] == pytest.approx(-gap, rel=1e-9)


def test_contact_forces_follow_the_contact_law(r200_all):
    r = r200_all
    p = r.params
    d, dd = indentations(p, r.x, r.v)
    F = r.contact_forces
    eps = 1e-9  # m: root location tolerance around d = 0
    open_ = d < -eps
    assert open_[:, 0].any() and open_[:, 1].any()  # spring and impact face open at times
    assert np.all(F[open_] == 0.0), "a force on an open surface"
    k = np.array([p[n] for n in ("kS", "kI", "kOff", "kOn", "kR")])
    c = np.array([p[n] for n in ("cS", "cI", "cOff", "cOn", "cR")])
    closed = d > eps
    assert closed[:, 1].any() and closed[:, 4].all()
    kv = k * d + c * dd  # Kelvin-Voigt with tension kept (the default law)
    scale = np.abs(kv).max(axis=0) + 1e-30
    err = np.where(closed, np.abs(F - kv), 0.0) / scale
    assert err.max() < 1e-9


def test_equations_of_motion_for_bit_and_anvil(r200_all):
    r = r200_all
    p = r.params
    F = r.contact_forces
    FS, FI, FOff, FOn, FR = F.T
    x2, x3, v2 = r.x[:, 1], r.x[:, 2], r.v[:, 1]
    fh = p["Fo"] * np.cos(p["alpha"] * 200 * r.t + p["phi"]) * np.sin(
        p["beta"] * (x2 - x3) + p["psi"])
    np.testing.assert_allclose(r.excitation_force, fh, atol=1e-9 * p["Fo"])
    a2 = (-FI + FS + r.excitation_force - p["cD"] * v2 * np.abs(v2)) / p["m2"]
    a1 = (-FR + FOn - FOff + FI) / p["m1"]
    np.testing.assert_allclose(r.a[:, 1], a2, atol=1e-9 * np.abs(a2).max())
    np.testing.assert_allclose(r.a[:, 0], a1, atol=1e-9 * np.abs(a1).max())


@pytest.mark.parametrize("flow", [200, 350])
def test_summary_impulse_matches_recorded_force(flow):
    rate = 20000
    r = vadsim.simulate("7in-cde", flow, **SHORT, record="window", output_rate_hz=rate,
                        summary_rate_hz=rate)
    fi = r.contact_forces[r.window_slice(), 1]
    assert r.impulse_mean == pytest.approx(fi.mean(), rel=0.01)
    assert r.impulse_pos == pytest.approx(np.maximum(fi, 0).mean(), rel=0.01)
    assert r.impulse_pos > 0


def test_a_run_without_summary_records_the_same_series():
    """summary_rate_hz=0 (what a diagnosis' runs use: they are measured from their stored
    series) computes no J* and no 200 ms peaks, and changes nothing else: the summary only
    samples the run."""
    kw = dict(cycles=40, analyse_cycles=20, record="window", output_rate_hz=20480)
    with_summary = vadsim.simulate("7in-cde", 350, **kw)
    without = vadsim.simulate("7in-cde", 350, **kw, summary_rate_hz=0)
    assert math.isnan(without.impulse_pos) and math.isnan(without.impulse_mean)
    assert without.window_peaks_g.shape == (0, 7)
    assert with_summary.impulse_pos > 0 and with_summary.window_peaks_g.shape[0] >= 2
    np.testing.assert_array_equal(without.a, with_summary.a)
    np.testing.assert_array_equal(without.x, with_summary.x)
    assert without.z == with_summary.z
    assert without.stats["steps"] == with_summary.stats["steps"]


@pytest.mark.parametrize("steady,rtol", [("full", 1e-12), ("auto", 1e-3)])
@pytest.mark.parametrize("flow,rate", [(200, 20000), (350, 10000), (250, 5000)])
def test_window_peaks_match_recorded_acceleration(flow, rate, steady, rtol):
    # A literal run samples both grids from the same interpolants: the same numbers. A run at
    # its orbit reads the summary from a table of one period (8x the rate, corners exact) and
    # the stored series from the orbit's replay: within the table's interpolation.
    r = vadsim.simulate("7in-cde", flow, cycles=40, analyse_cycles=20, record="window",
                        output_rate_hz=rate, summary_rate_hz=rate, steady=steady)
    a = np.abs(r.a[r.window_slice()]) / G
    per = round(0.2 * rate)  # samples per 200 ms window
    n_windows = int((r.window[1] - r.window[0]) / 0.2 + 1e-9)
    assert r.window_peaks_g.shape == (n_windows, 7) and n_windows >= 2
    expected = np.array([a[i * per:(i + 1) * per].max(axis=0) for i in range(n_windows)])
    np.testing.assert_allclose(r.window_peaks_g, expected, rtol=rtol)


# --------------------------------------------------------------------------------------------
# Bad input: ValueError naming the bad thing
# --------------------------------------------------------------------------------------------

def _sim(*args, **kw):
    opts = dict(TINY)
    opts.update(kw)
    return lambda: vadsim.simulate(*args, **opts)


def _ef(*args, **kw):
    return lambda: vadsim.extra_force(*args, **kw)


NAN, INF = float("nan"), float("inf")

BAD_INPUTS = [
    # presets and parameters
    ("unknown preset", _sim("8in-xyz", 200), r"8in-xyz"),
    ("unknown tool/bit", lambda: vadsim.get_preset("7in", "PDC"), r"PDC"),
    ("unknown parameter", _sim("7in-cde", 200, overrides={"kX": 1.0}), r"\bkX\b"),
    ("parameter case", _sim("7in-cde", 200, overrides={"ks": 1.0}), r"\bks\b"),
    ("unknown parameter in mapping", _sim({"foo": 1.0}, 200), r"\bfoo\b"),
    ("negative mass", _sim("7in-cde", 200, overrides={"m2": -1.0}), r"\bm2\b"),
    ("zero mass", _sim("7in-cde", 200, overrides={"m1": 0.0}), r"\bm1\b"),
    ("NaN stiffness", _sim("7in-cde", 200, overrides={"kI": NAN}), r"\bkI\b"),
    ("inf stiffness", _sim("7in-cde", 200, overrides={"kS": INF}), r"\bkS\b"),
    ("negative damping", _sim("7in-cde", 200, overrides={"cR": -1.0}), r"\bcR\b"),
    ("string parameter", _sim("7in-cde", 200, overrides={"kI": "stiff"}), r"\bkI\b"),
    ("None parameter", _sim("7in-cde", 200, overrides={"k5": None}), r"\bk5\b"),
    ("exponent out of range", _sim("7in-cde", 200, overrides={"hc_n": 5.0}), r"\bhc_n\b"),
    ("zero rock stiffness", _sim("7in-cde", 200, overrides={"kR": 0.0}), r"\bkR\b"),
    ("model of wrong type", _sim(42, 200), r"\bmodel\b"),
    ("bool parameter", _sim("7in-cde", 200, overrides={"kS": True}), r"\bkS\b"),
    # outside the physical ranges: numbers that break the arithmetic, not just the physics
    ("subnormal mass", _sim("7in-cde", 200, overrides={"m3": 5e-324}),
     r"parameter m3 = .* must be in \[1e-06, 1e\+06\] m\*"),
    ("subnormal stiffness", _sim("7in-cde", 200, overrides={"kI": 5e-324}),
     r"parameter kI = .* must be 0 or in \[.*\] N/m/kg"),
    ("subnormal damping", _sim("7in-cde", 200, overrides={"cS": 5e-324}), r"\bcS\b.*N s/m/kg"),
    ("huge mass", _sim("7in-cde", 200, overrides={"m1": 1e300}), r"\bm1\b"),
    ("length near 1e308", _sim("7in-cde", 200, overrides={"L1": 1e308}), r"\bL1\b.*l0"),
    ("length beyond 1 km", _sim("7in-cde", 200, overrides={"L3": 2000.0}),
     r"\bL3\b.* must be <= 1000 m"),
    ("huge l0", _sim("7in-cde", 200, overrides={"l0": 1e4}), r"\bl0\b.*\bm\b"),
    ("huge static deflection", _sim("7in-cde", 200, overrides={"kR": 1e-3}),
     r"\bkR\b.*static deflection"),
    ("subnormal drag", _sim("7in-cde", 200, overrides={"cD": 5e-324}), r"\bcD\b"),
    ("huge force", _sim("7in-cde", 200, overrides={"Fo": 1e300}), r"\bFo\b.*N/kg"),
    # flow
    ("zero flow", _sim("7in-cde", 0.0), r"flow_gpm"),
    ("negative flow", _sim("7in-cde", -200.0), r"flow_gpm"),
    ("NaN flow", _sim("7in-cde", NAN), r"flow_gpm"),
    ("inf flow", _sim("7in-cde", INF), r"flow_gpm"),
    ("string flow", _sim("7in-cde", "fast"), r"flow_gpm"),
    ("None flow", _sim("7in-cde", None), r"flow_gpm"),
    ("bool flow", _sim("7in-cde", True), r"flow_gpm"),
    ("tiny flow", _sim("7in-cde", 1e-3),
     r"^flow_gpm = 0\.001 must be in \[0\.9378, 1\.876e\+04\] gal/min.*0\.1, 2000\] Hz"),
    ("huge flow", _sim("7in-cde", 1e300), r"^flow_gpm = 1e\+300 must be in .* gal/min"),
    ("flow too slow for alpha", _sim("7in-cde", 200, overrides={"alpha": 1e-5}),
     r"^flow_gpm = 200"),
    # run options
    ("zero cycles", _sim("7in-cde", 200, cycles=0, analyse_cycles=0), r"\bcycles\b"),
    ("negative cycles", _sim("7in-cde", 200, cycles=-4, analyse_cycles=2), r"\bcycles\b"),
    ("NaN cycles", _sim("7in-cde", 200, cycles=NAN), r"\bcycles\b"),
    ("too many cycles", _sim("7in-cde", 200, cycles=2e6), r"\bcycles\b"),
    ("string cycles", _sim("7in-cde", 200, cycles="many"), r"\bcycles\b"),
    ("bool cycles", _sim("7in-cde", 200, cycles=True), r"\bcycles\b"),
    ("bool analyse_cycles", _sim("7in-cde", 200, analyse_cycles=True), r"\banalyse_cycles\b"),
    ("bool rtol", _sim("7in-cde", 200, rtol=True), r"\brtol\b"),
    ("analyse > cycles", _sim("7in-cde", 200, cycles=4, analyse_cycles=5), r"analyse_cycles"),
    ("zero analyse", _sim("7in-cde", 200, analyse_cycles=0), r"analyse_cycles"),
    ("rtol zero", _sim("7in-cde", 200, rtol=0.0), r"\brtol\b"),
    ("rtol one", _sim("7in-cde", 200, rtol=1.0), r"\brtol\b"),
    ("rtol NaN", _sim("7in-cde", 200, rtol=NAN), r"\brtol\b"),
    ("atol zero", _sim("7in-cde", 200, atol=0.0), r"\batol\b"),
    ("atol subnormal", _sim("7in-cde", 200, atol=5e-324), r"\batol\b.*\[1e-20, 1\] m"),
    ("atol huge", _sim("7in-cde", 200, atol=10.0), r"\batol\b"),
    ("rtol too tight", _sim("7in-cde", 200, rtol=1e-16), r"\brtol\b"),
    ("max_step subnormal", _sim("7in-cde", 200, max_step=5e-324), r"\bmax_step\b"),
    ("output rate subnormal", _sim("7in-cde", 200, record="all", output_rate_hz=5e-324),
     r"output_rate_hz"),
    ("summary rate subnormal", _sim("7in-cde", 200, summary_rate_hz=5e-324), r"summary_rate_hz"),
    ("negative max_step", _sim("7in-cde", 200, max_step=-1.0), r"\bmax_step\b"),
    ("bad method", _sim("7in-cde", 200, method="rk4"), r"\bmethod\b"),
    ("bad record", _sim("7in-cde", 200, record="some"), r"\brecord\b"),
    ("negative output rate", _sim("7in-cde", 200, output_rate_hz=-1.0), r"output_rate_hz"),
    ("negative summary rate", _sim("7in-cde", 200, summary_rate_hz=-1.0), r"summary_rate_hz"),
    ("zero max_steps", _sim("7in-cde", 200, max_steps=0), r"\bmax_steps\b"),
    ("float max_steps", _sim("7in-cde", 200, max_steps=1.5), r"\bmax_steps\b"),
    ("huge max_steps", _sim("7in-cde", 200, max_steps=2**70), r"\bmax_steps\b"),
    ("negative max_events", _sim("7in-cde", 200, max_events=-1), r"\bmax_events\b"),
    ("bool max_steps", _sim("7in-cde", 200, max_steps=True), r"\bmax_steps\b"),
    ("bool max_events", _sim("7in-cde", 200, max_events=False), r"\bmax_events\b"),
    # initial state
    ("initial_state too short", _sim("7in-cde", 200, initial_state=np.zeros(7)),
     r"initial_state"),
    ("initial_state 2-d", _sim("7in-cde", 200, initial_state=np.zeros((2, 7))),
     r"initial_state"),
    ("initial_state NaN", _sim("7in-cde", 200, initial_state=np.full(14, NAN)),
     r"initial_state"),
    ("initial_state inf", _sim("7in-cde", 200, initial_state=np.r_[np.zeros(13), INF]),
     r"initial_state"),
    ("initial_state string", _sim("7in-cde", 200, initial_state="static"), r"initial_state"),
    ("initial_state bools", _sim("7in-cde", 200, initial_state=[True] * 14), r"initial_state"),
    ("initial_state number strings", _sim("7in-cde", 200, initial_state=["1"] * 14),
     r"initial_state"),
    ("initial_state ragged", _sim("7in-cde", 200, initial_state=[[1.0], [1.0, 2.0]]),
     r"initial_state"),
    ("initial_state far away", _sim("7in-cde", 200, initial_state=np.r_[np.full(7, 1e4),
                                                                        np.zeros(7)]),
     r"initial_state\[0\].*1000 m"),
    # contact law
    ("unknown law", _sim("7in-cde", 200, law="hertz"), r"hertz"),
    # extra forces
    ("unknown extra force", _ef("magnet", c=1.0), r"magnet"),
    ("unknown body", _ef("friction", body="rotor", force=1.0), r"rotor"),
    ("unknown other body", _ef("dashpot", body="bit", other="casing", k=1.0), r"casing"),
    ("hydraulic on housing", _ef("hydraulic", acts_on="housing", c=1e-4), r"housing"),
    ("unknown extra argument", _ef("hydraulic", c=1e-4, gain=2.0), r"\bgain\b"),
    ("hydraulic without c", _ef("hydraulic"), r"\bc\b"),
    ("friction without force", _ef("friction"), r"\bforce\b"),
    ("dashpot without body", _ef("dashpot", k=1.0), r"\bbody\b"),
    ("hydraulic c string", _ef("hydraulic", c="big"), r"\bc\b"),
    ("hydraulic c None", _ef("hydraulic", c=None), r"\bc\b"),
    ("hydraulic c NaN", _ef("hydraulic", c=NAN), r"\bc\b"),
    ("negative friction", _ef("friction", force=-1.0), r"\bforce\b"),
    ("zero v_eps", _ef("friction", force=1.0, v_eps=0.0), r"\bv_eps\b"),
    ("negative dashpot k", _ef("dashpot", body="bit", k=-1.0), r"\bk\b"),
    ("NaN dashpot c", _ef("dashpot", body="bit", c=NAN), r"\bc\b"),
    ("bool hydraulic c", _ef("hydraulic", c=True), r"\bc\b"),
    ("huge hydraulic c", _ef("hydraulic", c=1e300), r"\bc\b"),
    ("subnormal v_eps", _ef("friction", force=1.0, v_eps=5e-324), r"\bv_eps\b"),
    ("subnormal dashpot k", _ef("dashpot", body="bit", k=5e-324), r"\bk\b"),
    ("extras not an extra force", _sim("7in-cde", 200, extras=["hydraulic"]), r"\bextra"),
    ("extras None", _sim("7in-cde", 200, extras=[None]), r"\bextra"),
    # weight on bit
    ("negative wob_klbf", _sim("7in-cde", 200, wob_klbf=-1.0), r"wob_klbf"),
    ("NaN wob_klbf", _sim("7in-cde", 200, wob_klbf=NAN), r"wob_klbf"),
    ("inf wob_klbf", _sim("7in-cde", 200, wob_klbf=INF), r"wob_klbf"),
    ("string wob_klbf", _sim("7in-cde", 200, wob_klbf="8"), r"wob_klbf"),
    ("bool wob_klbf", _sim("7in-cde", 200, wob_klbf=True), r"wob_klbf"),
    ("wob_klbf without preset", _sim({"kS": 2e5}, 200, wob_klbf=4.0), r"wob_klbf"),
]


@pytest.mark.parametrize("call,pattern", [(c, p) for _, c, p in BAD_INPUTS],
                         ids=[name for name, _, _ in BAD_INPUTS])
def test_bad_input_raises_value_error_naming_it(call, pattern):
    with pytest.raises(ValueError) as info:
        call()
    msg = str(info.value)
    assert msg.strip(), "empty message"
    assert re.search(pattern, msg), f"message does not name the bad input: {msg!r}"


def test_ranges_are_published_and_hold_the_presets():
    ranges = vadsim.model.presets.param_ranges()
    assert set(ranges) == set(vadsim.model.presets.param_names())
    for preset in vadsim.PRESETS.values():
        for name, value in preset.params.items():
            rule, lo, hi = ranges[name]
            assert (rule == "non-negative" and value == 0) or lo <= value <= hi, (name, value)
            if rule in ("positive", "non-negative") and not name.startswith("L"):
                # Masses, stiffnesses, damping, forces: normal numbers only (a subnormal
                # travel LOn is harmless: it is added, never divided by).
                assert lo >= 2.2250738585072014e-308, name
    lo, hi = vadsim.make_params("7in-cde").flow_range_gpm()
    assert lo < 1 and hi > 5000  # the flows anyone drills with
    # Valid runs at both ends of the flow range.
    for flow in (lo * 1.0001, hi * 0.9999):
        r = vadsim.simulate("7in-cde", flow, cycles=2, analyse_cycles=1, record="none",
                            summary_rate_hz=50000)
        assert np.all(np.isfinite(r.y_end))


def test_shared_checks_refuse_booleans():
    from vadsim import _checks

    for value in (True, False, np.bool_(True)):
        with pytest.raises(ValueError, match="fs_hz"):
            _checks.number("fs_hz", value)
        with pytest.raises(ValueError, match="fs_hz"):
            _checks.finite_positive("fs_hz", value)
    assert _checks.number("fs_hz", 3) == 3.0
    assert _checks.finite_positive("fs_hz", np.float32(2.5)) == 2.5


def test_solver_error_on_step_budget():
    assert issubclass(vadsim.SolverError, RuntimeError)
    with pytest.raises(vadsim.SolverError, match=r"t =") as info:
        vadsim.simulate("7in-cde", 200, max_steps=50, **TINY)
    assert "max_steps" in str(info.value)
    with pytest.raises(RuntimeError):  # catchable as a RuntimeError
        vadsim.simulate("7in-cde", 200, max_steps=50, **TINY)


def test_solver_error_on_event_budget():
    with pytest.raises(vadsim.SolverError, match=r"t =.*max_events"):
        vadsim.simulate("7in-cde", 200, max_events=3, **TINY)


def _budgets(cycles: float, **kw) -> tuple[int, int]:
    o = vadsim._core.RunOptions()
    o.cycles = cycles
    for k, v in kw.items():
        setattr(o, k, v)
    return o.step_budget(), o.event_budget()


def test_default_budgets_grow_with_the_run_length():
    # What a run needs per cycle, counted on a 400-cycle run at the slowest tested flow rate
    # of the 7in tool (most steps per cycle) and at the usual one.
    need = {}
    for flow in (5.0, 200.0):
        r = vadsim.simulate("7in-cde", flow, cycles=400, analyse_cycles=10, record="none",
                            summary_rate_hz=2000)
        need[flow] = (r.stats["steps"], len(r.events))
        steps_400, events_400 = _budgets(400)
        assert steps_400 >= 5 * r.stats["steps"] and events_400 >= 5 * len(r.events)
    # A 100000-cycle run needs 250 times as much: the default budgets give it that (and a
    # margin), as they give it to 400 cycles; they used to be a fixed 2e7 steps.
    ratio = 100000 / 400
    steps_long, events_long = _budgets(100000)
    for steps, events in need.values():
        assert steps_long >= 5 * ratio * steps
        assert events_long >= 5 * ratio * events
    assert steps_long >= ratio * 20000 * 400  # 20000 steps per cycle
    # Explicit budgets are honoured as given.
    assert _budgets(100000, max_steps=1234, max_events=56) == (1234, 56)
    with pytest.raises(vadsim.SolverError, match="max_steps = 50 "):
        vadsim.simulate("7in-cde", 200, max_steps=50, **TINY)
    with pytest.raises(ValueError, match=r"max_steps = 0 "):
        vadsim.simulate("7in-cde", 200, max_steps=0, **TINY)


# --------------------------------------------------------------------------------------------
# Continuation, overrides, wob, laws
# --------------------------------------------------------------------------------------------

def test_continuation_starts_from_previous_final_state():
    first = vadsim.simulate("7in-cde", 200, cycles=10, analyse_cycles=5, record="none")
    assert not np.allclose(first.y_end[:7], static_state(first.params))
    cont = vadsim.simulate("7in-cde", 200, cycles=10, analyse_cycles=5, record="all",
                           initial_state=first)
    assert cont.t[0] == 0.0
    np.testing.assert_allclose(cont.x[0], first.y_end[:7], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(cont.v[0], first.y_end[7:], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(cont.poincare[0], first.y_end, rtol=1e-14, atol=1e-14)
    # An array is the same as the result it came from.
    cont2 = vadsim.simulate("7in-cde", 200, cycles=10, analyse_cycles=5, record="all",
                            initial_state=first.y_end.copy())
    np.testing.assert_array_equal(cont.x, cont2.x)
    # Excitation phase restarts at t = 0, which is a whole number of cycles: 10 + 10 cycles
    # stays on the same (periodic, attracting) orbit as 20 cycles in one go.
    whole = vadsim.simulate("7in-cde", 200, cycles=20, analyse_cycles=5, record="none")
    np.testing.assert_allclose(cont.y_end[:7], whole.y_end[:7], rtol=0, atol=1e-6)
    np.testing.assert_allclose(cont.y_end[7:], whole.y_end[7:], rtol=0, atol=1e-2)


def test_wob_klbf_scales_wob():
    r = vadsim.simulate("7in-cde", 200, wob_klbf=8, **TINY)
    assert r.params["wob"] == pytest.approx(2 * vadsim.PRESETS["7in-cde"].params["wob"])
    assert r.params["wob"] == pytest.approx(2000.0)
    ra = vadsim.simulate("7in-cde", 200, wob_klbf=8, **{**TINY, "record": "all"})
    # The static state carries the doubled weight on bit.
    np.testing.assert_allclose(ra.contact_forces[0, [3, 4]], 2000.0, rtol=1e-9)
    np.testing.assert_allclose(ra.x[0], static_state(ra.params), rtol=1e-14)
    r4 = vadsim.simulate("7in-cde", 200, wob_klbf=4, **TINY)
    assert r4.params["wob"] == pytest.approx(1000.0)
    r0 = vadsim.simulate("7in-cde", 200, wob_klbf=0, **TINY)
    assert r0.params["wob"] == 0.0


def test_overrides_change_params_and_results(r200):
    r = vadsim.simulate("7in-cde", 200, overrides={"kS": 4.7e5, "m2": 1.2}, **SHORT)
    assert r.params["kS"] == 4.7e5 and r.params["m2"] == 1.2
    for k, v in r.params.items():
        if k not in ("kS", "m2"):
            assert v == r200.params[k], k
    assert r.impulse_pos != r200.impulse_pos
    # A mapping model: missing names come from 7in-cde.
    rm = vadsim.simulate({"kS": 4.7e5, "m2": 1.2}, 200, **SHORT)
    assert rm.preset is None and rm.m_ref_kg is None
    assert rm.params == r.params
    assert rm.impulse_pos == r.impulse_pos
    # A Preset object and core Params work as models too.
    pre = vadsim.get_preset("7in-cde").with_overrides(kS=4.7e5, m2=1.2)
    rp = vadsim.simulate(pre, 200, **SHORT)
    assert rp.impulse_pos == r.impulse_pos
    rc = vadsim.simulate(vadsim.make_params("7in-cde", {"kS": 4.7e5, "m2": 1.2}), 200, **SHORT)
    assert rc.impulse_pos == r.impulse_pos


@pytest.mark.parametrize("law", ["hunt_crossley", "kelvin_voigt_no_tension", "kelvin_voigt"])
def test_contact_laws_run(law, r200):
    r = vadsim.simulate("7in-cde", 200, law=law, **SHORT)
    assert np.all(np.isfinite(r.x)) and math.isfinite(r.impulse_pos)
    assert r.z["impact"] > 0
    if law == "kelvin_voigt":
        assert r.impulse_pos == r200.impulse_pos
    else:
        assert r.impulse_pos != r200.impulse_pos
        # Laws that cannot pull never give a negative impact-face force.
        assert r.contact_forces[:, 1].min() >= 0.0
        assert r.impulse_mean == pytest.approx(r.impulse_pos, rel=1e-12)


# --------------------------------------------------------------------------------------------
# Presets
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name,flow", [("7in-cde", 200), ("7in-rc", 200), ("9.5in-pdc", 560),
                                       ("7in-cde-cal", 200), ("7in-rc-cal", 200)])
def test_every_preset_runs(name, flow):
    r = vadsim.simulate(name, flow, **SHORT)
    assert r.preset == name
    assert np.all(np.isfinite(r.x)) and math.isfinite(r.impulse_pos)
    assert r.m_ref_kg == pytest.approx(vadsim.PRESETS[name].m_ref_kg)
    if name == "9.5in-pdc":
        assert r.f_exc_hz == pytest.approx(8.9, abs=0.05)  # MODEL.md: 560 gal/min -> 8.9 Hz


def test_preset_lookup_and_rc_differs_only_in_m1():
    assert vadsim.preset_names() == ["7in-cde", "7in-rc", "9.5in-pdc", "7in-cde-cal",
                                     "7in-rc-cal", "7in-cde-thesis", "7in-rc-thesis"]
    # the calibrated pair differs only in l0, wob and the phase at rest that its l0 gives
    cal = vadsim.PRESETS["7in-cde-cal"].params
    assert {k for k in cal if cal[k] != vadsim.PRESETS["7in-cde"].params[k]} == {
        "l0", "wob", "theta0"}
    assert vadsim.PRESETS["7in-cde-cal"].theta0 == pytest.approx(2.5057, abs=1e-4)  # MODEL.md
    assert vadsim.PRESETS["7in-rc-cal"].params["m1"] == 1.29
    cde, rc = vadsim.PRESETS["7in-cde"].params, vadsim.PRESETS["7in-rc"].params
    assert set(cde) == set(rc)
    diff = {k: (cde[k], rc[k]) for k in cde if cde[k] != rc[k]}
    assert diff == {"m1": (1.44, 1.29)}
    assert vadsim.get_preset("7in", "RC").name == "7in-rc"
    assert vadsim.get_preset("7in", "CDE").name == "7in-cde"
    assert vadsim.get_preset("7in").name == "7in-cde"
    assert vadsim.get_preset("9.5in").name == "9.5in-pdc"
    assert vadsim.get_preset("7in-RC").name == "7in-rc"
    r_cde = vadsim.simulate("7in-cde", 200, **TINY)
    r_rc = vadsim.simulate(vadsim.get_preset("7in", "RC"), 200, **TINY)
    assert r_rc.params["m1"] == 1.29 and r_cde.params["m1"] == 1.44
    assert {k for k in r_cde.params if r_cde.params[k] != r_rc.params[k]} == {"m1"}
    assert r_rc.preset == "7in-rc"


# --------------------------------------------------------------------------------------------
# Extra forces
# --------------------------------------------------------------------------------------------

def test_hydraulic_force_on_bit_changes_the_response_at_high_flow():
    opts = dict(cycles=60, analyse_cycles=30, record="none")
    base = vadsim.simulate("7in-cde", 600, **opts)
    # c Q^2 = 3600 N/kg at 600 gal/min: more than the on-bottom shoulder's share of the WOB,
    # so the bit is pushed off the shoulder and away from the anvil's blows.
    hyd = vadsim.simulate("7in-cde", 600, **opts,
                          extras=[vadsim.extra_force("hydraulic", acts_on="bit", c=1e-2)])
    rel_j = abs(hyd.impulse_pos - base.impulse_pos) / base.impulse_pos
    rel_p = abs(hyd.peak_stats(1)[0] - base.peak_stats(1)[0]) / base.peak_stats(1)[0]
    assert rel_j > 0.5 and rel_p > 0.5, (rel_j, rel_p)
    # A milder force still changes the numbers (deterministically), a zero one not at all.
    mild = vadsim.simulate("7in-cde", 600, **opts,
                           extras=[vadsim.extra_force("hydraulic", acts_on="bit", c=1e-3)])
    assert mild.impulse_pos != base.impulse_pos
    assert mild.peak_stats(1)[0] != base.peak_stats(1)[0]
    zero = vadsim.simulate("7in-cde", 600, extras=[vadsim.extra_force("hydraulic", c=0.0)],
                           **opts)
    assert zero.impulse_pos == base.impulse_pos
    np.testing.assert_array_equal(zero.window_peaks_g, base.window_peaks_g)


def test_hydraulic_force_load_paths():
    c, q = 1e-3, 600.0
    opts = dict(cycles=60, analyse_cycles=30, record="window", output_rate_hz=5000)
    base = vadsim.simulate("7in-cde", q, **opts)
    on_bit = vadsim.simulate("7in-cde", q, **opts,
                             extras=[vadsim.extra_force("hydraulic", acts_on="bit", c=c)])
    # On the bit, c Q^2 splits quasi-statically between the rock and the string above the
    # on-bottom shoulder (kOn, k3..k7 in series): the rock's mean force rises by its share.
    p = base.params
    k_string = 1.0 / sum(1.0 / p[k] for k in ("kOn", "k3", "k4", "k5", "k6", "k7"))
    share = p["kR"] / (p["kR"] + k_string)
    rise = on_bit.contact_forces[:, 4].mean() - base.contact_forces[:, 4].mean()
    assert rise == pytest.approx(c * q**2 * share, rel=0.1)
    # On the anvil (the default), it presses the anvil onto the bit: J* ~ c Q^2.
    on_anvil = vadsim.simulate("7in-cde", q, **opts,
                               extras=[vadsim.extra_force("hydraulic", c=c)])
    assert on_anvil.impulse_pos == pytest.approx(c * q**2, rel=0.05)


def test_friction_and_dashpot_run(r200):
    fr = vadsim.extra_force("friction", force=50.0)
    assert fr.name
    dp = vadsim.extra_force("dashpot", body="anvil", other="housing", k=1e4, c=50.0)
    ground = vadsim.extra_force("dashpot", body="mwd", k=1e5, c=100.0)
    for extras in ([fr], [dp], [ground], [fr, dp, ground]):
        r = vadsim.simulate("7in-cde", 200, extras=extras, **SHORT)
        assert np.all(np.isfinite(r.x)) and math.isfinite(r.impulse_pos)
        assert r.impulse_pos != r200.impulse_pos
    # A dashpot with k = c = 0 is no force at all.
    null = vadsim.simulate("7in-cde", 200, extras=[vadsim.extra_force("dashpot", body="bit")],
                           **SHORT)
    np.testing.assert_array_equal(null.x, r200.x)


# --------------------------------------------------------------------------------------------
# Ctrl-C: a run on the main thread stops at the next interrupt check
# --------------------------------------------------------------------------------------------

# Hang guard only: an interrupted child ends in well under a second; a child that ignored the
# signal would run its whole horizon (100000 cycles, minutes) and be killed here.
HANG_GUARD_S = 60.0
LONG_RUN = ("cycles=100000, analyse_cycles=10, record='none', summary_rate_hz=2000, "
            "steady='full'")  # every cycle integrated: the run outlasts the signal
NOTE_RE = re.compile(r"simulation interrupted at t = (\S+) s of t_end = (\S+) s, after (\d+) "
                     r"steps")


def _child(code: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    return subprocess.Popen([sys.executable, "-c", SIGINT_PRELUDE + code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


def _interrupt_after_start(proc: subprocess.Popen) -> tuple[str, str]:
    """Wait for the child's "started" line, send SIGINT, return (stdout, stderr)."""
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert line.strip() == "started", line + proc.stderr.read() if proc.stderr else ""
    # The child enters the run a few milliseconds after printing; the pause makes it all but
    # certain that the signal lands inside the run (the assertions below check that it did).
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=HANG_GUARD_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"the child ignored SIGINT (hang guard {HANG_GUARD_S} s); stderr: {err}")
    return line + out, err


def test_ctrl_c_stops_a_run_on_the_main_thread():
    proc = _child(f"""
import vadsim
print("started", flush=True)
vadsim.simulate("7in-cde", 200, {LONG_RUN})
print("finished", flush=True)
""")
    out, err = _interrupt_after_start(proc)
    assert proc.returncode != 0
    assert "finished" not in out
    assert "KeyboardInterrupt" in err, err
    # The note says where the run stopped: inside it, long before its end (counts, not time).
    m = NOTE_RE.search(err)
    assert m, f"no interrupt note (signal outside the run?): {err}"
    t, t_end, steps = float(m.group(1)), float(m.group(2)), int(m.group(3))
    alpha = vadsim.get_preset("7in-cde").params["alpha"]
    assert t_end == pytest.approx(100000 / alpha / 200 * 2 * math.pi, rel=1e-5)
    assert 0 < t < 0.5 * t_end
    assert steps > 0 and steps % 2000 == 0  # stopped at an interrupt check


def test_ctrl_c_with_a_run_in_a_worker_thread():
    """Python runs signal handlers on the main thread only: the main thread gets the
    KeyboardInterrupt, and a run in a worker thread is not checked and goes on to its end
    (documented in vadsim.simulate)."""
    proc = _child("""
import time
from concurrent.futures import ThreadPoolExecutor
import vadsim
ex = ThreadPoolExecutor(1)
fut = ex.submit(vadsim.simulate, "7in-cde", 200, cycles=2000, analyse_cycles=10,
                record="none", summary_rate_hz=2000)
print("started", flush=True)
try:
    while True:
        time.sleep(0.01)
except KeyboardInterrupt:
    print("main: KeyboardInterrupt", flush=True)
r = fut.result()
print("worker: cycles", round(r.window[1] * r.f_exc_hz, 6), flush=True)
""")
    out, err = _interrupt_after_start(proc)
    assert proc.returncode == 0, err
    assert "main: KeyboardInterrupt" in out, out + err
    assert "worker: cycles 2000.0" in out, out + err


def test_to_xarray_labels_itself() -> None:
    """The time series as a Dataset: a named dof dimension, CF units and long names on every
    variable and coordinate, and the run's labels under the sweep's key names."""
    r = vadsim.simulate("7in-cde", 200, cycles=20, analyse_cycles=10, output_rate_hz=2000)
    ds = r.to_xarray()
    assert list(ds.dof.values) == ["bit", "anvil", "housing", "motor", "sub", "lwd", "mwd"]
    assert ds.accel_g.sel(dof="bit").size == r.t.size
    np.testing.assert_array_equal(ds.accel_g.values, r.accel_g)
    for name in [*ds.data_vars, *ds.coords]:
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs, name
    assert ds.attrs["z_impact"] == r.z["impact"] and ds.attrs["j_pos"] == r.impulse_pos
    assert r.success is True and "steps" in r.message


def test_a_run_that_stores_accelerations_only_is_the_same_run() -> None:
    """``accelerations_only``: the same steps, events and accelerations to the bit; x, v and
    the forces empty; the Dataset holds what was stored; a non-boolean is refused by name."""
    kw = dict(cycles=20, analyse_cycles=10, output_rate_hz=20480.0, summary_rate_hz=0.0)
    full = vadsim.simulate("7in-cde", 400, **kw)
    slim = vadsim.simulate("7in-cde", 400, accelerations_only=True, **kw)
    np.testing.assert_array_equal(slim.t, full.t)
    np.testing.assert_array_equal(slim.a, full.a)
    assert slim.stats == full.stats and slim.z == full.z
    assert slim.x.shape == (0, 7) and slim.v.shape == (0, 7)
    assert slim.contact_forces.shape[0] == 0 and slim.excitation_force.size == 0
    assert slim.accelerations_only and not full.accelerations_only
    ds = slim.to_xarray()
    assert set(ds.data_vars) == {"a", "accel_g"} and ds.sizes["time"] == full.t.size
    with pytest.raises(ValueError, match="accelerations_only"):
        vadsim.simulate("7in-cde", 400, accelerations_only="yes", **kw)
