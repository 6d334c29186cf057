"""The calibrated 9.5in preset against the dissertation's own 9.5in simulation (section 3.3):
one impact per cycle at every event and x1 peaks within +-3 g (docs/CALIBRATION.md)."""

from concurrent.futures import ThreadPoolExecutor

import pytest
import vadsim
from vadsim.studies.thesis import field_events

EVENTS = field_events("9.5in", "PDC")


@pytest.fixture(scope="module")
def runs():
    with ThreadPoolExecutor(2) as pool:
        return list(pool.map(lambda q: vadsim.simulate("9.5in-pdc", q, record="none"),
                             EVENTS.flow_gpm))


def test_one_impact_per_cycle_at_every_event(runs):
    assert [r.z["impact"] for r in runs] == [1.0] * len(EVENTS)


@pytest.mark.parametrize("i", range(len(EVENTS)))
def test_peaks_within_3_g_of_the_dissertation_simulation(runs, i):
    e = EVENTS.iloc[i]
    if e.event == 8:
        pytest.skip("event 8's simulated peak is printed '04g' (misprint)")
    assert abs(runs[i].peak_stats(1)[0] - e.sim_peak_g) <= 3.0


def test_the_thesis_preset_meets_all_five_published_regime_bands():
    """7in-cde-thesis holds the phase at rest the constants scan chose (theta0 = 2.475 rad):
    every band of section 4.1 within 10 gal/min, where 7in-cde (2.264) misses four."""
    import numpy as np
    from vadsim.studies.constants import band_scores
    from vadsim.studies.sweep import sweep

    flows = np.arange(200.0, 650.0 + 1e-9, 10.0)
    bands = band_scores(sweep("7in-cde-thesis", flows, workers=2, progress=False))
    assert [b["ok"] for b in bands] == [True] * 5, bands
    assert max(b["error"] for b in bands) <= 10.0


def test_a_preset_with_its_own_phase_at_rest_is_the_psi_run_bit_for_bit():
    """theta0 = what l0 and psi give reproduces the dissertation's parameterisation exactly."""
    import math

    a = vadsim.simulate("7in-cde", 350.0, cycles=60, analyse_cycles=30, record="none")
    b = vadsim.simulate("7in-cde", 350.0, cycles=60, analyse_cycles=30, record="none",
                        overrides={"theta0": math.nan})
    assert "theta0" not in b.params and a.params["theta0"] == vadsim.PRESETS["7in-cde"].theta0
    assert a.impulse_pos == b.impulse_pos and a.z == b.z
    assert (a.y_end == b.y_end).all()
