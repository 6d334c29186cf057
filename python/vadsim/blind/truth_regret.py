"""Regret against the truth: the diagnosis' chosen model's cost minus the true model's.

Why this module exists: identification only says whether the right names came out. A search
can name the right candidate at the wrong values (or "none" where a library member at the truth
fits within the noise) and still score "correct" or look like a missing library entry. The
regret separates the two failures: after a diagnosis, the truth (read only now, for scoring)
and the chosen model are evaluated with the diagnosis' own evaluator on every event, and

* ``regret = RSS(chosen) - RSS(truth)``, the training cost (sum of squared standardised
  residuals over every event and feature) at the chosen point minus at the true point;
* ``noise = NOISE_SIGMAS * sqrt(2 n) s^2``: with ``n`` residuals of variance ``s^2`` the RSS
  of the true model scatters by ``sqrt(2 n) s^2`` (``s^2`` times a chi-square of ``n``
  degrees of freedom) from one draw of the recording noise to the next. A residual is
  standardised by the recording's window-to-window spread, which is wider than the noise a
  steady response leaves on a feature, so ``s^2`` is not 1 (0.01-0.07 on the blind
  benchmark's campaigns): it is read from the campaign, ``min(RSS_truth, RSS_chosen) / n``,
  what the better of the two models leaves (the truth's own RSS is not all noise where its
  run lands on another response than the recording's);
* a **search failure** is a regret above that noise: a point of the library (the truth) fits
  the campaign better than the chosen model by more than the noise explains, whatever the
  verdict says.

The true model is the truth's candidates at their values, ``wob_scale`` as concealed (1 unless
set) and ``theta0`` as concealed (the preset's value at rest unless set; for the independent
generator, MODEL.md's phase at rest under the concealed WOB), with the default nuisance
constants of a diagnosis. A negative regret is normal: the chosen model has fitted
parameters and the truth has none.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from vadsim.blind.independent import rest_phase
from vadsim.campaigns import campaign_preset, load_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.hypothesis import Hypothesis, HypothesisCosts, Point
from vadsim.fit.nuisance import DEFAULT_NUISANCE, NuisanceSpec, resolve_nuisance
from vadsim.model.defaults import DEFAULTS
from vadsim.model.settings import RunSettings

__all__ = ["NOISE_SIGMAS", "chosen_point", "regret", "regret_of", "truth_is_library_point",
           "truth_point"]

NOISE_SIGMAS = 2.0
"""A regret counts as beyond the noise above this many standard deviations of the true
model's RSS (``sqrt(2 n) s^2`` for ``n`` residuals of variance ``s^2``)."""


def truth_is_library_point(truth: Mapping[str, Any]) -> bool:
    """Whether a ``truth.json`` entry is a point of the library (every campaign vadsim writes;
    an independent generator's only when its effects are exact members, ``library_point``).
    Elsewhere the regret is n/a: no library point is the truth."""
    return bool(truth.get("library_point", True))


def truth_point(truth: Mapping[str, Any], nuisance: tuple[NuisanceSpec, ...]
                ) -> tuple[Hypothesis, Point]:
    """The true model of one ``truth.json`` entry as a hypothesis and its point."""
    keys = tuple(t["key"] for t in truth["truths"])
    hyp = Hypothesis(keys, nuisance)
    values = [float(t["values"][p.name]) for t in truth["truths"]
              for p in CANDIDATES[t["key"]].params]
    concealed: dict[str, Any] = dict(truth.get("nuisance", {}))
    if truth.get("generator") == "independent" and "theta0" not in concealed:
        # its phase at rest follows the concealed WOB's static state (MODEL.md)
        concealed["theta0"] = rest_phase(truth.get("preset", "7in-cde"),
                                         concealed.get("wob_scale", 1.0)) % math.pi
    nuis = [float(concealed.get(s.name, s.null or 0.0)) for s in nuisance]  # null: the preset's
    return hyp, hyp.round([*values, *nuis])


def chosen_point(result: Mapping[str, Any], nuisance: tuple[NuisanceSpec, ...]
                 ) -> tuple[Hypothesis, Point]:
    """The chosen model of one diagnosis (``Diagnosis.as_json()``) as a hypothesis and its
    point ("none": the calibrated base model)."""
    keys = tuple(k for k in result.get("missing_physics_keys") or () if k != "none")
    hyp = Hypothesis(keys, nuisance)
    params = result.get("parameters") or {}
    values = [float(params[CANDIDATES[k].id][p.name]) for k in keys
              for p in CANDIDATES[k].params]
    found = result.get("nuisance") or {}
    nuis = []
    for s in nuisance:
        v = found.get(s.name, s.null or 0.0)
        nuis.append(float(v["value"] if isinstance(v, Mapping) else v))
    return hyp, hyp.round([*values, *nuis])


def regret(campaign: str | Path, truth: Mapping[str, Any], result: Mapping[str, Any], *,
           cycles: float = DEFAULTS.recording_cycles,
           analyse_cycles: float = DEFAULTS.analyse_cycles,
           phases: int = DEFAULTS.diagnosis_phases, workers: int | None = None
           ) -> dict[str, Any]:
    """The regret of one diagnosed campaign (module docstring).

    Returns
    -------
    dict
        ``rss_truth``, ``rss_chosen``, ``n`` (residuals), ``rms_truth`` and ``rms_chosen``
        (RMS standardised residual over every event), ``regret``, ``noise`` and
        ``search_failure`` (regret > noise).
    """
    camp = load_campaign(campaign)
    settings = RunSettings(campaign_preset(camp), cycles=cycles, analyse_cycles=analyse_cycles)
    nuisance = resolve_nuisance(DEFAULT_NUISANCE, settings)
    eids = [e.id for e in camp.events]
    with CampaignEvaluator(camp, settings, phases=phases, workers=workers or 1) as ev:
        ev.base(eids)
        n = sum(len(ev.keys[e]) for e in eids)
        rss = {}
        for label, (hyp, point) in (("truth", truth_point(truth, nuisance)),
                                    ("chosen", chosen_point(result, nuisance))):
            rss[label] = float(np.sum(HypothesisCosts(ev, hyp, eids).event_rss([point])))
    return regret_of(rss["truth"], rss["chosen"], n)


def regret_of(rss_truth: float, rss_chosen: float, n: int) -> dict[str, Any]:
    """The regret, its noise and the verdict from the two training costs over ``n``
    residuals (module docstring); also ``residual_variance``, the ``s^2`` of the noise."""
    if not (isinstance(n, int) and n > 0):
        raise ValueError(f"n = {n!r} must be a positive number of residuals")
    s2 = min(rss_truth, rss_chosen) / n
    noise = NOISE_SIGMAS * math.sqrt(2.0 * n) * s2
    value = rss_chosen - rss_truth
    return {"rss_truth": rss_truth, "rss_chosen": rss_chosen, "n": n,
            "rms_truth": math.sqrt(rss_truth / n), "rms_chosen": math.sqrt(rss_chosen / n),
            "residual_variance": s2, "regret": value, "noise": noise,
            "search_failure": bool(value > noise)}
