"""Calibration: fit chosen parameters to a campaign's features.

Why this module exists: the dissertation withholds the standard length ``l0`` and the weight
on bit per unit reference mass ``wob``; field recordings disagree with any model in details.
:func:`calibrate` fits parameters by robust least squares on standardised residuals (features
of the simulation vs the targets, divided by the targets' spreads). This module holds what a
user calls: :func:`calibrate`, the checks of its arguments and the default search ranges
(:data:`DEFAULT_BOUNDS`). The rest lives in two modules:

* :mod:`vadsim.fit.calibration_targets`: what is fitted (a campaign's recorded features, or
  the dissertation's own simulated results) and the cost minimised;
* :mod:`vadsim.fit.calibration_search`: the search -- a global stage, a local polish, the
  search of ``l0``'s phase-alias stripes, the uncertainty and intervals at the optimum -- and
  its :class:`~vadsim.fit.calibration_search.CalibrationResult`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from vadsim._progress import bar
from vadsim.campaigns import Campaign, campaign_preset, load_any_campaign
from vadsim.fit.calibration_search import CalibrationResult, CalibrationSearch
from vadsim.fit.calibration_targets import calibration_evaluator
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import Preset, canonical_name, make_params, param_names
from vadsim.model.settings import RunSettings
from vadsim.signals.features import Feature

__all__ = ["DEFAULT_BOUNDS", "calibrate"]

DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "l0": (0.4, 1.4),
    "wob": (200.0, 2500.0),
}
"""Search ranges of the withheld constants: l0 in metres, wob in N/kg. ``theta0`` (rad)
searches half a turn each side of its start (every distinct phase once: theta0 + pi is the
same steady state); an unset one (nan) cannot be calibrated: set it first."""


def calibrate(
    campaign: str | os.PathLike[str] | Campaign,
    names: Sequence[str] = ("l0", "wob"),
    *,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    start: Mapping[str, float] | None = None,
    targets: str | Mapping[str, Mapping[str, Feature]] = "recorded",
    keys: Sequence[str] | None = None,
    resolution: str = "sensor",
    overrides: Mapping[str, float] | None = None,
    global_stage: bool | str = "scan",
    n_global: int = 512,
    n_starts: int = 3,
    alias_stripes: int = 4,
    alias_grid: int = 16,
    alias_refine: int = 17,
    max_alias_rounds: int = 20,
    max_nfev: int = 40,
    popsize: int = 8,
    maxiter: int = 10,
    seed: int = 1,
    profile_points: int = 0,
    interval_method: str = "auto",
    n_boot: int = 50,
    noise_g: float = 0.3,
    cycles: float = DEFAULTS.cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    workers: int | None = None,
    preset: Preset | None = None,
    callback: Callable[[str, int, float, dict[str, float]], None] | None = None,
    progress: bool = True,
) -> CalibrationResult:
    """Fit ``names`` to a campaign by robust least squares on standardised residuals.

    Why so many parameters: they group into what is fitted (``campaign`` to ``overrides``),
    the budget of each search stage (``global_stage`` to ``seed``), how the intervals are
    drawn (``profile_points`` to ``noise_g``), the runs (``cycles`` to ``preset``) and what
    the caller sees (``callback``, ``progress``). Each stage has its own budget because the
    cost is rough (regime changes, ``l0``'s phase aliases) and a quick check and a full
    calibration need very different ones (the recovery test runs every stage small); most
    map one to one to an option of ``vadsim calibrate``.

    Parameters
    ----------
    campaign
        A campaign (folder, TOML, ``"thesis:7in-cde"``...) or a loaded :class:`Campaign`.
    names
        Parameters to fit (Table 2.1 names, ``l0``, ``wob``...; ``wob_n_per_kg`` is ``wob``,
        the weight on bit per unit reference mass, N/kg).
    bounds
        Search range per name (defaults: :data:`DEFAULT_BOUNDS`, else 0.5x-2x the start).
    start
        Starting values (default: the preset's, with ``overrides``); the fit "before" is here.
    targets
        ``"recorded"`` (the campaign's features), ``"thesis-sim"`` (see
        :func:`~vadsim.fit.calibration_targets.thesis_targets`) or a mapping
        ``{event: {key: Feature}}``.
    keys
        Feature keys to fit (default: every key both sides have).
    resolution
        Simulated features ``"sensor"`` (through each sensor chain, for recordings) or
        ``"full"`` (solver resolution, as the dissertation's simulations).
    global_stage
        ``"scan"`` (default): evaluate ``n_global`` (rounded up to a power of two)
        scrambled-Sobol points over the bounds,
        then polish locally from the ``n_starts`` best distinct ones. The basin of ``l0`` is
        under 1 % wide (the excitation phase beta (x2 - x3) moves 1.9 rad per 0.005 of
        ``l0``), so the scan must be dense: 512 points space ``l0`` by ~0.002 over 0.4-1.4.
        ``"de"``: differential evolution (``popsize``, ``maxiter``). False: only the local
        polish from ``start``.
    alias_stripes, alias_grid, alias_refine
        When fitting ``l0``: search this many phase-alias stripes on each side of the best
        fit (half a period of the excitation phase apart: 0.0083 m for the 7in tool), on each
        a grid of ``alias_grid`` values of the other parameter (log-spaced if its bounds span
        4x or more; a Sobol' set for several), refined by ``alias_refine`` values around the
        best cells of the ``n_starts`` best stripes, then polish from the ``n_starts`` best
        distinct points (see the comment in the code; ``alias_stripes=0`` turns it off).
        While the best stripe is at an end of those scanned, up to ``max_alias_rounds``
        times ``alias_stripes`` more stripes are scanned beyond it. Only while ``theta0`` is
        unset (``theta0=nan``): a set phase at rest (every built-in preset's) makes ``l0`` a
        length scale without aliases, and the search is skipped.
    max_nfev
        Evaluations per local polish (``scipy.optimize.least_squares``).
    profile_points
        If > 0, also profile the cost along each parameter (others at the optimum).
    interval_method
        How far the cost may rise inside a 95 % interval: ``"bootstrap"`` measures it on
        ``n_boot`` campaigns the fitted model writes (through the sensor chains, at random
        sampling phases, with ``noise_g`` g of sensor noise; :mod:`vadsim.fit.bootstrap`),
        ``"profile"`` takes ``chi2(1) s^2`` (independent residuals, which a recording's
        features are not: too narrow), ``"auto"`` (default) the bootstrap where the targets
        are recorded time series, else the profile. The bootstrap's threshold is never
        below the profile's.
    callback
        Called as ``callback(stage, evaluation, cost, params)``.
    progress
        Show a progress bar of the campaign evaluations and the best cost so far (stderr).

    Returns
    -------
    CalibrationResult
        ``interval``: 95 % intervals from the cost along each parameter (the others at the
        optimum): where the cost stays within ``threshold`` of its minimum (see
        ``interval_method``; the profile's is ``CHI2_95 s^2``, ``s^2`` the residual variance,
        at least 1: the residuals are in units of the recordings' spreads).
        ``stderr`` from the Jacobian of the standardised residuals
        (``cov = s^2 (J^T J)^-1``) is kept for reference: on this rough cost (regime changes,
        phase aliases) it is far too small, so summaries quote the interval.
    """
    camp = load_any_campaign(campaign)
    settings = RunSettings(preset or campaign_preset(camp), overrides=overrides or {},
                           cycles=cycles, analyse_cycles=analyse_cycles)
    names = [canonical_name(n) for n in names]
    bounds = {canonical_name(k): v for k, v in (bounds or {}).items()}
    start = {canonical_name(k): v for k, v in (start or {}).items()}
    x0, lim = _start_and_bounds(settings, names, bounds, start)
    # l0 moves the excitation phase (and has 8.3 mm aliases) only while theta0 is unset
    if not math.isnan(settings.param("theta0")) or "theta0" in names:
        alias_stripes = 0
    method = _interval_method(interval_method, targets, resolution, camp)
    if method == "bootstrap" and not (isinstance(n_boot, int) and not isinstance(n_boot, bool)
                                      and n_boot >= 2):
        raise ValueError(f"n_boot = {n_boot!r} must be an integer >= 2")
    if method == "bootstrap" and not (noise_g >= 0 and math.isfinite(noise_g)):
        raise ValueError(f"noise_g = {noise_g!r} must be a finite number >= 0 (g RMS)")
    options: dict[str, Any] = dict(global_stage=global_stage, n_global=n_global, n_starts=n_starts,
                   alias_stripes=alias_stripes, alias_grid=alias_grid,
                   alias_refine=alias_refine, max_alias_rounds=max_alias_rounds,
                   max_nfev=max_nfev, popsize=popsize, maxiter=maxiter, seed=seed)
    with calibration_evaluator(camp, settings, targets, keys, resolution, workers) as obj:
        with bar(progress, None, f"calibrate {camp.name}", "evaluation") as b:
            fit = CalibrationSearch(obj, names, x0, lim, callback, bar=b, **options)
            result = fit.run(profile_points, method, n_boot=n_boot, noise_g=noise_g)
    result.settings = dict(targets=targets if isinstance(targets, str) else "custom",
                           resolution=resolution, keys=list(keys) if keys else None,
                           bounds={n: list(lim[n]) for n in names}, cycles=cycles,
                           analyse_cycles=analyse_cycles, interval_method=method,
                           n_boot=n_boot, noise_g=noise_g, **options)
    return result


def _interval_method(method: str, targets: Any, resolution: str, camp: Campaign) -> str:
    """The interval method ``"auto"`` stands for, or ``method`` checked."""
    drawable = (isinstance(targets, str) and targets == "recorded" and resolution == "sensor"
                and all(ev.data is not None for ev in camp.events))
    if method == "auto":
        return "bootstrap" if drawable else "profile"
    if method == "bootstrap" and not drawable:
        raise ValueError("interval_method = 'bootstrap' draws recordings: it needs "
                         "targets='recorded', resolution='sensor' and time series in every "
                         "event")
    if method not in ("bootstrap", "profile"):
        raise ValueError(f"interval_method = {method!r} must be 'auto', 'bootstrap' or "
                         "'profile'")
    return method


def _start_and_bounds(settings: RunSettings, names: list[str],
                      bounds: Mapping[str, tuple[float, float]] | None,
                      start: Mapping[str, float] | None
                      ) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
    """Checked starting values and search ranges of the fitted parameters."""
    if not names:
        raise ValueError("names is empty: nothing to calibrate")
    base = {**settings.preset.params, **settings.overrides}
    make_params(base)  # every name and override checked before any run
    for n in names:
        if n not in param_names():
            raise ValueError(f"unknown parameter {n!r}")
    x0 = {n: float((start or {}).get(n, settings.param(n))) for n in names}
    for n in names:
        if not math.isfinite(x0[n]):
            raise ValueError(f"start {n} = {x0[n]!r} is unset: give a start (e.g. {n} = the "
                             "value the preset derives, vadsim.model.presets.rest_phase) or set it")
    lim: dict[str, tuple[float, float]] = {}
    for n in names:
        if bounds and n in bounds:
            lo, hi = (float(v) for v in bounds[n])
        elif n in DEFAULT_BOUNDS:
            lo, hi = DEFAULT_BOUNDS[n]
        elif n == "theta0":
            lo, hi = x0[n] - math.pi / 2, x0[n] + math.pi / 2
        else:
            lo, hi = (0.5 * x0[n], 2.0 * x0[n]) if x0[n] > 0 else (2.0 * x0[n], 0.5 * x0[n])
        lim[n] = (lo, hi)
        if not (lo < hi):
            raise ValueError(f"bounds of {n}: {lim[n]} must have lo < hi")
        if not (lo <= x0[n] <= hi):
            raise ValueError(f"start {n} = {x0[n]} is outside its bounds {lim[n]}")
    return x0, lim


