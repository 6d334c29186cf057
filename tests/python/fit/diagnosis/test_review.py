"""The review of a chosen model once forward selection ends (vadsim.fit.diagnosis._review):
a variant chosen in place of the right one is swapped, an effect not needed on top of the
others is dropped, and what is needed stays."""

from __future__ import annotations

from dataclasses import replace

import pytest
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis import diagnose, search
from vadsim.fit.diagnosis import selection as dmod
from vadsim.fit.diagnosis.hypotheses import siblings, without
from vadsim.fit.diagnosis.policy import Policy, pinned_at_null
from vadsim.fit.hypothesis import Hypothesis
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.fit.nuisance import DEFAULT_NUISANCE
from vadsim.model.change import ModelChange

FLOWS = (200.0, 300.0, 400.0, 500.0, 600.0, 650.0)
SMALL = dict(cycles=160, analyse_cycles=100, duration_s=3.0, noise_g=0.3)
RUN = dict(cycles=SMALL["cycles"], analyse_cycles=SMALL["analyse_cycles"], phases=2,
           progress=False, policy=Policy(interval_search="search"))
"""No new runs for the intervals: these tests read none (the walk and the profile run
hundreds of points; tests/python/fit/test_interval_*.py test them)."""


def _truth(key: str, values: dict[str, float]) -> ModelChange:
    return CANDIDATES[key].change(values)


def _fit(keys: tuple[str, ...], point: tuple[float, ...]) -> HypothesisFit:
    return HypothesisFit(keys=keys, nuisance_specs=(), point=point, k=len(point),
                         intervals=[], rss=1.0, n=10, heldout_rms=1.0, heldout_rms_lofo=1.0,
                         heldout_rms_block=1.0, score=0.0)


def test_without_removes_or_replaces_a_candidate_and_keeps_the_others_values():
    fit = _fit(("contact_law", "sensor_chain[x1]", "mass[housing]"),
               (0.44, 0.5, 635.0, 4.8, 0.93))
    hyp, point = without(fit, "sensor_chain[x1]", "sensor_chain[both]")
    assert hyp.keys == ("contact_law", "sensor_chain[both]", "mass[housing]")
    assert point == (0.44, 0.5, 635.0, 4.8, 0.93)
    hyp, point = without(fit, "mass[housing]")
    assert hyp.keys == ("contact_law", "sensor_chain[x1]") and point == (0.44, 0.5, 635.0, 4.8)
    hyp, point = without(fit, "contact_law")
    assert hyp.keys == ("sensor_chain[x1]", "mass[housing]") and point == (635.0, 4.8, 0.93)
    assert Hypothesis(hyp.keys).specs[0].name == "f_res_hz"


def test_siblings_are_same_parameter_variants_cheap_or_already_fitted():
    keys = list(CANDIDATES)
    sc = siblings("sensor_chain[x1]", keys, ["sensor_chain[x1]"], fitted=())
    assert set(sc) == {"sensor_chain[x5]", "sensor_chain[both]"}
    # a model-side variant only where it was fitted fully when the chosen one was
    assert siblings("mass[housing]", keys, ["mass[housing]"], fitted=()) == []
    assert siblings("mass[housing]", keys, ["mass[housing]"], fitted=["mass[bit]"]) == \
        ["mass[bit]"]
    # a variant already chosen is not a swap
    assert "sensor_chain[both]" not in siblings(
        "sensor_chain[x1]", keys, ["sensor_chain[x1]", "sensor_chain[both]"], fitted=())


def _forced(monkeypatch, keys=None, **opts):
    """Forward selection run with other candidates or thresholds than the review's."""
    real = dmod.forward_selection

    def forced(ctx, ev, coarse_ev, base, none, all_keys, real_policy, say, tick):
        return real(ctx, ev, coarse_ev, base, none, list(keys or all_keys),
                    replace(real_policy, **opts), say, tick)

    monkeypatch.setattr(dmod, "forward_selection", forced)


