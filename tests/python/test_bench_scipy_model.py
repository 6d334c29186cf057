"""The pure-Python reference model of bench/bench_scipy.py against the C++ core.

The benchmark's ratio means something only if SciPy integrates the same model: its right-hand
side must equal the core's (with the contact modes the state implies), and a short SciPy run
must see the same impacts as vadsim.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
import vadsim

BENCH = Path(__file__).resolve().parents[2] / "bench" / "bench_scipy.py"
PRESET = "7in-cde"
FLOW = 200.0


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_scipy", BENCH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    try:
        spec.loader.exec_module(mod)
        yield mod
    finally:
        sys.modules.pop(spec.name, None)


@pytest.fixture(scope="module")
def params():
    return dict(vadsim.get_preset(PRESET).params)


def test_static_state_matches_core(bench, params):
    core = vadsim._core.Model(vadsim.make_params(PRESET))
    ref = bench.make_model(params, FLOW)
    np.testing.assert_allclose(ref.x_static, np.asarray(core.static_positions), rtol=0,
                               atol=1e-12)
    assert ref.x_top == pytest.approx(core.x_top, abs=1e-12)
    # At rest in the static state every force balances: zero acceleration at F_H = 0.
    ref_rest = bench.make_model({**params, "Fo": 0.0}, FLOW)
    assert np.abs(ref_rest.rhs(0.0, np.zeros(14))).max() < 1e-9


def test_reference_rhs_matches_core(bench, params):
    core = vadsim._core.Model(vadsim.make_params(PRESET))
    ref = bench.make_model(params, FLOW)
    rng = np.random.default_rng(20240611)
    seen = np.zeros((5, 2), dtype=int)  # per surface: states with the contact open / closed
    for _ in range(40):
        y = np.r_[rng.normal(0.0, 1e-2, 7), rng.normal(0.0, 2.0, 7)]
        t = float(rng.uniform(0.0, 1.0))
        d = [core.indentation(s, y) for s in range(5)]
        modes = [1 if ds > 0 else 0 for ds in d]
        for s in range(5):
            seen[s, modes[s]] += 1
            assert ref.indentation(s, y) == pytest.approx(d[s], rel=1e-9, abs=1e-15)
        want = np.asarray(core.rhs(t, FLOW, y, modes))
        got = ref.rhs(t, y)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
    # The random states exercise every contact both open and closed.
    assert (seen > 0).all(), seen


def test_scipy_three_cycles_impacts_match_vadsim(bench, params):
    s = bench.run_scipy(params, FLOW, cycles=3, analyse_cycles=3)
    r = vadsim.simulate(PRESET, FLOW, cycles=3, analyse_cycles=3, record="none")
    ev = r.events
    onsets = ev[(ev.surface == "impact") & (ev.kind == "onset")].time_s.to_numpy()
    assert s["impacts"]["impact"] == r.impacts["impact"] > 0
    np.testing.assert_allclose(s["onset_times"]["impact"], onsets, rtol=0, atol=1e-5)
    assert s["impacts"]["spring"] == r.impacts["spring"]
