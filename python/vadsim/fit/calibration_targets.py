"""What a calibration fits and the cost it minimises.

The targets are either a campaign's recorded features (``targets="recorded"``) or, for the
dissertation's campaigns, its own simulated results (``targets="thesis-sim"``:
:func:`thesis_targets`, simulated peaks at full resolution and one impact per cycle where its
simulation was periodic), or a mapping given. The comparison engine compares the chosen
feature keys against them (:func:`calibration_evaluator`), and the cost is the soft-L1 sum of
the standardised residuals (:func:`soft_l1`). :func:`calibration_cost` gives that cost at any
values, without fitting: what :func:`~vadsim.fit.calibrate.calibrate` minimises, for checking
identifiability by hand.

Why a module of its own: the fit, its search (:mod:`vadsim.fit.calibration_search`) and a
check by hand must read the same targets at the same cost.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from vadsim.campaigns import Campaign, campaign_preset, load_any_campaign
from vadsim.compare import CampaignEvaluator, ModelChange, recorded_features
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import Preset, make_params
from vadsim.model.settings import RunSettings
from vadsim.signals.features import Feature

__all__ = ["calibration_cost", "calibration_evaluator", "override_point", "residuals_at",
           "soft_l1", "thesis_targets"]


def thesis_targets(campaign: Campaign) -> dict[str, dict[str, Feature]]:
    """The dissertation's own simulated results of a shipped campaign as targets.

    ``x1_peak_mean_g``: its simulated peak (full resolution), spread 10 % (1.5 g at least);
    ``z_impact``: 1 impact per cycle where its simulation was periodic with one impact per
    cycle, spread 0.05; for the 7in tool, ``z_spring`` and ``z_impact`` from the published
    regime boundaries. Events without a simulated peak, or with a peak the table notes as
    misprinted, give no peak target.
    """
    out: dict[str, dict[str, Feature]] = {}
    for ev in campaign.events:
        ref = ev.reference or {}
        t: dict[str, Feature] = {}
        peak = ref.get("sim_peak_g")
        note = str(ref.get("note", ""))
        misprint = "peak" in note and "printed" in note  # 9.5in event 8's "04g"
        if peak is not None and not misprint and not (isinstance(peak, float)
                                                     and math.isnan(peak)):
            t["x1_peak_mean_g"] = Feature(float(peak), max(0.1 * float(peak), 1.5), 1)
        behaviour = str(ref.get("sim_behaviour", ""))
        if "1 impact/cycle" in behaviour:
            t["z_impact"] = Feature(1.0, 0.05, 1)
        if campaign.tool == "7in":
            t.update(_regime_targets(ev.flow_gpm))
        out[ev.id] = t
    return out


def _regime_targets(flow_gpm: float) -> dict[str, Feature]:
    """Z targets from the 7in regime boundaries (regimes_7in.csv, dissertation 4.1): a surface
    "regular" there has Z = 1, "none" Z = 0 (spread 0.05); intermittent gives no target."""
    from vadsim.data import published_regimes

    out: dict[str, Feature] = {}
    for _, row in published_regimes().iterrows():
        if row.flow_from_gpm <= flow_gpm <= row.flow_to_gpm:
            for col, key in (("surface1", "z_spring"), ("surface2", "z_impact")):
                state = row[col]
                if state in ("regular", "none"):
                    out[key] = Feature(1.0 if state == "regular" else 0.0, 0.05, 1)
    return out


def calibration_evaluator(camp: Campaign, settings: RunSettings,
                          targets: str | Mapping[str, Mapping[str, Feature]],
                          keys: Sequence[str] | None, resolution: str, workers: int | None
                          ) -> CampaignEvaluator:
    """The comparison engine set up for a calibration: its targets and compared keys.

    Why: :func:`~vadsim.fit.calibrate.calibrate` and :func:`calibration_cost` must compare
    the same features the same way, or a cost checked by hand is not the cost minimised.

    Parameters
    ----------
    camp
        The campaign.
    settings
        The base model and the run length.
    targets, keys, resolution, workers
        As for :func:`~vadsim.fit.calibrate.calibrate`.

    Returns
    -------
    CampaignEvaluator
        To be used as a context manager (it owns its workers).

    Raises
    ------
    ValueError
        A resolution or targets not understood, or no target left to fit.
    """
    if resolution not in ("sensor", "full"):
        raise ValueError(f"resolution = {resolution!r} must be 'sensor' or 'full'")
    if isinstance(targets, str):
        if targets == "recorded":
            tgt = {ev.id: recorded_features(camp, ev, settings.f_exc_hz(ev.flow_gpm))
                   for ev in camp.events}
        elif targets == "thesis-sim":
            tgt = thesis_targets(camp)
        else:
            raise ValueError(f"targets = {targets!r} must be 'recorded', 'thesis-sim' or "
                             "a mapping")
    else:
        tgt = {k: dict(v) for k, v in targets.items()}
    chosen = {ev.id: [k for k in tgt.get(ev.id, {}) if keys is None or k in keys]
              for ev in camp.events}
    if not any(chosen.values()):
        raise ValueError("no targets to fit (check keys and targets)")
    return CampaignEvaluator(camp, settings, targets=tgt, keys=chosen, resolution=resolution,
                             workers=workers)


def override_point(values: Mapping[str, float]
                   ) -> tuple[tuple[tuple[str, float], ...], ModelChange]:
    """A point's cache key in the comparison engine and its change to the base model.

    Why: the search, its profile and its bootstrap thresholds evaluate points through the
    engine's cache; one key per set of values lets a probe evaluated for its cost be read
    again without a run.

    Parameters
    ----------
    values
        Parameter values overriding the base model.

    Returns
    -------
    tuple of (tuple, ModelChange)
        The sorted overrides (hashable) and the change.
    """
    change = ModelChange(overrides={k: float(v) for k, v in values.items()})
    return tuple(sorted(change.overrides.items())), change


def residuals_at(obj: CampaignEvaluator, values: Mapping[str, float]) -> np.ndarray:
    """The campaign's standardised residuals with ``values`` overriding the base model.

    Why: every cost of a calibration (its search, its intervals, :func:`calibration_cost`)
    reads the residuals of a set of values the same way.

    Parameters
    ----------
    obj
        The calibration's comparison engine (:func:`calibration_evaluator`).
    values
        Parameter values overriding the base model.

    Returns
    -------
    numpy.ndarray
        Every compared feature of every event (a failed run gives
        :data:`vadsim.compare.FAILED_RESIDUAL`).
    """
    return obj.residuals(*override_point(values))


def soft_l1(r: np.ndarray) -> float:
    """The calibration's cost of standardised residuals: ``sum 2 (sqrt(1 + r^2) - 1)``.

    Why: a residual counts quadratically near 0 and linearly far out, so a few features the
    model cannot match (a regime change) do not decide the fit. It is twice the cost
    ``scipy.optimize.least_squares(loss="soft_l1")`` minimises in the local polish.

    Parameters
    ----------
    r
        Standardised residuals.

    Returns
    -------
    float
        The cost.
    """
    return float(np.sum(2.0 * (np.sqrt(1.0 + r ** 2) - 1.0)))


def calibration_cost(
    campaign: str | os.PathLike[str] | Campaign,
    values: Mapping[str, float],
    *,
    targets: str | Mapping[str, Mapping[str, Feature]] = "recorded",
    keys: Sequence[str] | None = None,
    resolution: str = "sensor",
    overrides: Mapping[str, float] | None = None,
    cycles: float = DEFAULTS.cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    workers: int | None = None,
    preset: Preset | None = None,
) -> tuple[float, pd.DataFrame]:
    """The cost :func:`~vadsim.fit.calibrate.calibrate` minimises, at given parameter values,
    without fitting.

    Why so many parameters: they are :func:`~vadsim.fit.calibrate.calibrate`'s own minus the
    search's, so that the cost is computed on exactly the targets, model and runs a
    calibration would use.

    For checking identifiability: compare the cost at the truth of a synthetic campaign with
    the cost at a suspected alias (e.g. ``l0`` shifted by one excitation-phase period). The
    arguments mean what they mean for :func:`~vadsim.fit.calibrate.calibrate`; ``values``
    override the preset (on top of ``overrides``).

    Returns
    -------
    (float, pandas.DataFrame)
        The soft-L1 cost ``sum 2 (sqrt(1 + r^2) - 1)`` of the standardised residuals, and the
        residuals (events x feature keys; a failed run gives
        :data:`vadsim.compare.FAILED_RESIDUAL`).
    """
    camp = load_any_campaign(campaign)
    settings = RunSettings(preset or campaign_preset(camp), overrides=overrides or {},
                           cycles=cycles, analyse_cycles=analyse_cycles)
    make_params(settings.preset, {**settings.overrides, **values})  # names checked first
    with calibration_evaluator(camp, settings, targets, keys, resolution, workers) as obj:
        r = residuals_at(obj, values)
        return soft_l1(r), obj.table(r)
