"""The excitation line of a record (vadsim.signals.excitation_line) and the operating point a
diagnosis reads from it (vadsim.fit.diagnosis.operating_point)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.diagnosis.operating_point import (
    OPERATING_POINT_TOLERANCE,
    operating_point,
    operating_point_text,
)
from vadsim.model.presets import get_preset
from vadsim.signals.excitation_line import excitation_line

RATE = 1024.0


def _ringing_train(f_hz: float, seconds: float, noise_g: float = 0.3, seed: int = 0
                   ) -> np.ndarray:
    """One decaying 1 kHz ring per cycle, sampled at 1024 Hz: its harmonics near 1 kHz alias
    next to the fundamental, as an impact's do."""
    t = np.arange(int(seconds * RATE)) / RATE
    phase = (t * f_hz) % 1.0 / f_hz  # time since the last impact, s
    ring = 60.0 * np.exp(-phase / 0.004) * np.sin(2 * np.pi * 1010.0 * phase)
    forced = 20.0 * np.sin(2 * np.pi * f_hz * t)  # the fundamental the strongest line
    return ring + forced + np.random.default_rng(seed).normal(0.0, noise_g, t.size)


@pytest.mark.parametrize("f_hz", [21.3268, 31.99, 53.3169, 69.312])
def test_the_line_of_an_aliased_impact_train_is_its_excitation(f_hz):
    """Within 3 / N of the record's N samples (2 / N: the fold's lock next to a frequency of
    a whole number of samples a cycle, 21.333 and 32.0 Hz here), searched from 2 % off."""
    n = int(3.0 * RATE)
    line = excitation_line(_ringing_train(f_hz, 3.0), RATE, f_hz * 1.02)
    assert line.hz == pytest.approx(f_hz, rel=3.0 / n)
    assert line.blocks == 3 and line.spread_hz < 2e-3 * f_hz


def test_a_record_that_does_not_repeat_is_not_read():
    rng = np.random.default_rng(1)
    line = excitation_line(rng.normal(0.0, 5.0, int(4 * RATE)), RATE, 30.0)
    assert not line.periodic and math.isnan(line.spread_hz)
    assert excitation_line(_ringing_train(30.0, 4.0), RATE, 30.0).periodic


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="span"):
        excitation_line(np.ones(4096), RATE, 30.0, span=0.7)
    with pytest.raises(ValueError, match="f_hz"):
        excitation_line(np.ones(4096), RATE, -1.0)


FLOWS = (200.0, 300.0, 400.0, 500.0, 600.0, 650.0)
SMALL = dict(duration_s=3.0, cycles=160, analyse_cycles=100, seed=12)


def test_records_run_at_their_stated_flows_report_nothing():
    rows = operating_point(synthetic_campaign("7in-cde", FLOWS, **SMALL), get_preset("7in-cde"))
    assert [r["event"] for r in rows] == [f"e0{i}" for i in range(1, 7)]
    assert all(abs(r["off"]) < OPERATING_POINT_TOLERANCE for r in rows), rows
    assert operating_point_text(rows) is None


def test_records_run_3_percent_above_their_stated_flows_are_reported_with_their_flow():
    """The folded evidence folds each record at its own frequency and the calibration can
    absorb the rest; the excitation line says the flow directly."""
    camp = synthetic_campaign("7in-cde", tuple(1.03 * q for q in FLOWS), **SMALL)
    camp.events = [dataclasses.replace(e, flow_gpm=q) for e, q in zip(camp.events, FLOWS,
                                                                          strict=True)]
    rows = operating_point(camp, get_preset("7in-cde"))
    read = [r for r in rows if r["periodic"]]  # 400 gal/min is erratic on 3 s records
    assert len(read) >= 4 and all(r["beyond"] for r in read), rows
    assert not any(r["beyond"] for r in rows if not r["periodic"])
    for r, q in zip(rows, FLOWS, strict=True):
        assert r["implied_flow_gpm"] == pytest.approx(1.03 * q, rel=2e-3)
    text = operating_point_text(rows)
    assert text is not None and f"{len(read)} of 6 events" in text and "(+3.0 %)" in text
