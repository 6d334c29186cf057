"""Hostile and careless campaign folders (issue 36, items 1 and 2): every input a campaign
brings is bounded before it is parsed, and the campaign file itself is confined to its folder.

Memory claims are checked in a child process by its own peak RSS (``ru_maxrss``): a count
budget, not a wall-clock one. The huge files are sparse or written in blocks, so the tests
themselves stay light.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from vadsim.campaigns import CampaignError, load_campaign
from vadsim.campaigns.format import (
    MAX_CSV_FIELD_BYTES,
    MAX_ID_CHARS,
    MAX_NAME_CHARS,
    MAX_RECORDING_S,
    MAX_TOML_BYTES,
    csv_limits,
)

PEAK_RSS_MB = 200
"""What refusing a hostile file may cost a whole ``vadsim validate`` process (peak RSS)."""

TOML = """name = "hostile"
tool = "7in"
bit = "CDE"
wob_klbf = 4.0

[sensors.x1]
dof = 1
rate_hz = 1024
range_g = 250

[[events]]
id = "e01"
flow_gpm = 200.0
file = "e01.csv"
"""


def _campaign(folder: Path, toml: str = TOML) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "campaign.toml").write_text(toml)
    return folder


def _good_csv(n: int = 3000) -> str:
    t = np.arange(n) / 1024
    a = np.sin(2 * np.pi * 20 * t)
    rows = (f"{ti:.7f},{float(ai)!r}\n" for ti, ai in zip(t, a, strict=True))
    return "time_s,x1_g\n" + "".join(rows)


def _validate_in_child(folder: Path) -> tuple[int, str, float]:
    """``vadsim validate FOLDER`` in a fresh process: its exit code, stderr and peak RSS (MB)."""
    # VmHWM is this process' own peak: ru_maxrss would carry over the parent's across exec
    code = ("import sys\nfrom vadsim.cli import main\n"
            f"rc = main(['validate', {str(folder)!r}, '--quiet', '--out', "
            f"{str(folder / 'report')!r}])\n"
            "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM:')][0]\n"
            "print(rc, int(hwm.split()[1]) / 1024)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600)
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    rc, rss = proc.stdout.split()[-2:]
    return int(rc), proc.stderr, float(rss)


def _write_blocks(path: Path, head: bytes, block: bytes, total: int, tail: bytes = b"") -> None:
    with path.open("wb") as f:
        f.write(head)
        for _ in range(total // len(block)):
            f.write(block)
        f.write(tail)


def test_one_line_csv_of_50_mb_is_refused_in_bounded_memory(tmp_path):
    """Issue 36: a header plus "1," 25 million times on one line took vadsim validate past
    10 GB and ended in a MemoryError traceback inside pandas."""
    folder = _campaign(tmp_path / "c")
    _write_blocks(folder / "e01.csv", b"time_s,x1_g\n", b"1," * (1 << 19), 50_000_000)
    rc, err, rss = _validate_in_child(folder)
    assert rc == 2
    assert "e01.csv" in err and "event 'e01'" in err and "line 2" in err
    assert f"longer than {csv_limits(1024, 2).max_line_bytes} bytes" in err, err
    assert rss < PEAK_RSS_MB, f"peak RSS {rss:.0f} MB"


def test_50_mb_of_newlines_is_refused_in_bounded_memory(tmp_path):
    """Issue 36: 50 MB of newlines took 2.7 GB."""
    folder = _campaign(tmp_path / "c")
    _write_blocks(folder / "e01.csv", b"time_s,x1_g\n0,0\n", b"\n" * (1 << 20), 50_000_000,
                  b"1,0\n")
    rc, err, rss = _validate_in_child(folder)
    assert rc == 2 and "e01.csv" in err
    limit = csv_limits(1024, 2).max_rows
    assert f"more than {limit} sample rows" in err, err
    assert rss < PEAK_RSS_MB, f"peak RSS {rss:.0f} MB"


def test_a_gigabyte_of_nul_bytes_is_refused_in_bounded_memory(tmp_path):
    """Issue 36: 1 GB of NUL bytes took 5.2 GB. The file is sparse: it costs no disk."""
    folder = _campaign(tmp_path / "c")
    with (folder / "e01.csv").open("wb") as f:
        f.truncate(1 << 30)
    rc, err, rss = _validate_in_child(folder)
    assert rc == 2 and "e01.csv" in err and "limit" in err, err
    assert rss < PEAK_RSS_MB, f"peak RSS {rss:.0f} MB"


def test_nul_bytes_under_the_size_limit_are_a_long_line(tmp_path):
    folder = _campaign(tmp_path / "c")
    with (folder / "e01.csv").open("wb") as f:
        f.truncate(1 << 20)
    with pytest.raises(CampaignError, match=r"e01\.csv.*line 1: longer than \d+ bytes"):
        load_campaign(folder)


def test_a_megabyte_campaign_name_is_refused_by_key(tmp_path):
    """Issue 36: a 1 MB ``name`` took 5 minutes and 832 MB (drawn into every figure title)."""
    folder = _campaign(tmp_path / "c", TOML.replace('"hostile"', '"' + "n" * 1_000_000 + '"'))
    (folder / "e01.csv").write_text(_good_csv())
    with pytest.raises(CampaignError, match=rf"campaign\.toml, line 1: key name: longer than "
                       rf"{MAX_NAME_CHARS} characters"):
        load_campaign(folder)


@pytest.mark.parametrize(("old", "new", "key"), [
    ('id = "e01"', 'id = "' + "e" * (MAX_ID_CHARS + 1) + '"', r"events\[0\]\.id"),
    ("[sensors.x1]", "[sensors." + "x" * (MAX_ID_CHARS + 1) + "]", "sensors"),
])
def test_ids_and_sensor_names_are_capped(tmp_path, old, new, key):
    folder = _campaign(tmp_path / "c", TOML.replace(old, new))
    with pytest.raises(CampaignError, match=rf"key {key}.*longer than {MAX_ID_CHARS} char"):
        load_campaign(folder)


def test_a_campaign_file_over_the_size_limit_is_refused_before_parsing(tmp_path):
    folder = _campaign(tmp_path / "c", TOML + "#" * MAX_TOML_BYTES + "\n")
    with pytest.raises(CampaignError, match=rf"campaign\.toml: .*larger than the limit of "
                       rf"{MAX_TOML_BYTES} bytes"):
        load_campaign(folder)


def test_a_csv_over_the_row_limit_is_refused(tmp_path):
    """The row limit is the recording length MAX_RECORDING_S at the sensors' rate."""
    toml = TOML.replace("rate_hz = 1024", "rate_hz = 1")
    folder = _campaign(tmp_path / "c", toml)
    rows = int(MAX_RECORDING_S) + 2
    (folder / "e01.csv").write_text("time_s,x1_g\n" + "".join(f"{i},0\n" for i in range(rows)))
    with pytest.raises(CampaignError, match=rf"e01\.csv \(event 'e01'\): more than "
                       rf"{int(MAX_RECORDING_S)} sample rows"):
        load_campaign(folder)