def test_a_single_left_at_an_end_of_a_range_calls_for_the_pair_step():
    """blind-01's first step: the hydraulic force alone at its exponent's lower end (1.0)
    with WOB at its upper end absorbed the anvil friction; a value at an end of its own
    range or of a nuisance constant's sends the selection to the pair step, an inside value,
    a value at its null (no effect), a periodic constant or a pair does not."""
    def fit(keys: tuple[str, ...], point: tuple[float, ...], nuisance=()) -> HypothesisFit:
        return replace(_fit(keys, point), nuisance_specs=tuple(nuisance))

    force = ("hydraulic_force[anvil]",)
    assert dmod.single_at_a_bound(fit(force, (127.5, 1.0)))
    assert dmod.single_at_a_bound(fit(force, (200.0, 2.0)))
    assert not dmod.single_at_a_bound(fit(force, (64.0, 2.0)))
    assert not dmod.single_at_a_bound(fit(force, (0.0, 2.0)))  # at its null: no effect
    assert dmod.single_at_a_bound(fit(force, (64.0, 2.0, 1.15, 2.5), DEFAULT_NUISANCE))
    assert dmod.single_at_a_bound(fit(force, (64.0, 2.0, 0.85, 2.5), DEFAULT_NUISANCE))
    assert not dmod.single_at_a_bound(fit(force, (64.0, 2.0, 1.02, 0.0), DEFAULT_NUISANCE))
    assert not dmod.single_at_a_bound(fit(force + ("anvil_friction",), (127.5, 1.0, 90.0)))


def test_a_first_step_fitted_in_full_gives_the_pair_step_its_prospects():
    """A pool too small to screen is fitted, not probed: its pairs are the best-scored
    singles' (one variant of each physics), at the nuisance values of the better one of each
    pair -- where the probes' reading gives none (6-event two-effect test campaign)."""
    def fit(key: str, point: tuple[float, ...], score: float) -> HypothesisFit:
        return replace(_fit((key,), point), nuisance_specs=DEFAULT_NUISANCE, score=score)

    fits = [fit("anvil_friction", (215.6, 1.004, 2.26), 526.1),
            fit("hydraulic_force[anvil]", (200.0, 1.0, 1.084, 2.32), 7.9),
            fit("contact_law", (8.66, 0.70, 1.15, 1.30), 1019.5),
            fit("hydraulic_force[bit]", (0.0, 2.0, 1.15, 1.30), 975.2)]
    assert search.pair_prospects(fits, search.PAIR_TOP) == []
    assert search.fitted_prospects(fits, search.PAIR_TOP) == [
        ("hydraulic_force[anvil]", "anvil_friction", (1.084, 2.32)),
        ("hydraulic_force[anvil]", "contact_law", (1.084, 2.32)),
        ("anvil_friction", "contact_law", (1.004, 2.26))]
    assert len(search.fitted_prospects(fits, 2)) == 1
    # a single that scores no better than the model it extends is no prospect
    assert search.fitted_prospects(fits, search.PAIR_TOP, base_score=973.3) == [
        ("hydraulic_force[anvil]", "anvil_friction", (1.084, 2.32))]


def test_joint_probes_after_full_fits_are_measured_on_the_probes_own_events(monkeypatch):
    """Where the pair step's prospects come from full fits, the single cost a joint probe
    must cut is the best single's at its fitted point on the coarse engine and the probe
    events -- not its full fit's cost over every event on the full engine, which a probe of
    fewer events would clear whatever it found."""
    measured: list[tuple[object, tuple[str, ...], tuple[float, ...]]] = []

    class Costs:  # the coarse engine's cost: 10 per unit of the first coordinate
        def __init__(self, ev, hyp, eids):
            self.ev, self.eids = ev, tuple(eids)

        def rss(self, point):
            measured.append((self.ev, self.eids, tuple(point)))
            return 10.0 * point[0]

    def fit(key: str, point: tuple[float, ...], score: float, rss: float) -> HypothesisFit:
        return replace(_fit((key,), point), nuisance_specs=DEFAULT_NUISANCE, score=score,
                       rss=rss)

    fits = [fit("anvil_friction", (215.6, 1.004, 2.26), 526.1, 900.0),
            fit("hydraulic_force[anvil]", (60.0, 1.0, 1.084, 2.32), 7.9, 100.0)]
    coarse = object()
    monkeypatch.setattr(search, "HypothesisCosts", Costs)
    monkeypatch.setattr(search, "fit_all", lambda *a, **k: ["probed"])
    ctx = type("Ctx", (), {"probe_eids": ("e01", "e03")})()
    base = replace(_fit((), (1.0, 0.0)), nuisance_specs=DEFAULT_NUISANCE, score=973.3)
    joint, single = search.pair_probes(ctx, object(), coarse, base, fits, lambda _m: None)
    assert joint == ["probed"]
    assert single == 600.0  # the force's point on the coarse engine, not its fit's 100
    assert {(ev, eids) for ev, eids, _p in measured} == {(coarse, ("e01", "e03"))}
    assert sorted(p for _e, _i, p in measured) == [fits[1].point, fits[0].point]


