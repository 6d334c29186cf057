"""Tests of vadsim.campaigns: the campaign format of RECORDINGS.md.

Why so many small cases: the loader's value is that every kind of bad field file is caught and
named precisely (file + line or key), so each rule gets its own case, and a fuzz test checks
that arbitrary damage yields a CampaignError and nothing else.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import os
import re
import tempfile
import tomllib
import warnings
from collections.abc import Callable
from datetime import timedelta
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import vadsim
import vadsim.campaigns as rec
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vadsim.campaigns import (
    KNOWN_TOOLS,
    Campaign,
    CampaignError,
    ClippedSamplesWarning,
    Event,
    Sensor,
    campaign_preset,
    load_any_campaign,
    load_campaign,
    save_campaign,
    thesis_campaigns,
)
from vadsim.campaigns.format import excerpt

# Line numbers matter: the error cases below assert them.
VALID_TOML = """\
name = "base campaign"
tool = "7in"
bit = "CDE"
wob_klbf = 4.0

[sensors.x1]
dof = 1
rate_hz = 1024
range_g = 250
lowpass_hz = 400

[sensors.x5]
dof = 5
rate_hz = 1024
range_g = 250

[[events]]
id = "e01"
flow_gpm = 200.0
file = "e01.csv"

[[events]]
id = "e02"
flow_gpm = 250.0
wob_klbf = 5.0
features = { x1_peak_mean_g = 68.0, x1_impact_hz = 24.0 }
reference = { sim_peak_g = 89.0, note = "from the table" }