def test_a_long_cell_is_refused_but_padding_within_the_limit_is_read(tmp_path):
    folder = _campaign(tmp_path / "c")
    pad = " " * (MAX_CSV_FIELD_BYTES - 12)
    (folder / "e01.csv").write_text(_good_csv().replace("\n0.0009766,", f"\n0.0009766,{pad}"))
    camp = load_campaign(folder)
    assert camp.events[0].data is not None and len(camp.events[0].data) == 3000


def test_streamed_reading_gives_the_same_samples_and_line_numbers(tmp_path):
    """The CSV is read in chunks: a file longer than one chunk reads the same samples, and a
    bad value far into it is still named by its line."""
    folder = _campaign(tmp_path / "c")
    text = _good_csv(300_000)
    (folder / "e01.csv").write_text(text)
    data = load_campaign(folder).events[0].data
    assert data is not None and len(data) == 300_000
    t = np.arange(300_000) / 1024
    assert np.array_equal(data["x1_g"].to_numpy(), np.sin(2 * np.pi * 20 * t))
    lines = text.split("\n")
    lines[250_001] = lines[250_001].split(",")[0] + ",abc"
    (folder / "e01.csv").write_text("\n".join(lines))
    with pytest.raises(CampaignError, match=r"e01\.csv \(event 'e01'\), line 250002: column "
                       r"'x1_g': non-numeric value 'abc'"):
        load_campaign(folder)


