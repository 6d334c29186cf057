"""Errors that name the right thing (issue 36, item 5): every public argument checked by name
and type at the boundary, and campaign-level errors naming the key, the event and the file."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import vadsim
from vadsim.campaigns import CampaignError, load_campaign
from vadsim.model.presets import load_preset_file, make_params

SHORT = dict(cycles=20, analyse_cycles=10, record="none")

TOML = """name = "c"
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
features = { x1_peak_mean_g = 60.0 }
"""


@pytest.mark.parametrize(("kwargs", "pattern"), [
    # issue 36: AttributeError
    ({"overrides": [("kS", 1.0)]}, r"overrides .*must be a mapping"),
    # issue 36: TypeError
    ({"extras": None}, r"extras = None must be a sequence"),
    ({"extras": "hydraulic"}, r"extras = 'hydraulic' must be a sequence"),
    # issue 36: OverflowError
    ({"overrides": {"k6": 10**400}}, r"parameter k6 = .* too large for a double"),
    ({"flow_gpm": 10**400}, r"flow_gpm = .* too large for a double"),
    ({"wob_klbf": 10**400}, r"wob_klbf = .* too large for a double"),
    ({"cycles": 10**400}, r"cycles = .* too large for a double"),
    # issue 36: strings were taken as numbers in overrides, refused as a flow
    ({"overrides": {"kS": "4.7e5"}}, r"parameter kS = '4.7e5' is not a number"),
    ({"overrides": {"kS": b"4.7e5"}}, r"parameter kS = b'4.7e5' is not a number"),
    ({"overrides": {1: 2.0}}, r"overrides: parameter names are strings, got 1"),
    # issue 36: law="" was accepted as the preset's law
    ({"law": ""}, r"unknown contact law ''"),
    ({"law": 3}, r"law = 3 must be"),
    # issue 36: wob_klbf=1e9 named `wob`
    ({"wob_klbf": 1e9}, r"wob_klbf = 1e\+09"),
])
def test_simulate_names_the_bad_argument(kwargs, pattern):
    args = {"flow_gpm": 200.0, **SHORT, **kwargs}
    with pytest.raises(ValueError, match=pattern):
        vadsim.simulate("7in-cde", **args)


def test_make_params_refuses_what_simulate_refuses():
    with pytest.raises(ValueError, match="overrides .*must be a mapping"):
        make_params("7in-cde", [("kS", 1.0)])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown contact law ''"):
        make_params("7in-cde", law="")


def test_run_settings_name_a_bad_override():
    with pytest.raises(ValueError, match=r"parameter kS = 'x' is not a number"):
        vadsim.RunSettings("7in-cde", overrides={"kS": "x"})
    with pytest.raises(ValueError, match=r"overrides .*must be a mapping"):
        vadsim.RunSettings("7in-cde", overrides=[("kS", 1.0)])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"extras = None must be a sequence"):
        vadsim.RunSettings("7in-cde", extras=None)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------ presets files


def test_a_preset_file_not_utf8_is_named(tmp_path):
    """Issue 36: a non-UTF-8 preset file gave a codec error without its name."""
    path = tmp_path / "p.toml"
    path.write_bytes(b'name = "x"\nnote = "\xff\xfe"\n')
    with pytest.raises(ValueError, match=rf"preset file {path}, line 2: not valid UTF-8"):
        load_preset_file(path)


@pytest.mark.parametrize(("text", "pattern"), [
    ('base = ["7in-cde"]', r"key base: must be a preset name \(a string\), got array"),  # #36
    ('base = "nope"', r"key base: unknown preset 'nope'"),
    ("wob_klbf = true", r"key wob_klbf: must be a number"),
    ('wob_klbf = "4"', r"key wob_klbf: must be a number"),
    ("law = 1", r"key law: must be a string"),
    ("name = 1", r"key name: must be a string"),
    ("params = 1", r"\[params\] must be a table"),
    ('[params]\nkS = "4e5"', r"parameter kS = '4e5' is not a number"),
])
def test_a_preset_file_names_the_bad_key(tmp_path, text, pattern):
    path = tmp_path / "p.toml"
    path.write_text(text + "\n")
    with pytest.raises(ValueError, match=rf"preset file {path}.*{pattern}"):
        load_preset_file(path)


def test_a_preset_file_must_be_a_regular_file_within_the_size_limit(tmp_path):
    big = tmp_path / "big.toml"
    big.write_text("#" * (2 << 20))
    with pytest.raises(ValueError, match=r"big\.toml.*larger than the limit"):
        load_preset_file(big)
    link = tmp_path / "dev.toml"
    link.symlink_to("/dev/zero")
    with pytest.raises(ValueError, match=r"dev\.toml.*not a regular file"):
        load_preset_file(link)


# --------------------------------------------------------------------------------- campaigns


def _campaign(folder: Path, toml: str) -> Path:
    folder.mkdir()
    (folder / "campaign.toml").write_text(toml)
    return folder


def test_a_huge_wob_is_refused_by_key_event_and_file(tmp_path):
    """Issue 36: ``wob_klbf = 1e300`` in a campaign gave "parameter wob = 2.5e+302 ... N/kg"
    with no key, event or file."""
    folder = _campaign(tmp_path / "c", TOML.replace('flow_gpm = 200.0',
                                                    'flow_gpm = 200.0\nwob_klbf = 1e300'))
    with pytest.raises(CampaignError, match=r"campaign\.toml, line 14: key events\[0\]\."
                       r"wob_klbf \(event 'e01'\): must be at most 1000 klbf"):
        load_campaign(folder)
    top = _campaign(tmp_path / "d", TOML.replace("wob_klbf = 4.0", "wob_klbf = 1e300"))
    with pytest.raises(CampaignError, match=r"line 4: key wob_klbf: must be at most 1000"):
        load_campaign(top)


def test_a_tiny_lowpass_is_refused_by_key(tmp_path):
    """Issue 36: ``lowpass_hz = 1e-300`` gave "Singular matrix"."""
    folder = _campaign(tmp_path / "c", TOML.replace("range_g = 250",
                                                    "range_g = 250\nlowpass_hz = 1e-300"))
    with pytest.raises(CampaignError, match=r"line 10: key sensors\.x1\.lowpass_hz: must be at "
                       r"least rate_hz / 1000 = 1\.024 Hz"):
        load_campaign(folder)


def test_the_sensor_chain_names_a_tiny_lowpass():
    import numpy as np
    from vadsim.signals.sensor import sensor_chain

    t = np.arange(1000) / 20480.0
    with pytest.raises(ValueError, match=r"lowpass_hz=1e-300 .*too low"):
        sensor_chain(t, np.sin(t), lowpass_hz=1e-300)


def test_a_run_that_fails_to_start_names_the_event_and_the_file(tmp_path):
    """A flow the model cannot run (beyond the excitation range) names the key, event, file."""
    from vadsim.compare import run_event
    from vadsim.model.settings import RunSettings

    folder = _campaign(tmp_path / "c", TOML.replace("flow_gpm = 200.0", "flow_gpm = 1e9"))
    camp = load_campaign(folder)
    with pytest.raises(ValueError, match=r"campaign\.toml: key events\[0\]\.flow_gpm "
                       r"\(event 'e01'\): flow_gpm = 1000000000\.0 must be in"):
        run_event(camp, camp.events[0], RunSettings("7in-cde", cycles=20, analyse_cycles=10))
    assert math.isfinite(camp.events[0].flow_gpm)
