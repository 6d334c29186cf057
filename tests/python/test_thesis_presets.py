"""The calibrated 9.5in preset against the dissertation's own 9.5in simulation (section 3.3):
one impact per cycle at every event and x1 peaks within +-3 g (docs/CALIBRATION.md)."""

from concurrent.futures import ThreadPoolExecutor

import pytest
import vadsim
from vadsim.thesis import field_events

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
