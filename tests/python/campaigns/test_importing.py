"""Tests of ``vadsim campaign import``: a continuous record and a surface log to a campaign.

What is asserted (issue 37): every format is read to the same campaign; units are converted;
the clock offset is recovered within one sample period of the surface log on the synthetic
flow-step record; a stretch shorter than the minimum, or with a flow change inside, is
refused with its reason; a wrongly named column gives an error naming the columns that
exist; the steady stretches match the flow steps and the imported campaign validates.
The simulations are short (two or three steps of 16 s; under a second of model time each).
"""

from __future__ import annotations

import builtins
import importlib
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from vadsim.campaigns import (
    CampaignError,
    StretchRules,
    campaign_text,
    import_campaign,
    load_campaign,
)
from vadsim.campaigns import sources as sources_module
from vadsim.campaigns.flowstep import FlowStepTest, flow_step_test
from vadsim.cli import main

G = 9.80665
STEP_S = 16.0


@pytest.fixture(scope="module")
def test3() -> FlowStepTest:
    """Three flow steps, the surface clock 123.4 s ahead of the record's."""
    return flow_step_test(flows=(200.0, 400.0, 650.0), step_s=STEP_S, clock_offset_s=123.4,
                          seed=5)


def _import(ft: FlowStepTest, record: Path, surface: Path, **kw):
    return import_campaign(record, surface, tool="7in", bit="CDE", columns=ft.columns, **kw)


def _flows(result) -> list[float]:
    return [ev.flow_gpm for ev in result.campaign.events]


def test_offset_recovered_within_one_sample_period(test3, tmp_path):
    res = _import(test3, test3.write_record(tmp_path / "r.csv"),
                  test3.write_surface(tmp_path / "s.csv"))
    period = float(np.median(np.diff(test3.surface["Time"])))
    error = res.alignment.offset_s - test3.clock_offset_s
    assert res.alignment.estimated
    assert abs(error) < period, (error, res.alignment.describe())
    # the record's own onset is found to within a few record samples of the pumps coming on
    assert abs(res.alignment.record_onset_s - test3.pumps_on_s) < 0.05


def test_stretches_match_the_flow_steps(test3, tmp_path):
    res = _import(test3, test3.write_record(tmp_path / "r.csv"),
                  test3.write_surface(tmp_path / "s.csv"))
    events = res.campaign.events
    assert len(events) == len(test3.steps)
    kept = {st.event_id: st.kept_s for st in res.stretches if st.accepted}
    for ev, (t0, t1, q) in zip(events, test3.steps, strict=True):
        lo, hi = kept[ev.id]
        assert t0 + 1.0 < lo < hi < t1, (ev.id, lo, hi, t0, t1)   # inside its step, settled
        assert hi - lo >= res.rules.min_duration_s
        assert abs(ev.flow_gpm - q) < 3.0
        assert abs(ev.wob_klbf - test3.wob_klbf) < 0.1
    refused = [st for st in res.stretches if not st.accepted]
    assert refused and all("pumps off" in st.reason for st in refused)


@pytest.mark.parametrize("record_suffix", [".csv", ".parquet", ".h5", ".las"])
def test_each_record_format_reads_to_the_same_campaign(test3, tmp_path, record_suffix):
    surface = test3.write_surface(tmp_path / "s.csv")
    reference = _import(test3, test3.write_record(tmp_path / "r.csv"), surface,
                        clock_offset_s=test3.clock_offset_s).campaign
    res = _import(test3, test3.write_record(tmp_path / f"r{record_suffix}"), surface,
                  clock_offset_s=test3.clock_offset_s)
    camp = res.campaign
    assert [e.id for e in camp.events] == [e.id for e in reference.events]
    assert _flows(res) == [e.flow_gpm for e in reference.events]
    assert camp.sensors == reference.sensors
    for a, b in zip(camp.events, reference.events, strict=True):
        assert a.data is not None and b.data is not None
        assert a.data.shape == b.data.shape
        np.testing.assert_allclose(a.data.to_numpy(), b.data.to_numpy(), rtol=1e-6,
                                   atol=1e-6)
    assert res.record.units["x1"].startswith("m/s^2")


