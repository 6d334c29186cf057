"""Calibration: fit chosen parameters to a campaign's features.

Why this module exists: the dissertation withholds the standard length ``l0`` and the weight
on bit per unit reference mass ``wob``; field recordings disagree with any model in details.
This module fits parameters by robust least squares on standardised residuals (features of
the simulation vs the targets, divided by the targets' spreads): a global stage first
(differential evolution; the landscape is rough: Z jumps at regime boundaries and ``l0``
enters the excitation's phase ``beta (x2 - x3)``: its features repeat every half period,
0.0083 in ``l0`` for the 7in tool), then a local robust least-squares polish, a search of
those phase-alias stripes (a grid of the other parameters on each), then an uncertainty
estimate from the local Jacobian and a profile of the cost around the optimum.

Targets are either a campaign's recorded features (``targets="recorded"``) or, for the
dissertation's campaigns, its own simulated results (``targets="thesis-sim"``: simulated
peaks at full resolution and one impact per cycle where its simulation was periodic).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vadsim._progress import bar
from vadsim.campaigns import Campaign, campaign_preset, load_any_campaign
from vadsim.compare import CampaignEvaluator, ModelChange, recorded_features
from vadsim.fit.bootstrap import cost_rises
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import Preset, canonical_name, make_params, param_names
from vadsim.model.settings import RunSettings
from vadsim.signals.features import Feature

__all__ = ["CalibrationResult", "DEFAULT_BOUNDS", "calibrate", "calibration_cost",
           "thesis_targets"]

DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "l0": (0.4, 1.4),
    "wob": (200.0, 2500.0),
}
"""Search ranges of the withheld constants: l0 in metres, wob in N/kg. ``theta0`` (rad)
searches half a turn each side of its start (every distinct phase once: theta0 + pi is the
same steady state); an unset one (nan) cannot be calibrated: set it first."""



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


def _objective(camp: Campaign, settings: RunSettings, targets, keys, resolution: str,
               workers: int | None) -> CampaignEvaluator:
    """The comparison engine set up for a calibration: its targets and compared keys."""
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


def _point(values: Mapping[str, float]) -> tuple[tuple[tuple[str, float], ...], ModelChange]:
    """A point's cache key in the comparison engine and its change to the base model."""
    change = ModelChange(overrides={k: float(v) for k, v in values.items()})
    return tuple(sorted(change.overrides.items())), change


