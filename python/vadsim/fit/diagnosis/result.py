"""What a diagnosis found, as data: :class:`Diagnosis` and its JSON form.

Its text (``summary()``, ``verdict_text()``) and notebook table come from the report layer
(:mod:`vadsim.report.text`, through :mod:`vadsim._render`); its figures from
:mod:`vadsim.plots.campaigns`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from vadsim._render import render
from vadsim.campaigns import Campaign
from vadsim.fit.diagnosis.operating_point import operating_point
from vadsim.fit.diagnosis.policy import Policy, none_model
from vadsim.fit.hypothesis import Fold
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.fit.locate import Mismatch
from vadsim.model.presets import Preset
from vadsim.signals.features import Feature

__all__ = ["Diagnosis", "jsonable"]


@dataclass
class Diagnosis:
    """Everything a diagnosis found; :meth:`as_json` is what ``vadsim diagnose --json`` prints.

    ``uncalibrated`` is the base model at its nominal constants, ``baseline`` the calibrated
    base model, ``none_fit`` the one of the two that "none" stands for (see
    :func:`none_model`), ``steps`` the ranking of each forward-selection step (the first is
    ``ranking``), ``chosen`` the final model with effects (None if none was chosen) and
    ``verdict`` one of ``"none"``, ``"explained"``, ``"unexplained"``, ``pairs`` what the
    pair step probed.
    """

    campaign: Campaign
    preset: Preset
    located: list[Mismatch]
    located_events: list[dict[str, Any]]
    uncalibrated: HypothesisFit
    baseline: HypothesisFit
    steps: list[list[HypothesisFit]]
    chosen: HypothesisFit | None
    verdict: str
    unexplained: list[dict[str, Any]]
    recorded: dict[str, dict[str, Feature]]
    keys: dict[str, list[str]]
    baseline_sim: dict[str, dict[str, float]]
    folds: list[Fold]
    settings: dict[str, Any]
    elapsed_s: float
    n_evals: int
    prediction: dict[str, Any] | None = None
    pairs: list[dict[str, Any]] = field(default_factory=list)
    """The pair step's joint probes (empty where it did not run): ``pair``, ``probe_rss``,
    ``single_rss`` (the best single probe's) and ``fitted`` (whether it earned a full fit)."""
    noise: dict[str, Any] | None = None
    """Whether the final model (the chosen one, or the base model "none" stands for) lies
    within the noise (:func:`~vadsim.fit.diagnosis.policy.within_noise`: ``rms`` on the
    campaign, ``band``, the ``quantile`` of ``draws`` campaigns the model wrote itself, their
    ``median``, ``within``). With "none" it decides the verdict; with a chosen model, outside
    the band is a remainder beyond the noise that the verdict's text names. None where the
    final model holds out above ``max_rms`` or the bootstrap was off."""
    widened_nuisance: list[dict[str, Any]] = field(default_factory=list)
    """Nuisance constants whose calibration ended at a bound of their range, each with the
    range widened and the base model refitted (:func:`~vadsim.fit.nuisance.widen`):
    ``name``, ``bound``, ``value`` where it stopped, ``from`` and ``to`` ranges. Every
    hypothesis is fitted over the widened ranges."""
    widened_chosen: list[dict[str, Any]] = field(default_factory=list)
    """Ranges the chosen model ended at a bound of, each widened and the model refitted
    (:func:`~vadsim.fit.diagnosis.hypotheses.refit_widening`): ``of`` (the candidate's id,
    or ``"nuisance"``), ``name``, ``bound``, ``value`` where it stopped, ``from`` and ``to``
    ranges. The reported values are the refit's."""
    review: list[dict[str, Any]] = field(default_factory=list)
    """The review of the chosen model (:func:`review`): each refit, ``action`` ``"swap"``
    (candidate ``from`` refitted as its variant ``to``) or ``"drop"`` (refitted without
    ``from``), the refit ``model``'s ``score`` and ``heldout_rms``, the score it was
    ``against`` and whether it was ``accepted``."""

    @property
    def ranking(self) -> list[HypothesisFit]:
        """The first step's ranking: every candidate alone (with the nuisance constants)."""
        return self.steps[0] if self.steps else []

    @property
    def policy(self) -> Policy:
        """The thresholds this result was decided with (from :attr:`settings`). A result
        recorded before ``interval_search`` was a setting had its intervals walked
        (``"walk"``), whatever today's default."""
        names = Policy.__dataclass_fields__
        given = {k: v for k, v in self.settings.items() if k in names}
        return Policy(**{"interval_search": "walk", **given})

    @property
    def none_fit(self) -> HypothesisFit:
        """The base model that "none" stands for (:func:`none_model`)."""
        return none_model(self.baseline, self.uncalibrated)

    @cached_property
    def operating_point(self) -> list[dict[str, Any]]:
        """Each recorded event's excitation line against its stated flow
        (:func:`~vadsim.fit.diagnosis.operating_point.operating_point`): evidence the fits do
        not see, where a record ran at another flow than stated."""
        return operating_point(self.campaign, self.preset, self.settings.get("overrides"))

    @property
    def final(self) -> HypothesisFit:
        """The model the verdict is about: the chosen effects, else :attr:`none_fit`."""
        return self.chosen if self.chosen is not None else self.none_fit

    @property
    def missing_physics(self) -> list[str]:
        """The chosen candidates' ids, most important first; ``["none"]`` if none."""
        return self.chosen.ids if self.chosen is not None else ["none"]

    def as_json(self) -> dict[str, Any]:
        """One JSON-ready object (the keys ``vadsim diagnose --json`` promises)."""
        final = self.final
        cand_iv, nuis_iv = final.intervals_by_id()
        nuisance = final.nuisance
        if not final.nuisance_specs:  # "none" at the nominal constants: the calibrated
            # values are still what the recordings say about them, with their intervals
            nuisance, nuis_iv = self.baseline.nuisance, self.baseline.intervals_by_id()[1]
        out: dict[str, Any] = {
            "campaign": self.campaign.name,
            "verdict": self.verdict,
            "missing_physics": self.missing_physics,
            "missing_physics_keys": list(self.chosen.keys) if self.chosen else ["none"],
            "parameters": final.parameters,
            "at_bounds": final.at_bounds,
            "intervals": {i: {k: list(v) for k, v in d.items()} for i, d in cand_iv.items()},
            "nuisance": {k: {"value": v, "interval": list(nuis_iv.get(k, (v, v)))}
                         for k, v in nuisance.items()},
            "interval_search": self.policy.interval_search,
            "unexplained": self.unexplained,
            "located": [m.as_dict() for m in self.located],
            "located_events": self.located_events,
            "heldout_error_uncalibrated": self.uncalibrated.heldout_rms,
            "heldout_error_before": self.none_fit.heldout_rms,
            "heldout_error_after": final.heldout_rms,
            "ranking": [self.none_fit.row()] + [f.row() for f in self.ranking],
            "steps": [{"step": i + 1, "ranking": [f.row() for f in step]}
                      for i, step in enumerate(self.steps)],
            "thresholds": {k: self.settings[k] for k in
                           ("min_delta", "min_reduction", "max_rms", "noise_rms",
                            "max_effects") if k in self.settings},
            "elapsed_s": self.elapsed_s,
            "evaluations": self.n_evals,
            "pairs_probed": self.pairs,
            "review": self.review,
            "widened_nuisance": self.widened_nuisance,
            "widened_chosen": self.widened_chosen,
            "noise": self.noise,
            "operating_point": self.operating_point,
        }
        if self.prediction is not None:
            out["prediction"] = self.prediction
        return jsonable(out)

    def summary(self) -> str:
        """A few lines for a terminal (written by :mod:`vadsim.report.text`)."""
        return render(self, "text")

    def verdict_text(self) -> str:
        """One sentence: what is missing, or that nothing is, or what is left unexplained."""
        return render(self, "verdict")

    def _repr_html_(self) -> str:
        return render(self, "html")



def jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    return obj