@pytest.mark.slow
def test_a_variant_chosen_in_place_of_the_right_one_is_swapped(monkeypatch):
    """A mount resonance on both sensors; forward selection may only name it on x1 (as it
    did on blind-12, where a contact law had absorbed the rest): the review refits it as
    its variants and takes the one on both sensors."""
    camp = synthetic_campaign("7in-cde", FLOWS, seed=21, **SMALL,
                              change=_truth("sensor_chain[both]", {"f_res_hz": 600.0, "q": 6.0}))
    _forced(monkeypatch, keys=["sensor_chain[x1]"])
    d = diagnose(camp, candidates=["sensor_chain[x1]", "sensor_chain[both]"], **RUN)
    swaps = [r for r in d.review if r["action"] == "swap"]
    assert {r["to"] for r in swaps} == {"sensor_chain[both]"}  # the candidates offered
    assert d.chosen is not None and d.chosen.keys == ("sensor_chain[both]",), d.summary()
    assert [r["to"] for r in swaps if r["accepted"]] == ["sensor_chain[both]"]
    assert d.chosen.values["f_res_hz"] == pytest.approx(600.0, rel=0.1)
    assert "review: sensor_chain[x1] as sensor_chain[both]" in d.summary()
    assert d.as_json()["review"] == d.review


@pytest.mark.slow
def test_an_effect_not_needed_on_top_of_the_others_is_dropped_and_the_needed_one_stays(
        monkeypatch):
    """A hydraulic force alone; forward selection with every threshold off adds a contact
    law (it has no null, so it never vanishes) on top. The review, with the diagnosis'
    thresholds, drops the contact law and keeps the hydraulic force."""
    camp = synthetic_campaign("7in-cde", FLOWS, seed=11, **SMALL,
                              change=_truth("hydraulic_force[anvil]", {"f_ref": 64.0, "n": 2.0}))
    _forced(monkeypatch, min_delta=-1e9, min_reduction=-1e9, noise_rms=0.0, max_effects=2)
    d = diagnose(camp, candidates=["hydraulic_force[anvil]", "contact_law"], **RUN)
    drops = [r for r in d.review if r["action"] == "drop"]
    assert {r["from"] for r in drops} == {"hydraulic_force[anvil]", "contact_law"}, d.summary()
    assert [r["from"] for r in drops if r["accepted"]] == ["contact_law"], d.summary()
    assert d.missing_physics == ["hydraulic_force"], d.summary()
    assert d.chosen.parameters["hydraulic_force"]["f_ref"] == pytest.approx(64.0, rel=0.2)


def _pair_fit(on_bottom: tuple[float, float], single: bool = False) -> HypothesisFit:
    """A contact law with an on-bottom stiffness factor beside it (blind-44's chosen pair)
    and the intervals given; or the stiffness alone."""
    keys = (("contact_stiffness[on_bottom]",) if single
            else ("contact_law[impact]", "contact_stiffness[on_bottom]"))
    ivs = ([] if single else [(0.997, 1.0016), (0.0761, 0.0767)]) + [on_bottom]
    point = tuple(0.5 * (lo + hi) for lo, hi in ivs)
    return HypothesisFit(keys=keys, nuisance_specs=(), point=point, k=len(point) + 2,
                         intervals=ivs, rss=9.1, n=709, heldout_rms=0.16,
                         heldout_rms_lofo=0.16, heldout_rms_block=0.16, score=-2000.0)


def test_an_effect_pinned_at_its_null_is_measured_absent():
    """An effect whose 95 % interval holds its null and lies inside its search range is
    measured to be absent; one whose interval reaches an end of its range is merely not
    pinned, and one away from its null is found. A single effect is left to the thresholds
    that chose it."""
    spec = CANDIDATES["contact_stiffness[on_bottom]"].params[0]
    assert spec.null == 1.0 and spec.lo < 0.9 and spec.hi > 1.1
    assert pinned_at_null(_pair_fit((0.995, 1.005))) == ["contact_stiffness[on_bottom]"]
    assert pinned_at_null(_pair_fit((1.01, 1.05))) == []  # away from its null: found
    assert pinned_at_null(_pair_fit((spec.lo, 1.005))) == []  # reaches its range: not pinned
    assert pinned_at_null(_pair_fit((0.995, 1.005), single=True)) == []
    # candidates without a null (the contact law) are never measured absent
    assert "contact_law[impact]" not in pinned_at_null(_pair_fit((0.995, 1.005)))


