"""The command line: every sub-command runs on a small case, errors exit 2 with a message."""

import json

import pytest
from vadsim.cli import main


def test_run_json(capsys):
    assert main(["run", "7in-cde", "--flow", "200", "600", "--cycles", "20", "--analyse",
                 "10", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["flow_gpm"] for r in out["runs"]] == [200.0, 600.0]
    assert out["runs"][0]["scenario"] in range(8)


def test_sweep_saves_and_plot_draws(tmp_path, capsys):
    nc = tmp_path / "s.nc"
    assert main(["sweep", "--flows", "200", "300", "100", "--cycles", "20", "--analyse", "10",
                 "--quiet", "--out", str(nc)]) == 0
    assert nc.stat().st_size > 0
    for kind in ("peaks", "z", "j"):
        png = tmp_path / f"{kind}.png"
        assert main(["plot", kind, str(nc), "--out", str(png)]) == 0
        assert png.stat().st_size > 1000
    png = tmp_path / "traces.png"
    assert main(["plot", "traces", "7in-cde", "--cycles", "10", "--analyse", "5",
                 "--out", str(png)]) == 0
    assert png.stat().st_size > 1000


def test_map_prints_counts(capsys):
    assert main(["map", "--param", "Fo", "--values", "250", "350", "--steps", "2",
                 "--flows", "200", "300", "100", "--cycles", "20", "--analyse", "10",
                 "--quiet"]) == 0
    assert "scenario counts" in capsys.readouterr().out


@pytest.mark.parametrize("argv, needle", [
    (["run", "--flow", "200", "--set", "kx=1"], "unknown parameter 'kx'"),
    (["run", "--flow", "-5"], "flow_gpm"),
    (["run", "no-such-tool"], "unknown preset"),
    (["plot", "compare", "only-one.nc"], "No such file"),
])
def test_errors_exit_2_with_a_message(argv, needle, capsys):
    assert main(argv) == 2
    assert needle in capsys.readouterr().err