def test_hdf5_written_by_pandas(test3, tmp_path):
    surface = test3.write_surface(tmp_path / "s.csv")
    test3.record.to_hdf(tmp_path / "r.h5", key="record", format="table")
    res = _import(test3, tmp_path / "r.h5", surface, units="m/s^2",
                  clock_offset_s=test3.clock_offset_s)
    reference = _import(test3, test3.write_record(tmp_path / "r.csv"), surface,
                        clock_offset_s=test3.clock_offset_s)
    assert res.record.pieces[0].n == reference.record.pieces[0].n
    for a, b in zip(res.campaign.events, reference.campaign.events, strict=True):
        assert a.data is not None and b.data is not None
        np.testing.assert_allclose(a.data.to_numpy(), b.data.to_numpy(), rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("surface_suffix", [".csv", ".xlsx", ".las"])
def test_each_surface_format_reads_to_the_same_campaign(test3, tmp_path, surface_suffix):
    record = test3.write_record(tmp_path / "r.csv")
    reference = _import(test3, record, test3.write_surface(tmp_path / "s.csv"))
    res = _import(test3, record, test3.write_surface(tmp_path / f"s{surface_suffix}"))
    assert _flows(res) == _flows(reference)
    assert res.alignment.offset_s == pytest.approx(reference.alignment.offset_s, abs=1e-6)
    for a, b in zip(res.campaign.events, reference.campaign.events, strict=True):
        assert a.data is not None and b.data is not None
        np.testing.assert_array_equal(a.data.to_numpy(), b.data.to_numpy())


def test_units_converted(tmp_path):
    ft = flow_step_test(flows=(300.0, 500.0), step_s=STEP_S, flow_unit="L/min", wob_unit="kN",
                        seed=2)
    assert "Flow [L/min]" in ft.surface and "WOB [kN]" in ft.surface
    res = _import(ft, ft.write_record(tmp_path / "r.csv"), ft.write_surface(tmp_path / "s.csv"))
    # L/min and kN in the log, gal/min and klbf in the campaign
    assert [round(q, -1) for q in _flows(res)] == [300.0, 500.0]
    assert all(abs(ev.wob_klbf - ft.wob_klbf) < 0.1 for ev in res.campaign.events)
    # m/s^2 in the record, g in the campaign: the samples are the record's divided by g
    ev = res.campaign.events[0]
    lo = res.stretches[[s.event_id for s in res.stretches].index(ev.id)].kept_s[0]
    rec = ft.record
    first = int(np.searchsorted(rec["Time"].to_numpy(), lo - 1e-9))
    assert ev.data is not None
    np.testing.assert_allclose(ev.data["x1_g"].to_numpy()[:50],
                               rec["AccZ_bit"].to_numpy()[first:first + 50] / G, rtol=1e-7)
    # a stated unit that contradicts the file's is refused, naming both
    with pytest.raises(CampaignError, match=r"is in m/s\^2 \(from the column name\), but "
                                            r"--units says g"):
        _import(ft, tmp_path / "r.csv", tmp_path / "s.csv", units="g")


def test_unit_missing_from_the_file_must_be_stated(tmp_path):
    ft = flow_step_test(flows=(300.0,), step_s=12.0, seed=1)
    plain = ft.record.rename(columns={"AccZ_bit": "a1", "AccZ_mwd": "a5"})
    plain.to_csv(tmp_path / "plain.csv", index=False)
    ft.write_surface(tmp_path / "s.csv")
    with pytest.raises(CampaignError, match=r"plain.csv: column 'a1': the file does not say "
                                            r"its unit; state it: --units g or --units m/s\^2"):
        import_campaign(tmp_path / "plain.csv", tmp_path / "s.csv", tool="7in", bit="CDE",
                        columns={"x1": "a1"})
    res = import_campaign(tmp_path / "plain.csv", tmp_path / "s.csv", tool="7in", bit="CDE",
                          columns={"x1": "a1", "x5": "a5"}, units="m/s^2",
                          rules=StretchRules(min_duration_s=5.0))
    assert res.record.units["x1"] == "m/s^2 (stated)"


def test_wrong_column_names_the_columns_that_exist(test3, tmp_path):
    record = test3.write_record(tmp_path / "r.csv")
    surface = test3.write_surface(tmp_path / "s.csv")
    with pytest.raises(CampaignError) as err:
        import_campaign(record, surface, tool="7in", bit="CDE", columns={"x1": "AccZ_bt"})
    msg = str(err.value)
    assert str(record) in msg and "'AccZ_bt'" in msg and "x1" in msg
    for col in test3.record.columns:
        assert repr(col if col != "Time" else "Time [s]").strip("'") in msg
    with pytest.raises(CampaignError, match=r"s.csv: no column 'Flw' for flow "
                                            r"\(--surface-column flow\); the columns are "
                                            r"'Time \[s\]', 'Flow \[gpm\]', 'WOB \[klbf\]'"):
        import_campaign(record, surface, tool="7in", bit="CDE", columns=test3.columns,
                        surface_columns={"flow": "Flw"})


def _handmade(tmp_path: Path, levels: list[tuple[float, float]],
              blip: tuple[float, float] | None = None) -> tuple[Path, Path]:
    """A record that is noise with pumps off and louder noise with them on, and a 1 Hz log of
    ``(seconds, flow)`` levels at 4 klbf (``blip``: one sample's flow at a time)."""
    rng = np.random.default_rng(0)
    t_log = np.arange(0.0, sum(d for d, _ in levels))
    flow = np.concatenate([np.full(int(d), q) for d, q in levels])
    if blip is not None:
        flow[int(blip[0])] = blip[1]
    log = pd.DataFrame({"time": t_log, "flow_gpm": flow + rng.normal(0, 1.0, flow.size),
                        "wob_klbf": 4.0 + rng.normal(0, 0.05, flow.size)})
    log.to_csv(tmp_path / "log.csv", index=False)
    t = np.arange(0.0, t_log[-1] + 1.0, 1 / 512)
    loud = np.interp(t, t_log, (flow > 50).astype(float))
    rec = pd.DataFrame({"time_s": t, "x1_g": rng.normal(0, 0.3, t.size) * (1 + 30 * loud)})
    rec.to_csv(tmp_path / "rec.csv", index=False)
    return tmp_path / "rec.csv", tmp_path / "log.csv"


def test_short_stretch_and_flow_change_inside_refused_with_reason(tmp_path):
    levels = [(10, 0.0), (20, 300.0), (6, 400.0), (24, 500.0), (20, 600.0)]
    record, log = _handmade(tmp_path, levels, blip=(48.0, 560.0))   # 12 s into the 500 level
    res = import_campaign(record, log, tool="7in", bit="CDE", columns={"x1": "x1_g"},
                          clock_offset_s=0.0)
    assert [round(q, -1) for q in _flows(res)] == [300.0, 600.0]
    reasons = {round(st.flow_gpm, -2): st.reason for st in res.stretches if not st.accepted}
    assert reasons[0.0].startswith("pumps off")
    assert "shorter than the 8 s minimum" in reasons[400.0]
    assert re.match(r"the flow changes inside: 5[56]\d gal/min at 48.0 s, \d+ gal/min from its "
                    r"level 500 \(tolerance 10\), for 1 sample", reasons[500.0]), reasons[500.0]
    summary = res.summary()
    for reason in reasons.values():
        assert reason in summary
    # the same rules, loosened, take the short stretch
    loose = import_campaign(record, log, tool="7in", bit="CDE", columns={"x1": "x1_g"},
                            clock_offset_s=0.0, rules=StretchRules(min_duration_s=2.0))
    assert 400.0 in [round(q, -1) for q in _flows(loose)]


def test_nothing_qualifies_lists_every_reason(tmp_path):
    record, log = _handmade(tmp_path, [(10, 0.0), (6, 300.0), (6, 400.0)])
    with pytest.raises(CampaignError, match=r"no steady stretch qualifies(.|\n)*shorter than "
                                            r"the 8 s minimum"):
        import_campaign(record, log, tool="7in", bit="CDE", columns={"x1": "x1_g"},
                        clock_offset_s=0.0)


def test_record_time_problems_name_the_file_column_and_row(tmp_path):
    t = np.arange(2000) / 1024.0
    t[700] += 0.4 / 1024.0
    pd.DataFrame({"t": t, "a [g]": np.zeros(t.size)}).to_csv(tmp_path / "jit.csv", index=False)
    _, log = _handmade(tmp_path, [(10, 0.0), (20, 300.0)])
    with pytest.raises(CampaignError, match=r"jit.csv: time column 't', row 700: .* sample "
                                            r"periods off the uniform grid"):
        import_campaign(tmp_path / "jit.csv", log, tool="7in", bit="CDE",
                        columns={"x1": "a", "time": "t"})
    t = np.arange(2000) / 1024.0
    t[900] = t[899]
    pd.DataFrame({"t": t, "a [g]": np.zeros(t.size)}).to_csv(tmp_path / "rep.csv", index=False)
    with pytest.raises(CampaignError, match=r"rep.csv: time column 't', row 900: .* does not "
                                            r"increase"):
        import_campaign(tmp_path / "rep.csv", log, tool="7in", bit="CDE",
                        columns={"x1": "a", "time": "t"})


def test_stated_rate_is_checked(test3, tmp_path):
    with pytest.raises(CampaignError, match=r"says 1024 Hz, but the rate given is 1000 Hz"):
        _import(test3, test3.write_record(tmp_path / "r.csv"),
                test3.write_surface(tmp_path / "s.csv"), rate_hz=1000.0)


def test_record_in_two_pieces_with_a_gap(test3, tmp_path):
    rec = test3.record
    cut = len(rec) // 2
    rec.iloc[:cut].to_csv(tmp_path / "a.csv", index=False)
    rec.iloc[cut + 512:].to_csv(tmp_path / "b.csv", index=False)   # half a second lost
    surface = test3.write_surface(tmp_path / "s.csv")
    res = import_campaign([tmp_path / "b.csv", tmp_path / "a.csv"], surface, tool="7in",
                          bit="CDE", columns=test3.columns, units="m/s^2")
    assert len(res.record.pieces) == 2
    gap = (res.record.pieces[0].t1_s, res.record.pieces[1].t0_s)
    for st in res.stretches:
        if st.kept_s is not None:   # no event straddles the gap
            assert st.kept_s[1] <= gap[0] or st.kept_s[0] >= gap[1]


def test_size_limits_name_the_file_and_the_limit(test3, tmp_path, monkeypatch):
    record = test3.write_record(tmp_path / "r.csv")
    surface = test3.write_surface(tmp_path / "s.csv")
    monkeypatch.setattr(sources_module, "MAX_FILE_BYTES", 1000)
    with pytest.raises(CampaignError, match=r"r.csv: .* larger than the import's limit .*"
                                            r"MAX_FILE_BYTES"):
        _import(test3, record, surface)
    monkeypatch.undo()
    with pytest.raises(CampaignError, match=r"name: 201 characters, more than the import's "
                                            r"limit of 200"):
        _import(test3, record, surface, name="n" * 201)
    (tmp_path / "long.csv").write_text("time,a [g]\n" + "1," * 40_000 + "\n")
    with pytest.raises(CampaignError, match=r"long.csv: a line is longer than the import's "
                                            r"limit of 65536 characters"):
        import_campaign(tmp_path / "long.csv", surface, tool="7in", bit="CDE",
                        columns={"x1": "a"})


def test_missing_reader_package_is_named(test3, tmp_path, monkeypatch):
    las = test3.write_record(tmp_path / "r.las")
    real = importlib.import_module

    def no_lasio(name, *args, **kwargs):
        if name == "lasio":
            raise ImportError("No module named 'lasio'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(sources_module.importlib, "import_module", no_lasio)
    with pytest.raises(CampaignError, match=r"r.las: reading LAS files needs the Python "
                                            r"package 'lasio', which is not installed"):
        _import(test3, las, test3.write_surface(tmp_path / "s.csv"))
    assert builtins  # the import machinery itself is untouched


def test_unknown_format_and_binary_files_refused(test3, tmp_path):
    surface = test3.write_surface(tmp_path / "s.csv")
    (tmp_path / "r.bin").write_bytes(b"\x00" * 10)
    with pytest.raises(CampaignError, match=r"r.bin: unknown file type '.bin'"):
        _import(test3, tmp_path / "r.bin", surface)
    (tmp_path / "r2.csv").write_bytes(b"\xff\xfe\x00\x01\n")
    with pytest.raises(CampaignError, match=r"r2.csv, line 1: not UTF-8 text"):
        _import(test3, tmp_path / "r2.csv", surface)


def test_cli_import_then_show(test3, tmp_path, capsys):
    record = test3.write_record(tmp_path / "r.parquet")
    surface = test3.write_surface(tmp_path / "s.xlsx")
    out = tmp_path / "camp"
    argv = ["campaign", "import", str(record), "--surface", str(surface), "--out", str(out),
            "--tool", "7in", "--bit", "CDE", "--column", "x1=AccZ_bit", "--column",
            "x5=AccZ_mwd", "--quiet"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "\n3 events\n" in printed and "clock offset" in printed and "```" not in printed
    markdown = (out / "import.md").read_text()
    assert "## 3 events" in markdown and "![record, surface log" in markdown
    assert (out / "import.png").stat().st_size > 10_000
    camp = load_campaign(out)
    assert len(camp.events) == 3
    assert main(["campaign", "show", str(out)]) == 0
    shown = capsys.readouterr().out
    assert shown == campaign_text(camp) + "\n"
    for ev in camp.events:
        assert f"{ev.flow_gpm:12.1f}" in shown
    assert "clipped samples (x1, x5)" in shown
    assert main(argv[:-2] + ["x5=nope", "--quiet"]) == 2
    assert "no column 'nope' for sensor x5" in capsys.readouterr().err


def test_imported_synthetic_campaign_validates(test3, tmp_path):
    from vadsim.fit.validate import validate

    res = _import(test3, test3.write_record(tmp_path / "r.csv"),
                  test3.write_surface(tmp_path / "s.csv"), out=tmp_path / "camp")
    v = validate(load_campaign(tmp_path / "camp"), cycles=240, analyse_cycles=160,
                 progress=False)
    z = v.residuals.to_numpy(dtype=float)
    z = z[np.isfinite(z)]
    # the model wrote the record: through the sensor chain it matches it, feature by feature
    assert float(np.sqrt(np.mean(z ** 2))) < 1.0
    assert float(np.max(np.abs(z))) < 4.0
    assert res.folder == tmp_path / "camp"