def _residuals(obj: CampaignEvaluator, values: Mapping[str, float]) -> np.ndarray:
    """The campaign's standardised residuals with ``values`` overriding the base model."""
    return obj.residuals(*_point(values))


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
    """The cost :func:`calibrate` minimises, at given parameter values, without fitting.

    For checking identifiability: compare the cost at the truth of a synthetic campaign with
    the cost at a suspected alias (e.g. ``l0`` shifted by one excitation-phase period). The
    arguments mean what they mean for :func:`calibrate`; ``values`` override the preset (on
    top of ``overrides``).

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
    with _objective(camp, settings, targets, keys, resolution, workers) as obj:
        r = _residuals(obj, values)
        return _soft_l1(r), obj.table(r)


@dataclass
class CalibrationResult:
    """Estimates with uncertainty, and the fit before and after."""

    names: list[str]
    start: dict[str, float]
    estimates: dict[str, float]
    stderr: dict[str, float]
    cost_before: float
    cost_after: float
    residuals_before: pd.DataFrame
    residuals_after: pd.DataFrame
    history: pd.DataFrame
    profile: dict[str, pd.DataFrame] = field(default_factory=dict)
    interval: dict[str, tuple[float, float]] = field(default_factory=dict)
    threshold: dict[str, float] = field(default_factory=dict)
    interval_method: str = "profile"
    seconds: float = 0.0
    evaluations: int = 0
    settings: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> str:
        """A few lines a person can read."""
        lines = [f"calibrated {', '.join(self.names)} in {self.seconds:.0f} s "
                 f"({self.evaluations} campaign evaluations)"]
        how = ("cost rise from a bootstrap of the fitted model's recordings"
               if self.interval_method == "bootstrap" else "cost rise chi2(1) s^2")
        for n in self.names:
            lo, hi = self.interval.get(n, (math.nan, math.nan))
            lines.append(f"  {n:>6} = {self.estimates[n]:.6g}, 95 % interval [{lo:.6g}, "
                         f"{hi:.6g}]   (start {self.start[n]:.6g})")
        if self.threshold:
            lines.append(f"  intervals: the values whose cost is within "
                         f"{', '.join(f'{v:.3g}' for v in self.threshold.values())} of the "
                         f"minimum ({how})")
        lines.append(f"  cost {self.cost_before:.4g} -> {self.cost_after:.4g} "
                     f"(RMS standardised residual "
                     f"{_rms(self.residuals_before):.3g} -> {_rms(self.residuals_after):.3g})")
        return "\n".join(lines)


def _rms(df: pd.DataFrame) -> float:
    v = df.to_numpy(float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v ** 2))) if v.size else math.nan


def _soft_l1(r: np.ndarray) -> float:
    return float(np.sum(2.0 * (np.sqrt(1.0 + r ** 2) - 1.0)))


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
        :func:`thesis_targets`) or a mapping ``{event: {key: Feature}}``.
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
    with _objective(camp, settings, targets, keys, resolution, workers) as obj:
        with bar(progress, None, f"calibrate {camp.name}", "evaluation") as b:
            fit = _Calibration(obj, names, x0, lim, callback, bar=b, **options)
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


CHI2_95 = 3.841458820694124
"""The 95 % quantile of chi-square with one degree of freedom: a profile interval's cost rise
(in units of the residual variance)."""


def _grid1(lo: float, hi: float, num: int) -> np.ndarray:
    """A 1-D grid, log-spaced when the range spans 4x or more."""
    if lo > 0 and hi / lo >= 4:
        return np.geomspace(lo, hi, num)
    return np.linspace(lo, hi, num)


class _Calibration:
    """One calibration: its evaluations, the global stage, the local polish, the search of
    l0's phase-alias stripes and the uncertainty at the optimum (see :func:`calibrate`)."""

    def __init__(self, obj: CampaignEvaluator, names: list[str], x0: dict[str, float],
                 lim: dict[str, tuple[float, float]], callback, *, global_stage, n_global: int,
                 n_starts: int, alias_stripes: int, alias_grid: int, alias_refine: int,
                 max_alias_rounds: int, max_nfev: int, popsize: int, maxiter: int,
                 seed: int, bar: Any = None) -> None:
        if global_stage not in ("scan", True, "de", False):
            raise ValueError(f"global_stage = {global_stage!r} must be 'scan', 'de' or False")
        self.obj, self.names, self.x0, self.lim, self.callback = obj, names, x0, lim, callback
        self.global_stage, self.n_global, self.n_starts = global_stage, n_global, n_starts
        self.alias_stripes, self.alias_grid = alias_stripes, alias_grid
        self.alias_refine, self.max_alias_rounds = alias_refine, max_alias_rounds
        self.max_nfev, self.popsize, self.maxiter, self.seed = max_nfev, popsize, maxiter, seed
        self.evals = 0
        self.bar = bar
        self.best = math.inf
        self.history: list[dict[str, float]] = []
        self.scale = np.array([hi - lo for lo, hi in (lim[n] for n in names)])
        self.lo_u = np.array([lim[n][0] for n in names]) / self.scale
        self.hi_u = np.array([lim[n][1] for n in names]) / self.scale

    # -- evaluations
    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        out = _residuals(self.obj, values)
        self.evals += 1
        cost = _soft_l1(out)
        self.history.append({**values, "cost": cost})
        if self.bar is not None:
            self.best = min(self.best, cost)
            self.bar.update()
            self.bar.set_postfix_str(f"best cost {self.best:.4g}")
        return out

    def cost(self, stage: str, values: dict[str, float]) -> float:
        c = _soft_l1(self.residuals(values))
        if self.callback:
            self.callback(stage, self.evals, c, values)
        return c

    def _values(self, x: np.ndarray) -> dict[str, float]:
        return dict(zip(self.names, (float(v) for v in x), strict=True))

    def _g(self, u: np.ndarray) -> np.ndarray:
        vals = self._values(u * self.scale)
        r = self.residuals(vals)
        if self.callback:
            self.callback("local", self.evals, _soft_l1(r), vals)
        return r

    def polish(self, x: Mapping[str, float]):
        from scipy.optimize import least_squares

        u0 = np.clip(np.array([x[n] for n in self.names]) / self.scale, self.lo_u, self.hi_u)
        return least_squares(self._g, u0, bounds=(self.lo_u, self.hi_u), loss="soft_l1",
                             diff_step=1e-3, max_nfev=self.max_nfev, x_scale=1.0)

    # -- the stages
    def global_starts(self) -> list[dict[str, float]]:
        """Starting points of the local polish from the global stage."""
        if self.global_stage in ("scan", True):
            return self._scan_starts()
        if self.global_stage == "de":
            return [self._de()]
        return [dict(self.x0)]

    def _scan_starts(self) -> list[dict[str, float]]:
        from scipy.stats import qmc

        names, lim = self.names, self.lim
        # Sobol' points balance only in powers of two: round n_global up to one.
        m = max(1, math.ceil(math.log2(max(self.n_global, 2))))
        pts = qmc.Sobol(d=len(names), scramble=True, seed=self.seed).random_base2(m)
        scored = []
        for u in pts:
            vals = {n: lim[n][0] + float(ui) * (lim[n][1] - lim[n][0])
                    for n, ui in zip(names, u, strict=True)}
            scored.append((self.cost("global", vals), vals))
        scored.sort(key=lambda cv: cv[0])
        # Distinct starts: at least 2 % of the range apart in some parameter.
        starts: list[dict[str, float]] = []
        for _, vals in scored:
            if len(starts) >= self.n_starts:
                break
            if all(max(abs(vals[n] - c[n]) / (lim[n][1] - lim[n][0]) for n in names) > 0.02
                   for c in starts):
                starts.append(vals)
        return starts

    def _de(self) -> dict[str, float]:
        from scipy.optimize import differential_evolution

        de = differential_evolution(
            lambda x: self.cost("global", self._values(x)), [self.lim[n] for n in self.names],
            popsize=self.popsize, maxiter=self.maxiter, seed=self.seed, polish=False,
            init="sobol", tol=0.0, updating="deferred",
            x0=np.array([self.x0[n] for n in self.names]),
        )
        return self._values(de.x)

    def alias_search(self, ls):
        """Search l0's phase-alias stripes around the best fit ``ls``.

        l0 enters the excitation F_H = Fo cos(w t + phi) sin(beta (x2 - x3) + psi) through the
        static anvil-housing distance x2 - x3 ~ (L3 - LI - LOn) l0. A shift of the phase by pi
        flips the sign of F_H, which is the same as shifting time by half an excitation cycle,
        and a recording's time origin is arbitrary: steady features repeat every half period
        pi / (beta (L3 - LI - LOn)) of l0 (0.0083 m for the 7in tool, 1.2 % of l0), up to the
        small change of the gaps, which scale with l0. Each such stripe is a valley under
        0.001 m wide along which the other parameters (wob) move freely, and its cost in them
        is rough (regime changes), so a local polish from a neighbouring stripe keeps the
        other parameters where they were. Scan instead: on each of the 2 alias_stripes + 1
        stripes around the best fit, a coarse grid of the other parameters, then a finer one
        around the best cells, then polish the best distinct points.
        """
        stripes = _AliasStripes(self, self._values(ls.x * self.scale))
        stripes.walk()
        stripes.refine()
        for cand in stripes.starts():
            fit = self.polish(cand)
            if fit.cost < ls.cost:
                ls = fit
        return ls

    def uncertainty(self, ls) -> dict[str, float]:
        """Standard errors from the local Jacobian (in parameter units)."""
        jac = ls.jac / self.scale
        m, n = jac.shape
        r = np.asarray(ls.fun, dtype=float)
        s2 = float(np.sum(r ** 2)) / max(m - n, 1)
        try:
            cov = np.linalg.pinv(jac.T @ jac) * s2
            return {nm: float(math.sqrt(max(cov[i, i], 0.0))) for i, nm in enumerate(self.names)}
        except np.linalg.LinAlgError:
            return {nm: math.nan for nm in self.names}

    def profile(self, est: dict[str, float], stderr: dict[str, float], points: int
                ) -> dict[str, pd.DataFrame]:
        """The cost along each parameter, the others at the optimum."""
        out: dict[str, pd.DataFrame] = {}
        for nm in self.names:
            width = max(3 * stderr[nm], 0.02 * abs(est[nm])) if math.isfinite(
                stderr[nm]) else 0.05 * abs(est[nm])
            grid = np.linspace(max(self.lim[nm][0], est[nm] - width),
                               min(self.lim[nm][1], est[nm] + width), points)
            costs = [_soft_l1(self.residuals({**est, nm: float(v)})) for v in grid]
            out[nm] = pd.DataFrame({nm: grid, "cost": costs})
        return out

    def probe_points(self, est: dict[str, float], nm: str, steps: int = 8,
                     grid: int = 25) -> np.ndarray:
        """The values of ``nm`` an interval is drawn on (the others at the optimum).

        The cost is rough (regime changes, chaotic intermittent events, phase aliases), so it
        is probed twice: walking outward from the optimum (from 0.1 % of the range,
        doubling) and on a ``grid`` over the whole range.
        """
        lo_b, hi_b = self.lim[nm]
        xs = {est[nm]} | {float(v) for v in np.linspace(lo_b, hi_b, grid)}
        for sign in (-1.0, 1.0):
            step = 0.001 * (hi_b - lo_b)
            for k in range(steps):
                xs.add(min(max(est[nm] + sign * step * (2 ** (k + 1) - 1), lo_b), hi_b))
        return np.array(sorted(xs))

    def interval(self, est: dict[str, float], nm: str, pts: np.ndarray, cost: np.ndarray,
                 limit: float) -> tuple[float, float]:
        """The values of ``nm`` whose cost stays below ``limit``: every accepted probe, out
        to the nearest rejected one beyond it on each side (or the bound). A second valley
        as good as the optimum widens it, as it should."""
        lo_b, hi_b = self.lim[nm]
        ok = np.flatnonzero(cost <= limit)
        if ok.size == 0:  # the optimum itself is on the limit: only its neighbours
            ok = np.array([int(np.argmin(np.abs(pts - est[nm])))])
        lo_i, hi_i = ok.min(), ok.max()
        return (float(pts[lo_i - 1]) if lo_i > 0 else lo_b,
                float(pts[hi_i + 1]) if hi_i < pts.size - 1 else hi_b)

    def thresholds(self, est: dict[str, float], pts: Mapping[str, np.ndarray], floor: float,
                   method: str, n_boot: int, noise_g: float) -> dict[str, float]:
        """Per parameter, how far the cost may rise inside its interval (see
        :func:`calibrate`'s ``interval_method``)."""
        if method != "bootstrap":
            return dict.fromkeys(self.names, floor)
        points: dict[Any, int] = {}
        groups: dict[str, list[int]] = {}
        items: list[tuple[Any, ModelChange]] = []
        for nm in self.names:
            for x in pts[nm]:
                key, change = _point({**est, nm: float(x)})
                if key not in points:
                    points[key] = len(items)
                    items.append((key, change))
                groups.setdefault(nm, []).append(points[key])
        got = self.obj.evaluate(items)  # every probe was evaluated for its cost: no run
        probes = [{e: got[(key, e)].sim for e in self.obj.event_ids} for key, _ in items]
        rises = cost_rises(self.obj, _point(est)[1], probes, groups, points[_point(est)[0]],
                           _soft_l1, n_boot=n_boot, noise_g=noise_g, seed=self.seed)
        return {nm: max(floor, float(np.quantile(rises[nm], 0.95))) for nm in self.names}

    def run(self, profile_points: int, method: str = "profile", *, n_boot: int = 50,
            noise_g: float = 0.3) -> CalibrationResult:
        t0 = time.perf_counter()
        r_before = self.residuals(self.x0)
        fits = [self.polish(c) for c in self.global_starts()]
        ls = min(fits, key=lambda fr: fr.cost)
        if "l0" in self.names and self.alias_stripes > 0:
            ls = self.alias_search(ls)
        # least_squares only accepts steps that lower its cost, so the polished point is never
        # worse than its start, and ls.fun already holds its residuals: no re-evaluation.
        est = self._values(ls.x * self.scale)
        r_after = np.asarray(ls.fun, dtype=float)
        stderr = self.uncertainty(ls)
        prof = self.profile(est, stderr, profile_points) if profile_points > 0 else {}
        cost_min = _soft_l1(r_after)
        # Residuals are standardised by the recordings' spreads: their variance is 1 unless
        # the fit is worse than the recordings' scatter, then it is the residual variance.
        s2 = max(float(np.sum(r_after ** 2)) / max(r_after.size - len(self.names), 1), 1.0)
        pts = {nm: self.probe_points(est, nm) for nm in self.names}
        costs = {nm: np.array([_soft_l1(self.residuals({**est, nm: float(x)})) for x in p])
                 for nm, p in pts.items()}
        threshold = self.thresholds(est, pts, CHI2_95 * s2, method, n_boot, noise_g)
        interval = {nm: self.interval(est, nm, pts[nm], costs[nm], cost_min + threshold[nm])
                    for nm in self.names}
        return CalibrationResult(
            names=self.names, start=self.x0, estimates=est, stderr=stderr,
            cost_before=_soft_l1(r_before), cost_after=_soft_l1(r_after),
            residuals_before=self.obj.table(r_before), residuals_after=self.obj.table(r_after),
            history=pd.DataFrame(self.history), profile=prof, interval=interval,
            threshold=threshold, interval_method=method,
            seconds=time.perf_counter() - t0, evaluations=self.evals,
        )


