"""The command line: every sub-command runs on a small case, errors exit 2 with a message."""

import json

import pytest
from vadsim.cli import build_parser, main


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


def _subcommands(parser):
    """{name: sub-parser} of ``vadsim``'s sub-commands."""
    [sub] = [a for a in parser._actions if isinstance(a.choices, dict)]
    return sub.choices


def _actions(parser, flag):
    return [a for a in parser._actions if flag in a.option_strings]


def test_version_prints_the_package_version(capsys):
    import vadsim

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"vadsim {vadsim.__version__}\n"


def test_preset_after_flow_is_the_preset_not_a_flow(capsys):
    assert main(["run", "--flow", "200", "7in-rc", "--cycles", "20", "--analyse", "10",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["preset"] == "7in-rc"
    assert [r["flow_gpm"] for r in out["runs"]] == [200.0]
    args = build_parser().parse_args(["run", "--flow", "200", "250", "9.5in-pdc"])
    assert (args.flow, args.flow_preset) == ([200.0, 250.0], "9.5in-pdc")


def test_two_presets_or_words_among_flows_are_errors(capsys):
    assert main(["run", "7in-cde", "--flow", "200", "7in-rc"]) == 2
    assert "two presets" in capsys.readouterr().err
    for argv in (["run", "--flow", "7in-rc"], ["run", "--flow", "200", "7in-rc", "300"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        assert "argument --flow" in capsys.readouterr().err


def test_plot_pdf_writes_one_pdf_per_figure(tmp_path, capsys):
    base = tmp_path / "x.pdf"
    assert main(["sweep", "--flows", "200", "300", "100", "--cycles", "20", "--analyse", "10",
                 "--quiet", "--plot", str(base)]) == 0
    out = capsys.readouterr().out
    for kind in ("peaks", "z", "j"):
        pdf = tmp_path / f"x-{kind}.pdf"
        assert pdf.read_bytes()[:5] == b"%PDF-"
        assert f"figure {pdf}" in out
    assert not base.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x-j.pdf", "x-peaks.pdf", "x-z.pdf"]


def test_plot_name_must_be_a_figure_format(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["sweep", "--plot", "x.jpg"])
    assert exc.value.code == 2
    assert "must end in" in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--wob", "--wob-klbf"])
def test_wob_is_an_alias_of_wob_klbf(flag, capsys):
    for command in ("run", "sweep", "map --param Fo --values 1 2"):
        args = build_parser().parse_args([*command.split(), flag, "30"])
        assert args.wob_klbf == 30.0
        assert "wob" not in vars(args)
    assert main(["run", "--flow", "200", "--cycles", "20", "--analyse", "10", flag, "25"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "25 klbf" in lines[0]


def test_wob_and_wob_klbf_give_the_same_run(capsys):
    rows = []
    for flag in ("--wob", "--wob-klbf"):
        assert main(["run", "--flow", "200", "--cycles", "20", "--analyse", "10", flag, "25",
                     "--json"]) == 0
        rows.append(json.loads(capsys.readouterr().out)["runs"])
    assert rows[0] == rows[1]


def test_jobs_is_a_hidden_alias_of_workers(capsys):
    parser = build_parser()
    assert parser.parse_args(["run"]).workers == 2
    assert parser.parse_args(["run", "--jobs", "3"]).workers == 3
    assert parser.parse_args(["run", "--workers", "3"]).workers == 3
    assert "--jobs" not in _subcommands(parser)["run"].format_help()


def test_set_and_cycles_are_declared_once_and_shared():
    subs = _subcommands(build_parser())
    sets = {name: _actions(p, "--set") for name, p in subs.items() if _actions(p, "--set")}
    assert set(sets) == {"run", "sweep", "map", "validate", "calibrate", "diagnose"}
    assert all(len(a) == 1 for a in sets.values())
    assert len({id(a[0]) for a in sets.values()}) == 1  # one Action object: the parent's
    cycles = {name: _actions(p, "--cycles")[0] for name, p in subs.items()
              if _actions(p, "--cycles")}
    assert cycles["diagnose"].default == 300
    assert {a.default for n, a in cycles.items() if n != "diagnose"} == {400}
    assert len({id(a) for n, a in cycles.items() if n != "diagnose"}) == 1


def test_set_and_cycles_appear_once_in_the_cli_source():
    import ast
    from pathlib import Path

    import vadsim.cli

    declared = []
    for path in Path(vadsim.cli.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
                declared += [(a.value, path.name) for a in node.args
                             if isinstance(a, ast.Constant)]
    assert [d for d in declared if d[0] == "--set"] == [("--set", "common.py")]
    assert [d for d in declared if d[0] == "--cycles"] == [("--cycles", "common.py")]
    assert [d[1] for d in declared if d[0] == "--workers"] == ["common.py"]


def test_figure_path_keeps_the_suffix():
    from vadsim.cli.common import figure_path

    assert figure_path("x.png", "peaks") == "x-peaks.png"
    assert figure_path("out/fig.svg", "map-j") == "out/fig-map-j.svg"
    assert figure_path("a.b/x.pdf", "z") == "a.b/x-z.pdf"


def test_map_values_need_from_to_step(capsys) -> None:
    """A wrong number of --values is a named error (exit 2), not a TypeError traceback."""
    assert main(["map", "--param", "kS", "--values", "1", "2", "3", "4", "--quiet"]) == 2
    assert "--values 1 2 3 4: expected FROM TO STEP" in capsys.readouterr().err
    assert main(["map", "--param", "kS", "--values", "1", "2", "3", "--steps", "4"]) == 2


def test_campaign_outside_its_folder_needs_allow_outside(tmp_path, capsys) -> None:
    """A campaign whose event file lies outside its folder is refused (exit 2, naming the
    key) unless --allow-outside is given."""
    from vadsim.campaigns import save_campaign
    from vadsim.campaigns.synthetic import synthetic_campaign

    camp = synthetic_campaign("7in-cde", (200.0, 400.0, 600.0), cycles=60, analyse_cycles=40)
    folder = save_campaign(camp, tmp_path / "camp")
    (folder / "e01.csv").rename(tmp_path / "e01.csv")
    toml = folder / "campaign.toml"
    toml.write_text(toml.read_text().replace('"e01.csv"', '"../e01.csv"'))
    args = ["validate", str(folder), "--cycles", "60", "--analyse", "40", "--quiet",
            "--out", str(tmp_path / "rep")]
    assert main(args) == 2
    assert "leaves the campaign folder" in capsys.readouterr().err
    assert main([*args, "--allow-outside"]) == 0


def test_blind_lists_classes_and_refuses_an_unknown_one(capsys, tmp_path):
    """--list prints every class with its count and runs nothing; an unknown class exits 2
    before a folder is made."""
    from vadsim.blind import DEFAULT_SCENARIOS, class_counts

    assert main(["blind", "--list"]) == 0
    out = capsys.readouterr().out
    for name, n in class_counts().items():
        assert f"{name}" in out and f" {n} " in out
    assert "total" in out and str(len(DEFAULT_SCENARIOS)) in out
    assert main(["blind", "--out", str(tmp_path / "x"), "--classes", "pair,foo"]) == 2
    assert "unknown blind class(es) foo" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_map_json_gives_a_record_per_point_and_says_which_an_adaptive_map_ran(capsys):
    args = ["map", "--param", "gap_ratio", "--values", "0.85", "1.5", "--steps", "5",
            "--flows", "200", "650", "90", "--cycles", "40", "--analyse", "20", "--quiet",
            "--json"]
    assert main(args) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == 5 * 6 and {"gap_ratio", "flow_gpm", "scenario", "j_pos"} <= set(rows[0])
    bigger = [*args[:7], "9", "--flows", "200", "650", "30", *args[12:]]
    assert main([*bigger, "--adaptive", "--coarse", "4"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == 9 * 16 and all(isinstance(r["simulated"], bool) for r in rows)
    assert 0 < sum(r["simulated"] for r in rows) < 9 * 16


def test_optimise_with_sample_maximises_the_robust_objective(monkeypatch, capsys):
    """``design optimise --sample N`` is the robust optimiser over N constants, not the
    single-point one."""
    import vadsim.studies.robust as robust

    seen = {}

    def stop(preset, n_sample, **kw):
        seen["n"] = n_sample
        raise RuntimeError("robust optimiser reached")

    monkeypatch.setattr(robust, "robust_optimise", stop)
    with pytest.raises(RuntimeError, match="robust optimiser reached"):
        main(["design", "optimise", "--sample", "9", "--quiet"])
    assert seen == {"n": 9}


def test_a_study_with_sample_is_judged_over_the_constants(tmp_path, capsys):
    """``design force --sample N`` goes to the sample, not to the single-point study."""
    out = tmp_path / "force.csv"
    assert main(["design", "force", "--sample", "1", "--steps", "2", "--cycles", "20",
                 "--analyse", "10", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "over 1 points of the plausible (theta0, gap) region" in text
    assert "j_max_worst" in out.read_text() and out.read_text().count("\n") == 3
