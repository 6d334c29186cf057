"""The candidate library as families (vadsim.fit.candidates): the agreed keys, ids and
parameters; every key's bounds, grid and change valid; the null of every family that has one
gives the base run exactly; and what each family promises where it acts (hydraulic n = 2 is
the old square law, a flow power or slope leaves the reference flow alone, a sensor on x5
leaves x1 alone, masses and stiffnesses change the run).

Runs are short (120 cycles, 60 analysed: ~50 ms each on the 7in tool), so the whole file
stays well under a minute and a half.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np
import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import measure_event, run_event
from vadsim.fit.candidates import (
    CANDIDATES,
    Candidate,
    ModelChange,
    candidate,
    candidate_ids,
    keys_for,
)
from vadsim.model.presets import make_params
from vadsim.model.settings import ExtraSpec, RunSettings

SETTINGS = RunSettings("7in-cde", cycles=120, analyse_cycles=60)
FLOWS = (300.0, 650.0)  # a regime-1 and a regime-5 flow of the 7in tool

# key: (id, {param: (lo, hi, scale, null)}, fixed choices): the table other agents rely on.
AGREED: dict[str, tuple[str, dict[str, tuple[float, float, str, float | None]], dict]] = {
    **{f"hydraulic_force[{b}]": ("hydraulic_force", {"f_ref": (0.0, 200.0, "linear", 0.0),
                                                     "n": (1.0, 3.0, "linear", None)},
                                 {"acts_on": b}) for b in ("anvil", "bit")},
    "contact_law": ("contact_law", {"factor": (0.1, 10.0, "log", None),
                                    "s": (0.0, 2.0, "linear", None)},
                    {"law": "power_damping"}),
    "contact_law[impact]": ("contact_law", {"stiffness": (0.25, 4.0, "log", None),
                                            "factor": (0.03, 3.0, "log", None)},
                            {"law": "power_damping_impact"}),
    "anvil_friction": ("anvil_friction", {"force": (0.0, 400.0, "linear", 0.0)}, {}),
    "anvil_friction[stribeck]": ("anvil_friction", {"force": (0.0, 400.0, "linear", 0.0),
                                                    "peak": (1.0, 3.0, "linear", None),
                                                    "v_s": (0.01, 0.3, "log", None)},
                                 {"law": "stribeck"}),
    "string_radiation": ("string_radiation", {"c": (0.0, 2.0e5, "linear", 0.0)}, {}),
    "axial_lateral": ("axial_lateral", {"gain": (0.0, 6.0, "linear", 0.0),
                                        "f_lat_hz": (25.0, 480.0, "log", None)}, {}),
    **{f"sensor_chain[{s}]": ("sensor_chain", {"f_res_hz": (150.0, 2000.0, "log", None),
                                               "q": (1.0, 30.0, "log", None)},
                              {"sensors": s}) for s in ("both", "x1", "x5")},
    "excitation_amplitude": ("excitation_amplitude", {"factor": (0.5, 2.0, "log", 1.0),
                                                      "p": (-1.5, 1.5, "linear", 0.0)}, {}),
    "excitation_phase": ("excitation_phase", {"slope": (-1.5, 1.5, "linear", 0.0)}, {}),
    **{f"contact_stiffness[{s}]": ("contact_stiffness", {"factor": (0.25, 4.0, "log", 1.0)},
                                   {"surface": s})
       for s in ("spring", "impact", "off_bottom", "on_bottom")},
    "rock_stiffness": ("rock_stiffness", {"factor": (0.25, 4.0, "log", 1.0)}, {}),
    **{f"mass[{b}]": ("mass", {"factor": (0.6, 1.6, "log", 1.0)}, {"body": b})
       for b in ("bit", "anvil", "housing", "motor", "sub", "lwd", "mwd")},
}


@functools.cache
def _base(flow: float):
    return SETTINGS.run(flow)


def _same_run(a, b) -> bool:
    """Same peaks (every window, every dof), same impacts, same impulse: the same run."""
    return (np.array_equal(a.window_peaks_g, b.window_peaks_g) and a.impacts == b.impacts
            and a.impulse_pos == b.impulse_pos)


def _run(change: ModelChange, flow: float):
    return change.apply(SETTINGS, flow).run(flow)


def _mid(cand: Candidate, **given: float) -> dict[str, float]:
    """Every parameter at the middle of its search box, some given."""
    return {p.name: given.get(p.name, p.from_unit(0.5)) for p in cand.params}


# ---------------------------------------------------------------------------- the library

def test_keys_ids_parameters_and_fixed_choices_are_the_agreed_ones():
    assert list(CANDIDATES) == list(AGREED)
    for key, (cid, params, fixed) in AGREED.items():
        c = CANDIDATES[key]
        assert (c.key, c.id) == (key, cid)
        got = {p.name: (p.lo, p.hi, p.scale, p.null) for p in c.params}
        assert got == params, key
        assert dict(c.fixed) == fixed, key
        assert c.public_parameters(_mid(c)) == {**fixed, **_mid(c)}
    assert candidate_ids() == list(dict.fromkeys(cid for cid, _, _ in AGREED.values()))
    # the generic candidates are told apart from the named physics
    assert {c.id for c in CANDIDATES.values() if c.group == "quantity"} == {
        "excitation_amplitude", "excitation_phase", "contact_stiffness", "rock_stiffness",
        "mass"}


def test_keys_for_expands_an_id_to_all_its_variants():
    assert keys_for(["mass"]) == [f"mass[{b}]" for b in
                                  ("bit", "anvil", "housing", "motor", "sub", "lwd", "mwd")]
    # "contact_law" is a key as well as an id: the four surfaces' family, not its impact variant
    assert keys_for(["sensor_chain", "contact_law"]) == [
        "sensor_chain[both]", "sensor_chain[x1]", "sensor_chain[x5]", "contact_law"]
    assert keys_for(["contact_law[impact]"]) == ["contact_law[impact]"]
    assert keys_for(["mass[lwd]", "mass"])[0] == "mass[lwd]"  # a key first, no repeats
    assert len(keys_for(["mass[lwd]", "mass"])) == 7
    assert keys_for(None) == list(CANDIDATES)
    assert candidate("contact_stiffness[on_bottom]").fixed == {"surface": "on_bottom"}
    with pytest.raises(ValueError, match=r"has variants: contact_stiffness\[spring\]"):
        candidate("contact_stiffness")
    with pytest.raises(ValueError, match="unknown candidate 'masses'"):
        keys_for(["masses"])


@pytest.mark.parametrize("key", list(AGREED))
def test_every_key_has_valid_bounds_grid_and_changes(key):
    c = CANDIDATES[key]
    assert c.signature and c.side in ("model", "measurement")
    assert c.group in ("physics", "quantity")
    # grids multiply: a third parameter (a friction's Stribeck peak and velocity) only where
    # two of them take at most 3 grid points, so a probe stays at 5 x 3 x 3 points
    assert len(c.params) <= 3
    assert len(c.params) < 3 or sorted(p.grid for p in c.params)[:2] == [3, 3]
    for p in c.params:
        assert p.lo < p.hi and p.grid >= 2 and p.scale in ("linear", "log")
        assert p.null is None or p.lo <= p.null <= p.hi
        assert p.scale == "linear" or p.lo > 0
        for x in (p.lo, 0.5 * (p.lo + p.hi), p.hi):
            assert p.from_unit(p.to_unit(x)) == pytest.approx(x, rel=1e-12, abs=1e-15)
    # every corner of the box builds a change that applies and validates at both ends of the
    # 7in range, and runs where it acts on the model
    for corner in itertools.product(*[(p.lo, p.hi) for p in c.params]):
        values = dict(zip((p.name for p in c.params), corner, strict=True))
        ch = c.change(values)
        assert isinstance(ch, ModelChange)
        if c.side == "measurement":
            assert not ch.changes_run
            a = np.sin(np.linspace(0.0, 60.0, 4096))
            for name in ("x1", "x5"):
                out = ch.measurement(name, a, 20480.0) if ch.measurement else a
                assert out.shape == a.shape and np.all(np.isfinite(out))
            continue
        for flow in (200.0, 650.0):
            s = ch.apply(SETTINGS, flow)
            make_params(s.preset, s.overrides, s.law)
        r = _run(ch, 650.0)
        assert np.all(np.isfinite(r.window_peaks_g)) and r.window_peaks_g.size


def test_errors_name_the_bad_parameter_and_its_bounds():
    with pytest.raises(ValueError, match=r"hydraulic_force\[bit\]: f_ref = -1.*\[0, 200\]"):
        CANDIDATES["hydraulic_force[bit]"].change({"f_ref": -1.0, "n": 2.0})
    with pytest.raises(ValueError, match=r"hydraulic_force\[anvil\]: n = 3.5.*\[1, 3\]"):
        CANDIDATES["hydraulic_force[anvil]"].change({"f_ref": 10.0, "n": 3.5})
    with pytest.raises(ValueError, match=r"contact_law: s = 2.5 outside \[0, 2\]"):
        CANDIDATES["contact_law"].change({"factor": 1.0, "s": 2.5})
    with pytest.raises(ValueError, match=r"contact_law: factor = 0.05 outside \[0.1, 10\]"):
        CANDIDATES["contact_law"].change({"factor": 0.05, "s": 1.0})
    with pytest.raises(ValueError, match=r"mass\[sub\]: factor = 2.0 outside \[0.6, 1.6\]"):
        CANDIDATES["mass[sub]"].change({"factor": 2.0})
    with pytest.raises(ValueError, match=r"excitation_phase: slope = nan"):
        CANDIDATES["excitation_phase"].change({"slope": math.nan})
    with pytest.raises(ValueError, match="missing parameter 'p'"):
        CANDIDATES["excitation_amplitude"].change({"factor": 1.2})
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) c; it has f_ref, n"):
        CANDIDATES["hydraulic_force[anvil]"].change({"f_ref": 10.0, "n": 2.0, "c": 1e-4})


# -------------------------------------------------------------------------------- the nulls

@pytest.mark.parametrize("key", [k for k, c in CANDIDATES.items()
                                 if any(p.null is not None for p in c.params)])
def test_a_family_at_its_null_is_exactly_the_base_run(key):
    c = CANDIDATES[key]
    values = {p.name: p.null if p.null is not None else p.from_unit(0.3) for p in c.params}
    ch = c.change(values)
    assert not ch.changes_run and ch.measurement is None, ch.describe()
    for flow in FLOWS:
        assert _same_run(_run(ch, flow), _base(flow)), (key, flow)


def test_contact_law_null_is_kelvin_voigt_without_tension_not_the_base_law():
    ch = CANDIDATES["contact_law"].change({"factor": 1.0, "s": 0.0})
    kv = SETTINGS.with_changes(law="kelvin_voigt_no_tension")
    for flow in FLOWS:
        r = _run(ch, flow)
        assert _same_run(r, kv.run(flow))
    assert not _same_run(_run(ch, 650.0), _base(650.0))  # the base law keeps tension
    # the family reaches beyond it: damping that vanishes at first touch changes the run
    assert not _same_run(_run(CANDIDATES["contact_law"].change({"factor": 1.0, "s": 1.5}),
                              300.0), _run(ch, 300.0))


# ---------------------------------------------------------------------- what families promise

@pytest.mark.parametrize("acts_on", ["anvil", "bit"])
def test_hydraulic_square_law_is_the_old_c_form(acts_on):
    cand = CANDIDATES[f"hydraulic_force[{acts_on}]"]
    # f_ref = c 400^2: 2.5e-4 * 160000 = 40 exactly, so the two runs are bit for bit the same
    old = ModelChange(extras=[ExtraSpec.of("hydraulic", acts_on=acts_on, c=2.5e-4)])
    new = cand.change({"f_ref": 40.0, "n": 2.0})
    for flow in FLOWS:
        assert _same_run(_run(new, flow), _run(old, flow))
    # other exponents agree with the square law at 400 gal/min only
    at_ref = [_run(cand.change({"f_ref": 40.0, "n": n}), 400.0) for n in (1.0, 3.0)]
    assert all(_same_run(r, _run(new, 400.0)) for r in at_ref)
    if acts_on == "anvil":  # on the bit, 40 N/kg under 1000 N/kg of WOB barely shows
        r1 = _run(cand.change({"f_ref": 40.0, "n": 1.0}), 650.0)
        assert not _same_run(r1, _run(new, 650.0))


def test_excitation_amplitude_power_acts_away_from_the_reference_flow_only():
    cand = CANDIDATES["excitation_amplitude"]
    tilted = cand.change({"factor": 1.0, "p": 1.0})
    assert tilted.apply(SETTINGS, 400.0).param("Fo") == SETTINGS.param("Fo")
    assert _same_run(_run(tilted, 400.0), _base(400.0))
    r650 = _run(tilted, 650.0)
    assert not np.allclose(r650.window_peaks_g, _base(650.0).window_peaks_g, rtol=1e-3)
    assert tilted.apply(SETTINGS, 650.0).param("Fo") == pytest.approx(
        SETTINGS.param("Fo") * 650.0 / 400.0)
    scaled = cand.change({"factor": 1.5, "p": 0.0})
    assert scaled.apply(SETTINGS, 400.0).param("Fo") == pytest.approx(1.5 * SETTINGS.param("Fo"))


def test_excitation_phase_slope_is_nothing_at_the_reference_flow():
    ch = CANDIDATES["excitation_phase"].change({"slope": 0.8})
    assert _same_run(_run(ch, 400.0), _base(400.0))
    assert ch.apply(SETTINGS, 650.0).param("theta0") == pytest.approx(
        SETTINGS.param("theta0") + 0.8 * (650.0 / 400.0 - 1.0))
    assert not _same_run(_run(ch, 650.0), _base(650.0))


def test_sensor_chain_on_one_sensor_leaves_the_other_untouched():
    camp = synthetic_campaign("7in-cde", (400.0,), cycles=120, analyse_cycles=60,
                              duration_s=1.0, noise_g=0.0)
    ev = camp.events[0]
    r = run_event(camp, ev, SETTINGS)
    base = measure_event(camp, ev, r, phases=1)
    values = {"f_res_hz": 500.0, "q": 10.0}
    for only, other in (("x5", "x1"), ("x1", "x5")):
        got = measure_event(camp, ev, r, phases=1,
                            measurement=CANDIDATES[f"sensor_chain[{only}]"].change(values)
                            .measurement)
        for feats, ref in ((got.sensor, base.sensor), (got.full, base.full)):
            # the other sensor's own features (not a ratio of both, e.g. x5_x1_peak_ratio);
            # every sensor's fold is aligned on the reference x1's spike (fold_features), so
            # a chain on x1 legitimately moves x5's folded bins: only x5's unfolded ones stay
            untouched = {k: v for k, v in feats.items() if k.startswith(other)
                         and only not in k and not (only == "x1" and "_fold" in k)}
            assert untouched and untouched == {k: ref[k] for k in untouched}
            assert any(feats[k] != ref[k] for k in feats if k.startswith(only)), only
    both = measure_event(camp, ev, r, phases=1,
                         measurement=CANDIDATES["sensor_chain[both]"].change(values).measurement)
    assert all(any(both.sensor[k] != base.sensor[k] for k in both.sensor if k.startswith(s))
               for s in ("x1", "x5"))


@pytest.mark.parametrize("key", [k for k in CANDIDATES
                                 if k.startswith(("mass[", "contact_stiffness["))
                                 and k != "contact_stiffness[off_bottom]"] + ["rock_stiffness"])
def test_masses_and_stiffnesses_change_the_run(key):
    cand = CANDIDATES[key]
    name = {**{f"mass[{b}]": f"m{i}" for i, b in enumerate(
        ("bit", "anvil", "housing", "motor", "sub", "lwd", "mwd"), start=1)},
        "contact_stiffness[spring]": "kS", "contact_stiffness[impact]": "kI",
        "contact_stiffness[on_bottom]": "kOn", "rock_stiffness": "kR"}[key]
    hi = cand.params[0].hi
    ch = cand.change({"factor": hi})
    assert ch.apply(SETTINGS, 300.0).param(name) == pytest.approx(hi * SETTINGS.param(name))
    assert any(not _same_run(_run(ch, f), _base(f)) for f in FLOWS), key


def test_off_bottom_stiffness_scales_koff_and_is_silent_on_bottom():
    """The off-bottom shoulder never touches in on-bottom runs (its signature says so)."""
    ch = CANDIDATES["contact_stiffness[off_bottom]"].change({"factor": 4.0})
    assert ch.apply(SETTINGS, 300.0).param("kOff") == pytest.approx(4.0 * SETTINGS.param("kOff"))
    assert _run(ch, 300.0).impacts["off_bottom"] == 0