class _AliasStripes:
    """The scan of l0's phase-alias stripes (:meth:`_Calibration.alias_search`)."""

    def __init__(self, cal: _Calibration, best: dict[str, float]) -> None:
        self.cal, self.best = cal, best
        p0 = {**cal.obj.settings.preset.params, **cal.obj.settings.overrides, **best}
        self.half = math.pi / (abs(p0["beta"]) * (p0["L3"] - p0["LI"] - p0["LOn"]))
        self.others = [n for n in cal.names if n != "l0"]
        self.scored: list[tuple[float, dict[str, float]]] = []
        self.by_stripe: dict[int, float] = {}
        self.coarse = np.empty(0)
        self.grid = self._others_grid()

    def stripe(self, k: int) -> float:
        return self.best["l0"] + k * self.half

    def in_bounds(self, k: int) -> bool:
        lo, hi = self.cal.lim["l0"]
        return lo <= self.stripe(k) <= hi

    def _others_grid(self) -> list[dict[str, float]]:
        cal, others = self.cal, self.others
        if len(others) == 1:
            self.coarse = _grid1(*cal.lim[others[0]], cal.alias_grid)
            return [{others[0]: float(w)} for w in self.coarse]
        if not others:
            return [{}]
        from scipy.stats import qmc

        m = max(1, math.ceil(math.log2(max(cal.alias_grid * len(others), 2))))
        pts = qmc.Sobol(d=len(others), scramble=True, seed=cal.seed + 1).random_base2(m)
        return [{n: cal.lim[n][0] + float(ui) * (cal.lim[n][1] - cal.lim[n][0])
                 for n, ui in zip(others, u, strict=True)} for u in pts]

    def score(self, k: int, vals: dict[str, float]) -> None:
        c = self.cal.cost("alias", vals)
        self.scored.append((c, vals))
        self.by_stripe[k] = min(self.by_stripe.get(k, math.inf), c)

    def scan(self, ks) -> None:
        for k in ks:
            if k not in self.by_stripe and self.in_bounds(k):
                for ov in self.grid:
                    self.score(k, {"l0": self.stripe(k), **ov})

    def walk(self) -> None:
        """Scan the stripes around the best fit; the fit of the stripes trends over many of
        them (the gaps scale with l0), so while the best stripe is at an end of those scanned,
        scan further."""
        n = self.cal.alias_stripes
        self.scan(range(-n, n + 1))
        for _ in range(self.cal.max_alias_rounds):
            if not self.by_stripe:
                break
            k_best = min(self.by_stripe, key=self.by_stripe.__getitem__)
            lo_k, hi_k = min(self.by_stripe), max(self.by_stripe)
            new: list[int] = []
            if k_best >= hi_k - 1 and self.in_bounds(hi_k + 1):
                new += range(hi_k + 1, hi_k + n + 1)
            if k_best <= lo_k + 1 and self.in_bounds(lo_k - 1):
                new += range(lo_k - n, lo_k)
            if not new:
                break
            self.scan(new)

    def refine(self) -> None:
        """Finer: +-1 coarse step around the best cells of the n_starts best stripes."""
        if len(self.others) != 1:
            return
        (o,) = self.others
        coarse, done = self.coarse, list[float]()
        for _, vals in sorted(self.scored, key=lambda cv: cv[0]):
            if len(done) >= self.cal.n_starts:
                break
            if any(abs(vals["l0"] - v) < 0.5 * self.half for v in done):
                continue
            done.append(vals["l0"])
            i = int(np.argmin(np.abs(coarse - vals[o])))
            fine = _grid1(coarse[max(i - 1, 0)], coarse[min(i + 1, coarse.size - 1)],
                          self.cal.alias_refine)
            k = round((vals["l0"] - self.best["l0"]) / self.half)
            for w in fine:
                if not np.any(np.isclose(w, coarse)):
                    self.score(k, {"l0": vals["l0"], o: float(w)})

    def starts(self) -> list[dict[str, float]]:
        """The n_starts best distinct points."""
        lim, out = self.cal.lim, list[dict[str, float]]()
        for _, vals in sorted(self.scored, key=lambda cv: cv[0]):
            if len(out) >= self.cal.n_starts:
                break
            if all(abs(vals["l0"] - c["l0"]) > 0.5 * self.half or any(
                    abs(vals[n] - c[n]) > 0.02 * (lim[n][1] - lim[n][0]) for n in self.others)
                   for c in out):
                out.append(vals)
        return out