# ------------------------------------------------------------------- the campaign file itself


def test_a_symlinked_campaign_file_leading_to_another_campaign_is_refused(tmp_path):
    """Issue 36: a symlinked campaign.toml was followed to a campaign outside (read, exit 0)."""
    outside = _campaign(tmp_path / "outside")
    (outside / "e01.csv").write_text(_good_csv())
    folder = tmp_path / "c"
    folder.mkdir()
    (folder / "campaign.toml").symlink_to(outside / "campaign.toml")
    (folder / "e01.csv").write_text(_good_csv())
    with pytest.raises(CampaignError, match=r"campaign\.toml.*leaves the campaign folder"):
        load_campaign(folder)
    with pytest.raises(CampaignError, match="leaves the campaign folder"):
        load_campaign(folder / "campaign.toml")
    assert load_campaign(folder, allow_outside=True).name == "hostile"


def test_a_campaign_file_linked_to_a_system_file_is_refused_unopened(tmp_path):
    """Issue 36: a campaign.toml linked to a system file was opened ("TOML syntax error")."""
    folder = tmp_path / "c"
    folder.mkdir()
    (folder / "campaign.toml").symlink_to("/etc/passwd")
    with pytest.raises(CampaignError, match="leaves the campaign folder") as err:
        load_campaign(folder)
    assert "syntax" not in str(err.value)


def test_the_cli_refuses_a_linked_campaign_file_unless_allowed(tmp_path, capsys):
    from vadsim.cli import main

    outside = _campaign(tmp_path / "outside", TOML.replace('file = "e01.csv"',
                                                           "features = { x1_impact_hz = 24.0 }"))
    folder = tmp_path / "c"
    folder.mkdir()
    (folder / "campaign.toml").symlink_to(outside / "campaign.toml")
    assert main(["validate", str(folder), "--quiet", "--out", str(tmp_path / "r")]) == 2
    assert "leaves the campaign folder" in capsys.readouterr().err


@pytest.mark.parametrize("which", ["campaign.toml", "e01.csv"])
def test_a_fifo_or_device_is_refused_not_read(tmp_path, which):
    """A named pipe never ends: reading one would hang the run; it is not a regular file."""
    folder = _campaign(tmp_path / "c")
    if which == "e01.csv":
        os.mkfifo(folder / "e01.csv")
    else:
        (folder / "campaign.toml").unlink()
        os.mkfifo(folder / "campaign.toml")
    with pytest.raises(CampaignError, match=rf"{which}.*not a regular file"):
        load_campaign(folder)


def test_a_device_linked_campaign_file_is_refused_even_when_outside_is_allowed(tmp_path):
    folder = tmp_path / "c"
    folder.mkdir()
    (folder / "campaign.toml").symlink_to("/dev/zero")
    with pytest.raises(CampaignError, match="not a regular file"):
        load_campaign(folder, allow_outside=True)


def test_limits_are_stated_in_the_docs(repository):
    docs = repository / "docs" / "RECORDINGS.md"
    text = docs.read_text()
    for value in (MAX_TOML_BYTES, MAX_NAME_CHARS, MAX_ID_CHARS, MAX_CSV_FIELD_BYTES):
        assert f"{value:,}" in text or str(value) in text, value
    assert json.dumps(int(MAX_RECORDING_S)) in text


def test_figures_cut_long_names_and_ids():
    """Issue 36: the campaign name was drawn into every figure title whole."""
    import matplotlib
    import pandas as pd
    from vadsim.plots import mismatch_heatmap
    from vadsim.plots.style import LABEL_CHARS, short_label

    matplotlib.use("Agg")
    assert short_label("a\nb  c") == "a b c"
    assert len(short_label("n" * 1_000_000)) == LABEL_CHARS
    table = pd.DataFrame({"x1_peak_mean_g": [0.5, -1.0]}, index=["e" * 5000, "short"])
    fig = mismatch_heatmap(table)
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert max(len(x) for x in labels) <= 40 and labels[1] == "short"