[[events]]
id = "e03"
flow_gpm = 300.0
file = "e03.csv"
features = { x5_peak_std_g = 3.5 }
"""

N_ROWS = 40


def _csv_text(seed: int, n: int = N_ROWS, rate: float = 1024.0, t0: float = 0.0) -> str:
    rng = np.random.default_rng(seed)
    t = (t0 + np.arange(n) / rate).tolist()
    a = rng.uniform(-100.0, 100.0, size=(n, 2)).round(3).tolist()
    rows = [f"{ti:.7f},{x1!r},{x5!r}" for ti, (x1, x5) in zip(t, a, strict=True)]
    return "time_s,x1_g,x5_g\n" + "\n".join(rows) + "\n"


def _valid_files() -> dict[str, bytes]:
    return {
        "campaign.toml": VALID_TOML.encode(),
        "e01.csv": _csv_text(1).encode(),
        "e03.csv": _csv_text(3, t0=12.5).encode(),
    }


def _write(folder: Path, files: dict[str, bytes]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in files.items():
        (folder / name).write_bytes(content)
    return folder


@pytest.fixture
def valid(tmp_path: Path) -> Path:
    return _write(tmp_path / "camp", _valid_files())


# --------------------------------------------------------------------------------------------
# Helpers to damage a valid folder in one precise way.


def _edit(name: str, fn: Callable[[str], str]) -> Callable[[Path], None]:
    def apply(folder: Path) -> None:
        path = folder / name
        path.write_text(fn(path.read_text()))

    return apply


def _toml_sub(old: str, new: str) -> Callable[[Path], None]:
    def fn(text: str) -> str:
        assert old in text, old
        return text.replace(old, new, 1)

    return _edit("campaign.toml", fn)


def _toml_drop_lines(first: int, last: int, prepend: str = "") -> Callable[[Path], None]:
    def fn(text: str) -> str:
        lines = text.split("\n")
        return prepend + "\n".join(lines[: first - 1] + lines[last:])

    return _edit("campaign.toml", fn)


def _csv_line(lineno: int, new: str | None, name: str = "e01.csv") -> Callable[[Path], None]:
    """Replace (or delete, when new is None) one 1-based line of an event CSV."""

    def fn(text: str) -> str:
        lines = text.split("\n")
        if new is None:
            del lines[lineno - 1]
        else:
            lines[lineno - 1] = new
        return "\n".join(lines)

    return _edit(name, fn)


def _csv_cell(lineno: int, col: int, value: str) -> Callable[[Path], None]:
    def fn(text: str) -> str:
        lines = text.split("\n")
        cells = lines[lineno - 1].split(",")
        cells[col] = value
        lines[lineno - 1] = ",".join(cells)
        return "\n".join(lines)

    return _edit("e01.csv", fn)


def _csv_replace(content: str, name: str = "e01.csv") -> Callable[[Path], None]:
    return _edit(name, lambda _text: content)


def _bytes_at(name: str, marker: bytes, insert: bytes) -> Callable[[Path], None]:
    def apply(folder: Path) -> None:
        path = folder / name
        data = path.read_bytes()
        path.write_bytes(data.replace(marker, marker + insert, 1))

    return apply


def _delete(name: str) -> Callable[[Path], None]:
    return lambda folder: (folder / name).unlink()


def _time_at(lineno: int, rate: float = 1024.0) -> str:
    return f"{(lineno - 2) / rate:.7f}"


# (id, damage, fragments the message must contain). Every case names the file and the line
# and/or the key.
BAD_CASES: list[tuple[str, Callable[[Path], None], list[str]]] = [
    ("missing-toml", _delete("campaign.toml"), ["campaign.toml", "missing"]),
    ("toml-syntax", _toml_sub("flow_gpm = 200.0", "flow_gpm = 200.0.0"),
     ["campaign.toml", "syntax", "line 19"]),
    ("toml-truncated-string", _toml_sub('name = "base campaign"', 'name = "base'),
     ["campaign.toml", "syntax", "line 1"]),
    ("toml-not-utf8", _bytes_at("campaign.toml", b"bit = ", b"\xff"),
     ["campaign.toml", "line 3", "UTF-8"]),
    ("missing-name", _toml_drop_lines(1, 1), ["campaign.toml", "key name", "missing"]),
    ("missing-tool", _toml_drop_lines(2, 2), ["campaign.toml", "key tool", "missing"]),
    ("missing-bit", _toml_drop_lines(3, 3), ["campaign.toml", "key bit", "missing"]),
    ("missing-sensors", _toml_drop_lines(6, 16), ["campaign.toml", "key sensors", "missing"]),
    ("missing-events", _toml_drop_lines(17, 40), ["campaign.toml", "key events", "missing"]),
    ("name-not-string", _toml_sub('name = "base campaign"', "name = 3"),
     ["campaign.toml", "line 1", "key name", "string"]),
    ("sensors-not-table", _toml_drop_lines(6, 16, prepend="sensors = 5\n"),
     ["campaign.toml", "key sensors", "table"]),
    ("sensors-empty", _toml_drop_lines(6, 16, prepend="sensors = {}\n"),
     ["campaign.toml", "key sensors", "at least one"]),
    ("events-not-array", _toml_drop_lines(17, 40, prepend='events = "x"\n'),
     ["campaign.toml", "key events", "array"]),
    ("events-empty", _toml_drop_lines(17, 40, prepend="events = []\n"),
     ["campaign.toml", "key events", "at least one"]),
    ("missing-dof", _toml_drop_lines(7, 7), ["campaign.toml", "sensors.x1.dof", "missing"]),
    ("dof-zero", _toml_sub("dof = 1", "dof = 0"), ["campaign.toml", "line 7", "sensors.x1.dof"]),
    ("dof-eight", _toml_sub("dof = 5", "dof = 8"), ["campaign.toml", "line 13",
                                                    "sensors.x5.dof"]),
    ("dof-float", _toml_sub("dof = 1", "dof = 1.5"), ["line 7", "sensors.x1.dof", "integer"]),
    ("dof-string", _toml_sub("dof = 1", 'dof = "1"'), ["line 7", "sensors.x1.dof", "integer"]),
    ("dof-bool", _toml_sub("dof = 1", "dof = true"), ["line 7", "sensors.x1.dof"]),
    ("rate-zero", _toml_sub("rate_hz = 1024", "rate_hz = 0"),
     ["campaign.toml", "line 8", "sensors.x1.rate_hz", "> 0"]),
    ("rate-negative", _toml_sub("rate_hz = 1024", "rate_hz = -1024"),
     ["line 8", "sensors.x1.rate_hz"]),
    ("rate-string", _toml_sub("rate_hz = 1024", 'rate_hz = "fast"'),
     ["line 8", "sensors.x1.rate_hz", "number"]),
    ("rate-nan", _toml_sub("rate_hz = 1024", "rate_hz = nan"), ["line 8", "sensors.x1.rate_hz"]),
    ("rate-huge-int", _toml_sub("rate_hz = 1024", "rate_hz = " + "9" * 400),
     ["line 8", "sensors.x1.rate_hz", "range"]),
    ("range-zero", _toml_sub("range_g = 250", "range_g = 0"),
     ["campaign.toml", "line 9", "sensors.x1.range_g"]),
    ("lowpass-zero", _toml_sub("lowpass_hz = 400", "lowpass_hz = 0"),
     ["line 10", "sensors.x1.lowpass_hz"]),
    ("lowpass-nyquist", _toml_sub("lowpass_hz = 400", "lowpass_hz = 512"),
     ["campaign.toml", "line 10", "sensors.x1.lowpass_hz", "Nyquist"]),
    ("lowpass-above", _toml_sub("lowpass_hz = 400", "lowpass_hz = 600"),
     ["line 10", "sensors.x1.lowpass_hz"]),
    ("sensor-bad-name", _toml_sub("[sensors.x5]", '[sensors."x 5"]'),
     ["campaign.toml", "line 12", "sensors"]),
    ("sensor-unknown-key", _toml_sub("lowpass_hz = 400", "lowpass = 400"),
     ["campaign.toml", "line 10", "sensors.x1.lowpass", "unknown key"]),
    ("unknown-top-key", _toml_sub('bit = "CDE"', 'bit = "CDE"\nbits = 1'),
     ["campaign.toml", "line 4", "key bits", "unknown key"]),
    ("unknown-bit", _toml_sub('bit = "CDE"', 'bit = "XYZ"'),
     ["campaign.toml", "line 3", "key bit", "XYZ", "CDE"]),
    ("bit-lowercase", _toml_sub('bit = "CDE"', 'bit = "cde"'), ["line 3", "key bit"]),
    ("unknown-tool", _toml_sub('tool = "7in"', 'tool = "5in"'),
     ["campaign.toml", "line 2", "key tool", "5in", "7in"]),
    ("missing-id", _toml_drop_lines(18, 18), ["campaign.toml", "line 17", "events[0].id"]),
    ("id-not-string", _toml_sub('id = "e01"', "id = 1"), ["line 18", "events[0].id", "string"]),
    ("duplicate-id", _toml_sub('id = "e03"', 'id = "e01"'),
     ["campaign.toml", "line 30", "events[2].id", "duplicate", "events[0]"]),
    ("flow-zero", _toml_sub("flow_gpm = 200.0", "flow_gpm = 0"),
     ["campaign.toml", "line 19", "events[0].flow_gpm", "'e01'", "> 0"]),
    ("flow-negative", _toml_sub("flow_gpm = 250.0", "flow_gpm = -250.0"),
     ["campaign.toml", "line 24", "events[1].flow_gpm", "'e02'"]),
    ("flow-nan", _toml_sub("flow_gpm = 200.0", "flow_gpm = nan"),
     ["line 19", "events[0].flow_gpm", "finite"]),
    ("flow-inf", _toml_sub("flow_gpm = 200.0", "flow_gpm = inf"), ["line 19", "flow_gpm"]),
    ("flow-string", _toml_sub("flow_gpm = 200.0", 'flow_gpm = "200"'),
     ["line 19", "events[0].flow_gpm", "number"]),
    ("flow-missing", _toml_drop_lines(19, 19), ["line 17", "events[0].flow_gpm", "missing"]),
    ("event-wob-zero", _toml_sub("wob_klbf = 5.0", "wob_klbf = 0.0"),
     ["campaign.toml", "line 25", "events[1].wob_klbf"]),
    ("campaign-wob-negative", _toml_sub("wob_klbf = 4.0", "wob_klbf = -4.0"),
     ["campaign.toml", "line 4", "key wob_klbf"]),
    ("wob-missing-no-default", _toml_drop_lines(4, 4),
     ["campaign.toml", "events[0].wob_klbf", "no default"]),
    ("event-not-table", _toml_drop_lines(17, 40, prepend="events = [1, 2]\n"),
     ["campaign.toml", "events[0]", "table"]),
    ("neither-file-nor-features", _toml_drop_lines(26, 26),
     ["campaign.toml", "line 22", "events[1]", "neither"]),
    ("event-unknown-key", _toml_sub("flow_gpm = 300.0", "flow_gpm = 300.0\nflow_gmp = 1.0"),
     ["campaign.toml", "line 32", "events[2].flow_gmp", "unknown key"]),
    ("feature-unknown-sensor", _toml_sub("x1_peak_mean_g = 68.0", "x9_peak_mean_g = 68.0"),
     ["campaign.toml", "line 26", "events[1].features.x9_peak_mean_g"]),
    ("feature-unknown-feature", _toml_sub("x1_impact_hz", "x1_rms_g"),
     ["campaign.toml", "line 26", "events[1].features.x1_rms_g"]),
    ("feature-no-sensor", _toml_sub("x5_peak_std_g", "peak_std_g"),
     ["campaign.toml", "line 33", "events[2].features.peak_std_g"]),
    ("feature-negative", _toml_sub("x1_impact_hz = 24.0", "x1_impact_hz = -24.0"),
     ["line 26", "events[1].features.x1_impact_hz", ">= 0"]),
    ("feature-string", _toml_sub("x1_impact_hz = 24.0", 'x1_impact_hz = "24"'),
     ["line 26", "events[1].features.x1_impact_hz", "number"]),
    ("features-not-table", _toml_sub("features = { x5_peak_std_g = 3.5 }", "features = 3"),
     ["line 33", "events[2].features", "table"]),
    ("reference-nested", _toml_sub('note = "from the table"', "note = [1]"),
     ["line 27", "events[1].reference.note"]),
    ("rates-differ", _toml_sub("dof = 5\nrate_hz = 1024", "dof = 5\nrate_hz = 2048"),
     ["campaign.toml", "line 14", "sensors.x5.rate_hz", "time_s"]),
    ("missing-csv", _toml_sub('file = "e01.csv"', 'file = "nofile.csv"'),
     ["campaign.toml", "line 20", "events[0].file", "nofile.csv", "not found"]),
    ("csv-is-folder", _toml_sub('file = "e01.csv"', 'file = "."'),
     ["campaign.toml", "line 20", "events[0].file"]),
    # Event CSVs
    ("csv-unexpected-column", _csv_line(1, "time_s,x1_g,x9_g"),
     ["e01.csv", "line 1", "unexpected column 'x9_g'"]),
    ("csv-missing-column", _csv_replace("time_s,x1_g\n0.0,1.0\n0.0009766,2.0\n"),
     ["e01.csv", "line 1", "missing column 'x5_g'"]),
    ("csv-no-time", _csv_line(1, "t,x1_g,x5_g"), ["e01.csv", "line 1", "time_s"]),
    ("csv-time-not-first", _csv_line(1, "x1_g,time_s,x5_g"), ["e01.csv", "line 1", "time_s"]),
    ("csv-duplicate-column", _csv_line(1, "time_s,x1_g,x1_g"),
     ["e01.csv", "line 1", "twice"]),
    ("csv-empty", _csv_replace(""), ["e01.csv", "line 1", "empty"]),
    ("csv-header-only", _csv_replace("time_s,x1_g,x5_g\n"), ["e01.csv", "line 2", "no samples"]),
    ("csv-one-sample", _csv_replace("time_s,x1_g,x5_g\n0.0,1.0,2.0\n"),
     ["e01.csv", "line 3", "at least 2"]),
    ("csv-non-numeric", _csv_cell(7, 1, "abc"), ["e01.csv", "line 7", "x1_g", "'abc'"]),
    ("csv-nan", _csv_cell(9, 2, "NaN"), ["e01.csv", "line 9", "x5_g", "NaN"]),
    ("csv-empty-cell", _csv_cell(9, 2, ""), ["e01.csv", "line 9", "x5_g", "missing"]),
    ("csv-inf", _csv_cell(9, 1, "inf"), ["e01.csv", "line 9", "x1_g", "infinite"]),
    ("csv-overflow", _csv_cell(9, 1, "1e999"), ["e01.csv", "line 9", "x1_g", "range"]),
    ("csv-nan-time", _csv_cell(12, 0, "nan"), ["e01.csv", "line 12", "time_s"]),
    ("csv-quoted", _csv_cell(6, 1, '"1.0"'), ["e01.csv", "line 6", "x1_g"]),
    ("csv-too-many-fields", _csv_line(5, _time_at(5) + ",1.0,2.0,3.0"),
     ["e01.csv", "line 5", "fields"]),
    ("csv-too-many-fields-first-row", _csv_line(2, _time_at(2) + ",1.0,2.0,3.0"),
     ["e01.csv", "line 2", "fields"]),
    ("csv-too-few-fields", _csv_line(5, _time_at(5) + ",1.0"), ["e01.csv", "line 5"]),
    ("csv-blank-line", _csv_line(5, ""), ["e01.csv", "line 5"]),
    ("csv-not-utf8", _bytes_at("e01.csv", _time_at(4).encode(), b"\xfe"),
     ["e01.csv", "line 4", "UTF-8"]),
    ("csv-time-repeated", _csv_cell(10, 0, _time_at(9)),
     ["e01.csv", "line 10", "strictly"]),
    ("csv-time-backwards", _csv_cell(10, 0, "0.0"), ["e01.csv", "line 10", "strictly"]),
    ("csv-dropped-sample", _csv_line(10, None), ["e01.csv", "line 10", "grid"]),
    ("csv-jitter", _csv_cell(15, 0, f"{13 / 1024 + 2e-6:.7f}"), ["e01.csv", "line 15", "grid"]),
    ("csv-wrong-rate", _csv_replace(_csv_text(1, rate=512.0)),
     ["e01.csv", "line 3", "1024 Hz", "means 512.0"]),
    ("csv-second-file", _edit("e03.csv", lambda t: t.replace("\n", "\nbad,1,2\n", 1)),
     ["e03.csv", "line 2", "time_s", "'bad'"]),
    # Digits and blanks of other scripts: Python's float() reads '١٢٣' as 123, the format
    # holds ASCII decimals only.
    ("csv-arabic-indic-digits", _csv_cell(7, 1, "\u0661\u0662\u0663"),
     ["e01.csv", "line 7", "x1_g", "non-numeric"]),
    ("csv-fullwidth-digits", _csv_cell(7, 2, "\uff11.\uff15"),
     ["e01.csv", "line 7", "x5_g", "non-numeric"]),
    ("csv-devanagari-time", _csv_cell(7, 0, "\u0966.\u0966\u0966\u096b"),
     ["e01.csv", "line 7", "time_s", "non-numeric"]),
    ("csv-no-break-space", _csv_cell(7, 1, "\u00a01.5"),
     ["e01.csv", "line 7", "x1_g", "non-numeric"]),
    # Booleans are not numbers, although Python's bool is an int.
    ("flow-bool", _toml_sub("flow_gpm = 200.0", "flow_gpm = true"),
     ["line 19", "events[0].flow_gpm", "'e01'", "number", "boolean"]),
    ("event-wob-bool", _toml_sub("wob_klbf = 5.0", "wob_klbf = true"),
     ["line 25", "events[1].wob_klbf", "number", "boolean"]),
    ("campaign-wob-bool", _toml_sub("wob_klbf = 4.0", "wob_klbf = false"),
     ["line 4", "key wob_klbf", "number", "boolean"]),
    ("rate-bool", _toml_sub("rate_hz = 1024", "rate_hz = true"),
     ["line 8", "sensors.x1.rate_hz", "number", "boolean"]),
    ("range-bool", _toml_sub("range_g = 250", "range_g = true"),
     ["line 9", "sensors.x1.range_g", "number", "boolean"]),
    ("lowpass-bool", _toml_sub("lowpass_hz = 400", "lowpass_hz = true"),
     ["line 10", "sensors.x1.lowpass_hz", "number", "boolean"]),
    ("feature-bool", _toml_sub("x1_impact_hz = 24.0", "x1_impact_hz = true"),
     ["line 26", "events[1].features.x1_impact_hz", "number", "boolean"]),
    # Integers beyond Python's digit limit for int(str): tomllib raises a plain ValueError.
    ("rate-int-beyond-digit-limit", _toml_sub("rate_hz = 1024", "rate_hz = " + "9" * 5000),
     ["campaign.toml"]),
]


@pytest.mark.parametrize(("damage", "fragments"), [(d, f) for _, d, f in BAD_CASES],
                         ids=[c[0] for c in BAD_CASES])
def test_bad_input_names_file_and_line_or_key(valid: Path, damage: Callable[[Path], None],
                                              fragments: list[str]) -> None:
    damage(valid)
    with pytest.raises(CampaignError) as info:
        load_campaign(valid)
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"


def test_valid_campaign_loads(valid: Path) -> None:
    c = load_campaign(valid)
    assert (c.name, c.tool, c.bit, c.wob_klbf) == ("base campaign", "7in", "CDE", 4.0)
    assert c.sensors["x1"] == Sensor("x1", 1, 1024.0, 250.0, 400.0)
    assert c.sensors["x5"] == Sensor("x5", 5, 1024.0, 250.0, None)
    assert [e.id for e in c.events] == ["e01", "e02", "e03"]
    e1, e2, e3 = c.events
    assert e1.wob_klbf == 4.0 and e2.wob_klbf == 5.0
    assert e2.data is None and e2.features == {"x1_peak_mean_g": 68.0, "x1_impact_hz": 24.0}
    assert e2.reference == {"sim_peak_g": 89.0, "note": "from the table"}
    assert e3.features == {"x5_peak_std_g": 3.5}
    assert list(e1.data.columns) == ["time_s", "x1_g", "x5_g"]
    assert e1.data.shape == (N_ROWS, 3) and e3.data["time_s"].iloc[0] == 12.5
    assert all(d == np.float64 for d in e1.data.dtypes)
    assert e1.n_clipped == 0 and set(e1.clipped) == {"x1", "x5"}
    # The toml file itself is accepted as the path too.
    assert load_campaign(valid / "campaign.toml") == c
    assert c.event("e03") is e3


def test_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(CampaignError, match="nowhere"):
        load_campaign(tmp_path / "nowhere")


def test_tolerated_variants(valid: Path) -> None:
    """Things a field file may legitimately do: CRLF, BOM, column order, trailing blanks."""
    text = (valid / "e01.csv").read_text()
    lines = text.strip().split("\n")
    swapped = [",".join([r.split(",")[0], r.split(",")[2], r.split(",")[1]]) for r in lines]
    (valid / "e01.csv").write_bytes(("\ufeff" + "\r\n".join(swapped) + "\r\n\r\n").encode())
    c = load_campaign(valid)
    reference = pd.read_csv(_write(valid.parent / "ref", _valid_files()) / "e01.csv")
    np.testing.assert_array_equal(c.events[0].data.to_numpy(), reference.to_numpy())


def test_time_at_printed_resolution_and_clock_drift(valid: Path) -> None:
    # 7-decimal rounding (5e-8 s) and a 0.5 ppm clock error are within the format's tolerance.
    t = (np.arange(5000) / 1024) * (1 + 5e-7)
    rows = "\n".join(f"{x:.7f},0.5,-0.5" for x in t)
    (valid / "e01.csv").write_text("time_s,x1_g,x5_g\n" + rows + "\n")
    assert load_campaign(valid).events[0].data.shape == (5000, 3)
    # 5 ppm is not: the error names the first sample off the grid.
    t = (np.arange(5000) / 1024) * (1 + 5e-6)
    rows = "\n".join(f"{x:.7f},0.5,-0.5" for x in t)
    (valid / "e01.csv").write_text("time_s,x1_g,x5_g\n" + rows + "\n")
    with pytest.raises(CampaignError, match=r"e01\.csv.*line \d+: .*grid"):
        load_campaign(valid)


def test_tool_preset_file(valid: Path, tmp_path: Path) -> None:
    (valid / "presets").mkdir()
    (valid / "presets" / "mytool.toml").write_text("l0 = 0.7\n")
    _toml_sub('tool = "7in"', 'tool = "presets/mytool.toml"')(valid)
    c = load_campaign(valid)
    assert c.tool == "presets/mytool.toml"
    # Saving elsewhere carries the preset along, so the copy still loads.
    out = save_campaign(c, tmp_path / "copy")
    assert (out / "presets" / "mytool.toml").read_text() == "l0 = 0.7\n"
    assert load_campaign(out) == c


def test_known_tools_constant() -> None:
    assert {"7in", "9.5in"} <= set(KNOWN_TOOLS)
    assert rec.KNOWN_BITS == ("CDE", "RC", "PDC")


# --------------------------------------------------------------------------------------------
# A campaign reads only files inside its own folder (unless allow_outside=True)

SECRET = "SECRET_VALUE_4f1c"
PRESET_TOML = 'name = "outside preset"\nbase = "7in-rc"\n'


@pytest.fixture
def outside(tmp_path: Path) -> Path:
    """A folder next to the campaign: a valid event CSV, a file with a secret, a preset."""
    out = tmp_path / "outside"
    out.mkdir()
    (out / "e01.csv").write_text(_csv_text(101))
    (out / "secret.csv").write_text(f"{SECRET},x1_g,x5_g\n")
    (out / "preset.toml").write_text(PRESET_TOML)
    return out


def _point_e01_outside(folder: Path, outside: Path, how: str) -> None:
    """Make event e01 of the campaign in ``folder`` name outside/e01.csv in one way."""
    if how == "dotdot":
        name = "../outside/e01.csv"
    elif how == "dotdot-via-subfolder":
        (folder / "sub").mkdir()
        name = "sub/../../outside/e01.csv"
    elif how == "absolute":
        name = str(outside / "e01.csv")
    elif how == "symlinked-file":
        (folder / "link.csv").symlink_to(outside / "e01.csv")
        name = "link.csv"
    elif how == "symlinked-folder":
        (folder / "data").symlink_to(outside, target_is_directory=True)
        name = "data/e01.csv"
    else:
        raise AssertionError(how)
    _toml_sub('file = "e01.csv"', f"file = {name!r}")(folder)


@pytest.mark.parametrize("how", ["dotdot", "dotdot-via-subfolder", "absolute", "symlinked-file",
                                 "symlinked-folder"])
def test_event_file_outside_the_folder_is_refused(valid: Path, outside: Path, how: str) -> None:
    _point_e01_outside(valid, outside, how)
    with pytest.raises(CampaignError) as info:
        load_campaign(valid)
    message = str(info.value)
    for fragment in ["campaign.toml", "line 20", "events[0].file", "'e01'",
                     "leaves the campaign folder"]:
        assert fragment in message, f"{fragment!r} not in {message!r}"
    # With the explicit flag the same file is read, and it is the outside one.
    c = load_campaign(valid, allow_outside=True)
    expected = pd.read_csv(outside / "e01.csv").to_numpy()
    np.testing.assert_array_equal(c.events[0].data.to_numpy(), expected)
    assert c.allow_outside


@pytest.mark.parametrize("name", ["../outside/secret.csv", "/proc/self/environ"])
def test_refusal_does_not_print_the_file(valid: Path, outside: Path, name: str) -> None:
    if not Path(name).is_absolute():
        assert (valid / name).is_file()
    elif not Path(name).exists():
        pytest.skip(f"{name} does not exist here")
    _toml_sub('file = "e01.csv"', f"file = {name!r}")(valid)
    with pytest.raises(CampaignError, match="leaves the campaign folder") as info:
        load_campaign(valid)
    message = str(info.value)
    assert SECRET not in message
    assert not [k for k, v in os.environ.items() if len(v) > 3 and f"{k}={v}" in message]
    assert len(message) < 500 + len(str(valid))


def test_symlink_inside_the_folder_is_fine(valid: Path) -> None:
    (valid / "sub").mkdir()
    (valid / "sub" / "alias.csv").symlink_to(valid / "e01.csv")
    _toml_sub('file = "e01.csv"', 'file = "sub/alias.csv"')(valid)
    c = load_campaign(valid)
    assert not c.allow_outside
    expected = pd.read_csv(valid / "e01.csv").to_numpy()
    np.testing.assert_array_equal(c.events[0].data.to_numpy(), expected)


def _point_tool_outside(folder: Path, outside: Path, how: str) -> None:
    if how == "absolute":
        name = str(outside / "preset.toml")
    elif how == "dotdot":
        name = "../outside/preset.toml"
    elif how == "symlinked-file":
        (folder / "mytool.toml").symlink_to(outside / "preset.toml")
        name = "mytool.toml"
    else:
        raise AssertionError(how)
    _toml_sub('tool = "7in"', f"tool = {name!r}")(folder)


@pytest.mark.parametrize("how", ["absolute", "dotdot", "symlinked-file"])
def test_tool_file_outside_the_folder_is_refused(valid: Path, outside: Path, how: str,
                                                 tmp_path: Path) -> None:
    _point_tool_outside(valid, outside, how)
    for load in (load_campaign, load_any_campaign):
        with pytest.raises(CampaignError) as info:
            load(valid)
        message = str(info.value)
        for fragment in ["campaign.toml", "line 2", "key tool", "leaves the campaign folder"]:
            assert fragment in message, f"{fragment!r} not in {message!r}"

    c = load_any_campaign(valid, allow_outside=True)
    assert c.allow_outside and campaign_preset(c).name == "outside preset"
    assert campaign_preset(c).bit == "RC"
    # campaign_preset checks again: the flag travels with the campaign, not with the folder.
    with pytest.raises(CampaignError, match="key tool.*leaves the campaign folder"):
        campaign_preset(dataclasses.replace(c, allow_outside=False))
    # Saving copies the preset in: the copy is self-contained and loads without the flag.
    with pytest.raises(CampaignError, match="key tool.*leaves the campaign folder"):
        save_campaign(dataclasses.replace(c, allow_outside=False), tmp_path / "refused")
    assert not (tmp_path / "refused").exists()
    copy = load_campaign(save_campaign(c, tmp_path / "copy"))
    assert copy.tool == (outside / "preset.toml").name
    assert (tmp_path / "copy" / copy.tool).read_text() == PRESET_TOML
    assert campaign_preset(copy).name == "outside preset"
    assert dataclasses.replace(copy, tool=c.tool) == c


def test_campaign_preset_without_root_stays_in_the_current_folder(
        valid: Path, outside: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(valid)
    c = dataclasses.replace(load_campaign(valid), root=None, tool=str(outside / "preset.toml"))
    with pytest.raises(CampaignError, match="key tool.*leaves the campaign folder"):
        campaign_preset(c)
    assert campaign_preset(dataclasses.replace(c, allow_outside=True)).name == "outside preset"
    (valid / "here.toml").write_text(PRESET_TOML)
    assert campaign_preset(dataclasses.replace(c, tool="here.toml")).name == "outside preset"
    assert campaign_preset(dataclasses.replace(c, tool="7in")).name == "7in-cde"


# --------------------------------------------------------------------------------------------
# Error messages quote at most ~80 characters of a file or a TOML value

HUGE = 200_000


def test_excerpt() -> None:
    assert excerpt("abc") == "'abc'"
    assert excerpt("a" * 80) == repr("a" * 80)
    assert excerpt("a" * 81) == "'" + "a" * 80 + "...' (81 characters)"
    assert excerpt("it's" * 100).endswith('..." (400 characters)')
    assert excerpt(12) == "12" and excerpt([1] * 5) == "[1, 1, 1, 1, 1]"
    assert excerpt([1] * 1000) == "[" + "1, " * 26 + "1... (3000 characters)"
    assert len(excerpt("\x00" * 1000)) < 400


LONG_CASES: list[tuple[str, Callable[[Path], None], list[str]]] = [
    # Lines beyond the line limit (RECORDINGS.md "Limits") are refused before parsing.
    ("csv-header-column", _csv_line(1, "time_s,x1_g," + "y" * HUGE),
     ["e01.csv", "line 1", "longer than 195 bytes"]),
    ("csv-first-column", _csv_line(1, "z" * HUGE + ",x1_g,x5_g"),
     ["e01.csv", "line 1", "longer than 195 bytes"]),
    ("csv-header-column-short", _csv_line(1, "time_s,x1_g," + "y" * 150),
     ["e01.csv", "line 1", "unexpected column", "(150 characters)"]),
    ("csv-token", _csv_cell(7, 1, "q" * HUGE), ["e01.csv", "line 7", "longer than"]),
    ("csv-token-short", _csv_cell(7, 1, "q" * 100), ["e01.csv", "line 7", "x1_g",
                                                     "non-numeric"]),
    # Also a long run of digits that is no number: the number check must fail quickly.
    ("csv-digits", _csv_cell(7, 1, "1" * HUGE + "x"), ["e01.csv", "line 7", "longer than"]),
    ("toml-bit", _toml_sub('bit = "CDE"', 'bit = "' + "X" * HUGE + '"'),
     ["campaign.toml", "line 3", "key bit", f"({HUGE} characters)"]),
    ("toml-name-array", _toml_sub('name = "base campaign"', "name = [" + "1," * HUGE + "]"),
     ["campaign.toml", "line 1", "key name", "string", "characters)"]),
    ("toml-key", _toml_sub('bit = "CDE"', 'bit = "CDE"\n' + "k" * HUGE + " = 1"),
     ["campaign.toml", "unknown key", f"({HUGE} characters)"]),
    ("toml-event-id", _toml_sub('id = "e01"\nflow_gpm = 200.0',
                                'id = "' + "e" * HUGE + '"\nflow_gpm = 0'),
     ["campaign.toml", "line 18", "events[0].id", f"longer than 64 characters ({HUGE})"]),
    ("toml-number", _toml_sub("rate_hz = 1024", "rate_hz = " + "9" * 4000),
     ["campaign.toml", "line 8", "sensors.x1.rate_hz", "range", "(4000 characters)"]),
    ("toml-file", _toml_sub('file = "e01.csv"', 'file = "' + "f" * HUGE + '"'),
     ["campaign.toml", "line 20", "events[0].file", f"({HUGE} characters)"]),
    ("toml-tool", _toml_sub('tool = "7in"', 'tool = "' + "t" * HUGE + '"'),
     ["campaign.toml", "line 2", "key tool", f"({HUGE} characters)"]),
    # A header with a long run of blanks: the scan for line numbers must stay linear.
    ("toml-sensor-name", _toml_sub("[sensors.x5]", '[sensors."x' + " " * HUGE + '5"]'),
     ["campaign.toml", "line 12", "sensors", f"({HUGE + 2} characters)", "longer than 64"]),
]


@pytest.mark.parametrize(("damage", "fragments"), [(d, f) for _, d, f in LONG_CASES],
                         ids=[c[0] for c in LONG_CASES])
def test_error_messages_quote_little(valid: Path, damage: Callable[[Path], None],
                                     fragments: list[str]) -> None:
    damage(valid)
    with pytest.raises(CampaignError) as info:
        load_campaign(valid)
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message[:2000]!r}"
    # The folder's path appears at most twice; everything else is short.
    assert len(message) < 600 + 2 * len(str(valid)), message[:2000]


def test_header_scan_finds_lines_of_spaced_and_quoted_headers(valid: Path) -> None:
    text = (valid / "campaign.toml").read_text()
    text = text.replace("[sensors.x5]", "  [ sensors . 'x5' ]  # the motor sensor")
    text = text.replace("[[events]]", '[[ "events" ]] # one event', 3)
    (valid / "campaign.toml").write_text(text.replace("dof = 5", "dof = 9"))
    with pytest.raises(CampaignError, match=r"line 13: key sensors\.x5\.dof"):
        load_campaign(valid)
    (valid / "campaign.toml").write_text(text.replace("flow_gpm = 300.0", "flow_gpm = -3"))
    with pytest.raises(CampaignError, match=r"line 31: key events\[2\]\.flow_gpm"):
        load_campaign(valid)


# --------------------------------------------------------------------------------------------
# Clipping


def test_clipped_samples_are_flagged_and_warned(valid: Path) -> None:
    _csv_cell(5, 1, "250.0")(valid)
    _csv_cell(6, 1, "-312.5")(valid)
    _csv_cell(7, 2, "249.999")(valid)  # just inside the range: trusted
    with pytest.warns(ClippedSamplesWarning) as record:
        c = load_campaign(valid)
    assert len(record) == 1
    message = str(record[0].message)
    assert "e01.csv" in message and "2 samples" in message and "x1: 2" in message
    ev = c.events[0]
    assert ev.n_clipped == 2
    assert np.flatnonzero(ev.clipped["x1"]).tolist() == [3, 4]  # lines 5, 6
    assert not ev.clipped["x5"].any()
    assert ev.clipped["x1"].dtype == bool and ev.clipped["x1"].shape == (N_ROWS,)
    # The values themselves are kept as recorded; the flag says not to trust them.
    assert ev.data["x1_g"].iloc[4] == -312.5


def test_no_warning_without_clipping(valid: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_campaign(valid)


# --------------------------------------------------------------------------------------------
# Round trip


def _random_campaign(seed: int) -> Campaign:
    rng = np.random.default_rng(seed)
    rate = float(rng.choice([256.0, 1024.0, 2000.0, 20000.0]))
    names = list(rng.choice(["x1", "x5", "bit_sub", "mwd-2", "X7"],
                            size=int(rng.integers(1, 5)), replace=False))
    sensors = {}
    for name in names:
        lowpass = float(rng.uniform(1, rate / 2 - 1)) if rng.random() < 0.5 else None
        sensors[name] = Sensor(name, dof=int(rng.integers(1, 8)), rate_hz=rate,
                               range_g=float(rng.choice([50.0, 250.0, 1e3])),
                               lowpass_hz=lowpass)
    wob_default = float(rng.uniform(1, 20)) if rng.random() < 0.7 else None
    decimals = max(7, math.ceil(math.log10(rate)) + 3)
    events = []
    for i in range(int(rng.integers(1, 6))):
        features = {}
        for name in names:
            for feat in rec.FEATURES:
                if rng.random() < 0.3:
                    features[f"{name}_{feat}"] = float(rng.uniform(0, 300))
        data = None
        has_data = rng.random() < 0.6 or not features
        if has_data:
            n = int(rng.integers(2, 400))
            t0 = float(rng.uniform(-10, 1000))
            # On the printed grid, so time round-trips exactly too (see the idempotence test).
            t = np.array([float(f"{x:.{decimals}f}") for x in t0 + np.arange(n) / rate])
            cols = {"time_s": t}
            for name in names:
                a = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 2.5, size=n)
                if rng.random() < 0.3:
                    a = a.astype(np.float32).astype(np.float64)
                cols[f"{name}_g"] = a
            data = pd.DataFrame(cols)
        reference = {}
        if rng.random() < 0.5:
            reference = {"sim_peak_g": float(rng.uniform(0, 100)), "n": int(rng.integers(-5, 5)),
                         "ok": bool(rng.random() < 0.5),
                         "text": 'quote " backslash \\ tab \t newline \n unicode µ°'}
        wob = wob_default if (wob_default is not None and rng.random() < 0.5) else float(
            rng.uniform(0.5, 30))
        events.append(Event(
            id=f"ev {i}/{seed}" if i == 0 else f"e{i:02d}",
            flow_gpm=float(rng.uniform(1, 1000)), wob_klbf=wob,
            file=(f"sub/e{i:02d}.csv" if i % 2 else f"e{i:02d}.csv") if has_data else None,
            features=features, data=data, reference=reference,
        ))
    return Campaign(name=f'random "{seed}"\n', tool=str(rng.choice(KNOWN_TOOLS)),
                    bit=str(rng.choice(rec.KNOWN_BITS)), wob_klbf=wob_default,
                    sensors=sensors, events=events, description="µ\\" if seed % 2 else "")


@pytest.mark.parametrize("seed", range(8))
def test_round_trip(tmp_path: Path, seed: int) -> None:
    original = _random_campaign(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ClippedSamplesWarning)
        loaded = load_campaign(save_campaign(original, tmp_path / "c"))
    assert loaded == original
    assert loaded.root == tmp_path / "c"
    for ev in loaded.events:
        if ev.data is not None:
            for name, sensor in loaded.sensors.items():
                expected = np.abs(ev.data[f"{name}_g"].to_numpy()) >= sensor.range_g
                np.testing.assert_array_equal(ev.clipped[name], expected)


def test_saved_toml_layout_and_content(tmp_path: Path) -> None:
    original = _random_campaign(5)
    text = (save_campaign(original, tmp_path / "c") / "campaign.toml").read_text()
    lines = text.split("\n")
    assert lines[0].startswith("# Field-test campaign")
    # One table per sensor and per event, so that errors in an edited copy get line numbers.
    assert [x for x in lines if x.startswith("[")] == (
        [f"[sensors.{name}]" for name in original.sensors] + ["[[events]]"] * len(original.events))
    doc = tomllib.loads(text)
    assert (doc["name"], doc["tool"], doc["bit"]) == (original.name, original.tool, original.bit)
    assert list(doc["sensors"]) == list(original.sensors)
    assert [e["id"] for e in doc["events"]] == [e.id for e in original.events]
    assert [e.get("features", {}) for e in doc["events"]] == [e.features for e in original.events]


AWKWARD = ['quote " and \'', "back\\slash \\u0041 \\n", "tab\tnewline\ncr\r crlf\r\n",
           "nul \x00 del \x7f esc \x1b", '"""triple"""', "\'\'\'", "# not a comment",
           "[[events]]", "  padded  ", "key = 1", "\u00b5\u00b0\u043a\u043b\u044e\u0447 \U0001f600",
           "\u2028 \ufeff", "x" * 300]


def test_round_trip_awkward_text(tmp_path: Path) -> None:
    data = pd.DataFrame({"time_s": [0.0, 0.5, 1.0], "x1_g": [1.0, -2.0, 3.0]})
    reference: dict[str, object] = {t: t for t in AWKWARD}
    reference |= {"": 1, "a.b": True, "x y": -0.0, "inf": math.inf, "big": 2**63 - 1}
    events = [Event("plain", 100.0, 4.0, file="plain.csv", data=data, reference=reference)]
    # names and ids within their limits (RECORDINGS.md "Limits"); the reference takes any text
    events += [Event(f"id {i} {t}"[:64], 100.0 + i, 4.0, features={"x1_peak_mean_g": 1.0},
                     reference={"text": t}) for i, t in enumerate(AWKWARD)]
    c = Campaign("\n".join(AWKWARD)[:200], "7in", "RC", None, {"x1": Sensor("x1", 1, 2.0, 250.0)},
                 events, description="".join(AWKWARD))
    loaded = load_campaign(save_campaign(c, tmp_path / "c"))
    assert loaded == c
    assert list(loaded.events[0].reference) == list(reference)
    assert math.copysign(1.0, loaded.events[0].reference["x y"]) == -1.0


def test_round_trip_off_grid_time_is_idempotent(tmp_path: Path) -> None:
    t = 0.123456789 + np.arange(3000) / 1024
    data = pd.DataFrame({"time_s": t, "x1_g": np.sin(t) * 1e-3 / 7})
    c = Campaign("c", "7in", "RC", 4.0, {"x1": Sensor("x1", 1, 1024.0, 250.0)},
                 [Event("a", 100.0, 4.0, file="a.csv", data=data)])
    first = load_campaign(save_campaign(c, tmp_path / "1"))
    got = first.events[0].data
    np.testing.assert_allclose(got["time_s"], t, rtol=0, atol=5.01e-8)
    np.testing.assert_array_equal(got["x1_g"], data["x1_g"])
    assert load_campaign(save_campaign(first, tmp_path / "2")) == first
    assert (tmp_path / "1" / "a.csv").read_text().split("\n")[1].startswith("0.1234568,")


def test_save_names_files_of_events_without_one(tmp_path: Path) -> None:
    data = pd.DataFrame({"time_s": [0.0, 0.5], "x1_g": [1.0, 2.0]})
    c = Campaign("c", "9.5in", "PDC", None, {"x1": Sensor("x1", 1, 2.0, 250.0)},
                 [Event("run 1", 560.0, 8.0, data=data)])
    out = save_campaign(c, tmp_path / "c")
    loaded = load_campaign(out)
    assert loaded.events[0].file == "run_1.csv"
    assert (out / "run_1.csv").is_file()
    np.testing.assert_array_equal(loaded.events[0].data.to_numpy(), data.to_numpy())


@pytest.mark.parametrize("case", ["bit", "file-without-data", "no-file-no-features",
                                  "bad-columns", "nan", "time", "same-file", "sensor-name",
                                  "file-is-campaign-toml"])
def test_save_refuses_what_would_not_load(tmp_path: Path, case: str) -> None:
    data = pd.DataFrame({"time_s": [0.0, 0.5, 1.0], "x1_g": [1.0, 2.0, 3.0]})
    sensors = {"x1": Sensor("x1", 1, 2.0, 250.0)}
    events = [Event("a", 100.0, 4.0, file="a.csv", data=data)]
    bit = "CDE"
    if case == "bit":
        bit = "XYZ"
    elif case == "file-without-data":
        events = [Event("a", 100.0, 4.0, file="a.csv")]
    elif case == "no-file-no-features":
        events = [Event("a", 100.0, 4.0)]
    elif case == "bad-columns":
        events[0].data = data.rename(columns={"x1_g": "x2_g"})
    elif case == "nan":
        events[0].data = data.assign(x1_g=[1.0, np.nan, 3.0])
    elif case == "time":
        events[0].data = data.assign(time_s=[0.0, 0.5, 1.5])
    elif case == "same-file":
        events.append(Event("b", 200.0, 4.0, file="a.csv", data=data))
    elif case == "sensor-name":
        sensors = {"x1": Sensor("x2", 1, 2.0, 250.0)}
    elif case == "file-is-campaign-toml":
        events[0].file = "campaign.toml"
    with pytest.raises(CampaignError):
        save_campaign(Campaign("c", "7in", bit, None, sensors, events), tmp_path / "c")
    # Checked before writing: nothing half-written is left behind.
    assert not (tmp_path / "c").exists() or not any((tmp_path / "c").iterdir())


# --------------------------------------------------------------------------------------------
# Thesis campaigns


def _field_table() -> list[dict[str, str]]:
    from vadsim.data import thesis_rows

    return thesis_rows("field_events.csv")


def test_thesis_campaigns_counts_and_setup() -> None:
    camps = thesis_campaigns()
    assert list(camps) == ["7in-cde", "7in-rc", "9.5in-pdc"]
    assert [len(c.events) for c in camps.values()] == [10, 6, 12]
    for key, c in camps.items():
        tool, bit = key.split("-")
        assert (c.tool, c.bit.lower()) == (tool, bit)
        assert c.sensors == {"x1": Sensor("x1", 1, 1024.0, 250.0),
                             "x5": Sensor("x5", 5, 1024.0, 250.0)}
        assert all(e.data is None and e.file is None for e in c.events)
    assert {e.wob_klbf for e in camps["7in-cde"].events} == {4.0}
    assert {e.wob_klbf for e in camps["9.5in-pdc"].events} == {8.0}


def test_thesis_campaigns_match_the_field_table() -> None:
    camps = thesis_campaigns()
    rows = _field_table()
    assert len(rows) == 28
    for row in rows:
        c = camps[f"{row['tool']}-{row['bit'].lower()}"]
        ev = c.event(f"e{int(row['event']):02d}")
        assert ev.flow_gpm == float(row["flow_gpm"])
        assert ev.wob_klbf == float(row["wob_klbf"])
        expected = {"x1_peak_mean_g": float(row["field_peak_g"])}
        if row["field_impact_hz"]:
            expected["x1_impact_hz"] = float(row["field_impact_hz"])
        assert ev.features == expected
        assert ev.reference["field_behaviour"] == row["field_behaviour"]
        assert ev.reference["sim_behaviour"] == row["sim_behaviour"]
        assert ev.reference["sim_peak_g"] == float(row["sim_peak_g"])
        if row["sim_impact_hz"]:
            assert ev.reference["sim_impact_hz"] == float(row["sim_impact_hz"])
        else:
            assert "sim_impact_hz" not in ev.reference


def test_thesis_campaign_spot_values() -> None:
    camps = thesis_campaigns()
    e1 = camps["7in-cde"].event("e01")
    assert (e1.flow_gpm, e1.features) == (200.0, {"x1_peak_mean_g": 65.0, "x1_impact_hz": 20.0})
    assert e1.reference["sim_peak_g"] == 67.0 and e1.reference["sim_impact_hz"] == 21.0
    e3 = camps["7in-cde"].event("e03")
    assert e3.features == {"x1_peak_mean_g": 49.0} and "31.2" in e3.reference["note"]
    e12 = camps["7in-rc"].event("e12")
    assert e12.features == {"x1_peak_mean_g": 87.0, "x1_impact_hz": 29.0}
    e8 = camps["9.5in-pdc"].event("e08")
    assert (e8.flow_gpm, e8.reference["sim_peak_g"]) == (710.0, 4.0)
    assert e8.reference["sim_behaviour"] == "periodic 1 impact/cycle"


def test_thesis_campaigns_are_fresh_copies() -> None:
    a = thesis_campaigns()
    a["7in-cde"].events.clear()
    assert len(thesis_campaigns()["7in-cde"].events) == 10


def test_shipped_thesis_campaigns_are_up_to_date(tmp_path: Path) -> None:
    script = Path(vadsim.__file__).parent / "data" / "make_thesis_campaigns.py"
    spec = importlib.util.spec_from_file_location("make_thesis_campaigns", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(tmp_path)
    shipped = Path(vadsim.__file__).parent / "data" / "campaigns"
    for key in rec.THESIS_CAMPAIGNS:
        assert ((tmp_path / key / "campaign.toml").read_text()
                == (shipped / key / "campaign.toml").read_text()), key


# --------------------------------------------------------------------------------------------
# Fuzz: any damage gives a Campaign or a CampaignError, never another exception.

_BASE = _valid_files()
_FILES = sorted(_BASE)
_CSVS = [f for f in _FILES if f.endswith(".csv")]
_TOML_NUMBER = re.compile(rb"(?<![\w.\-])-?\d+(?:\.\d+)?(?![\w.])")
_TOML_STRING = re.compile(rb'"[^"\n]*"')
_TOML_VALUES = [b'"abc"', b"nan", b"-5", b"0", b"1e400", b"-inf", b"true", b"[1, 2]",
                b"{ a = 1 }", b"9" * 40, b'""', b"1979-05-27", b"'x1'", b"-0.0", b"{}",
                b'"7in"', b'"../../etc/passwd"', b'"\\u0000"', b'"' + b"a" * 300 + b'"']
_CSV_VALUES = [b"abc", b"nan", b"", b"-1e308", b"1e999", b"1,2", b'"', b"\x00", b"inf",
               b"250", b"-250", b"0x10", b"1_0", b" ", b"\n", b"1e-320", b"\r", b"NA"]


def _mutate(files: dict[str, bytes], op: tuple) -> None:
    kind = op[0]
    if kind == "truncate":
        _, name, frac = op
        if name in files:
            files[name] = files[name][: int(frac * len(files[name]))]
    elif kind in ("toml_number", "toml_string"):
        _, k, value = op
        pattern = _TOML_NUMBER if kind == "toml_number" else _TOML_STRING
        text = files.get("campaign.toml", b"")
        matches = list(pattern.finditer(text))
        if matches:
            m = matches[k % len(matches)]
            files["campaign.toml"] = text[: m.start()] + value + text[m.end():]
    elif kind == "delete_line":
        _, name, frac = op
        if name in files:
            lines = files[name].split(b"\n")
            del lines[int(frac * (len(lines) - 1))]
            files[name] = b"\n".join(lines)
    elif kind == "duplicate_line":
        _, name, frac = op
        if name in files:
            lines = files[name].split(b"\n")
            i = int(frac * (len(lines) - 1))
            lines.insert(i, lines[i])
            files[name] = b"\n".join(lines)
    elif kind == "csv_cell":
        _, name, frac, col, value = op
        if name in files:
            lines = files[name].split(b"\n")
            i = int(frac * (len(lines) - 1))
            cells = lines[i].split(b",")
            cells[col % len(cells)] = value
            lines[i] = b",".join(cells)
            files[name] = b"\n".join(lines)
    elif kind == "bytes":
        _, name, frac, blob = op
        if name in files:
            data = files[name]
            i = int(frac * len(data))
            files[name] = data[:i] + blob + data[i + len(blob):]
    elif kind == "delete_file":
        files.pop(op[1], None)


_fracs = st.floats(0, 1, allow_nan=False)
_op = st.one_of(
    st.tuples(st.just("truncate"), st.sampled_from(_FILES), _fracs),
    st.tuples(st.just("toml_number"), st.integers(0, 100), st.sampled_from(_TOML_VALUES)),
    st.tuples(st.just("toml_string"), st.integers(0, 100), st.sampled_from(_TOML_VALUES)),
    st.tuples(st.just("delete_line"), st.sampled_from(_FILES), _fracs),
    st.tuples(st.just("duplicate_line"), st.sampled_from(_FILES), _fracs),
    st.tuples(st.just("csv_cell"), st.sampled_from(_CSVS), _fracs, st.integers(0, 3),
              st.sampled_from(_CSV_VALUES)),
    st.tuples(st.just("bytes"), st.sampled_from(_FILES), _fracs, st.binary(min_size=1,
                                                                          max_size=6)),
    st.tuples(st.just("delete_file"), st.sampled_from(_FILES)),
)


@settings(max_examples=250, deadline=timedelta(seconds=2),
          suppress_health_check=[HealthCheck.too_slow])
@given(ops=st.lists(_op, min_size=1, max_size=3))
def test_fuzz_damaged_campaign_gives_campaign_or_campaign_error(ops: list[tuple]) -> None:
    files = dict(_BASE)
    for op in ops:
        _mutate(files, op)
    with tempfile.TemporaryDirectory() as tmp:
        folder = _write(Path(tmp) / "c", files)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ClippedSamplesWarning)
            try:
                result = load_campaign(folder)
            except CampaignError as exc:
                assert str(exc)
            else:
                assert isinstance(result, Campaign)