def test_a_remainder_beyond_the_noise_sends_every_candidate_not_fitted_to_a_full_fit(
        monkeypatch):
    """blind-36: the excitation force 1.25 times the written one; the amplitude's probe saw
    no gain and an on-bottom contact stiffness was chosen instead, leaving a remainder far
    beyond the noise. Forward selection is held to the stiffness here (as its probes held
    it there); the remainder then sends the amplitude to a full fit, which passes against
    the stiffness and replaces it, at the written factor."""
    camp = synthetic_campaign("7in-cde", FLOWS, seed=36, **SMALL,
                              change=_truth("excitation_amplitude", {"factor": 1.25, "p": 0.0}))
    _forced(monkeypatch, keys=["contact_stiffness[on_bottom]"])
    said: list[str] = []
    d = diagnose(camp, candidates=["contact_stiffness[on_bottom]", "excitation_amplitude"],
                 **{**RUN, "progress": said.append})
    assert any("leaves a remainder beyond the noise" in s for s in said), said
    assert d.chosen is not None and d.chosen.keys == ("excitation_amplitude",), d.summary()
    assert d.chosen.values["factor"] == pytest.approx(1.25, rel=0.05), d.summary()
    swap, = (r for r in d.review if r.get("why", "").startswith("a remainder"))
    assert swap["to"] == "excitation_amplitude" and swap["accepted"]
    assert swap["from"] in ("none", "contact_stiffness[on_bottom]")
    assert "excitation_amplitude" in {f.key for f in d.ranking if not f.probe}
    assert d.verdict == "explained"


def test_a_remainder_no_candidate_passes_against_leaves_the_model_as_it_was(monkeypatch):
    """Candidates fitted for a remainder that do not pass against the final model (the
    usual thresholds) change nothing; every candidate a step fitted fully, or that the model
    holds, is not fitted again."""
    from vadsim.fit.scoring import aicc

    away = {"contact_stiffness[on_bottom]": (1.3,), "excitation_amplitude": (1.25, 0.2)}

    def fit(keys, heldout, rss, probe=False):
        point = tuple(v for k in keys for v in away[k])
        f = replace(_fit(keys, point), heldout_rms=heldout,
                    heldout_rms_lofo=heldout, heldout_rms_block=heldout, rss=rss, probe=probe,
                    n_heldout=500)
        return replace(f, score=aicc(500, heldout ** 2, f.k))

    base = fit((), 4.0, 8000.0)
    chosen = fit(("contact_stiffness[on_bottom]",), 1.8, 2000.0)
    probed = fit(("excitation_amplitude",), 3.9, 7900.0, probe=True)
    sel = dmod.Selection(steps=[[chosen, probed]], chosen=chosen)
    asked: list[list[str]] = []
    for found, replaced in ((fit(("excitation_amplitude",), 1.5, 1900.0), False),
                            (fit(("excitation_amplitude",), 0.2, 60.0), True)):
        def fit_all(ctx, jobs, ev, cev, say, tick=None, found=found):
            asked.append([j.hyp.keys[-1] for j in jobs])
            return [found for _ in jobs]

        monkeypatch.setattr(dmod, "fit_all", fit_all)
        monkeypatch.setattr(dmod, "job", lambda current, key: type("J", (), {
            "hyp": Hypothesis((key,))})())
        got = dmod.remainder_search(None, None, None, replace(sel, steps=[[chosen, probed]]),
                                    base, chosen, ["contact_stiffness[on_bottom]",
                                                   "excitation_amplitude"], Policy(),
                                    lambda _m: None, lambda *_a: None)
        assert (got is found) == replaced
    assert asked == [["excitation_amplitude"]] * 2
    # nothing left to fit: no fit at all
    done = dmod.Selection(steps=[[chosen, fit(("excitation_amplitude",), 3.9, 7900.0)]],
                          chosen=chosen)
    assert dmod.remainder_search(None, None, None, done, base, chosen,
                                 ["contact_stiffness[on_bottom]", "excitation_amplitude"],
                                 Policy(), lambda _m: None, lambda *_a: None) is None
    assert len(asked) == 2
