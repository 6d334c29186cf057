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
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vadsim.fit.validate import (
    EventSimulation,
    campaign_preset,
    event_residuals,
    load_any_campaign,
    recorded_features,
    simulate_event,
)
from vadsim.model.presets import Preset, make_params
from vadsim.model.simulate import SolverError, simulate
from vadsim.campaigns import Campaign
from vadsim.signals.features import Feature

__all__ = ["CalibrationResult", "DEFAULT_BOUNDS", "calibrate", "calibration_cost",
           "thesis_targets"]

DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "l0": (0.4, 1.4),
    "wob": (200.0, 2500.0),
}
"""Search ranges of the withheld constants: l0 in metres, wob in N/kg."""

FAILED_RESIDUAL = 30.0
"""Residual given to every target of an event whose run fails, so the search moves away."""


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
    from vadsim.studies.thesis import published_regimes

    out: dict[str, Feature] = {}
    for _, row in published_regimes().iterrows():
        if row.flow_from_gpm <= flow_gpm <= row.flow_to_gpm:
            for col, key in (("surface1", "z_spring"), ("surface2", "z_impact")):
                state = row[col]
                if state in ("regular", "none"):
                    out[key] = Feature(1.0 if state == "regular" else 0.0, 0.05, 1)
    return out


def _full_resolution_event(campaign: Campaign, event, preset: Preset,
                          overrides: Mapping[str, float], cycles: float,
                          analyse_cycles: float) -> EventSimulation:
    """Peaks and impacts per cycle at full resolution from the core's own steady-window
    summary (20 kHz): no time series is stored, which makes a 9.5in run 10x cheaper."""
    r = simulate(preset, event.flow_gpm, cycles=cycles, analyse_cycles=analyse_cycles,
                 overrides=overrides, wob_klbf=event.wob_klbf, record="none")
    full: dict[str, Feature] = {}
    for name, s in campaign.sensors.items():
        peaks = r.window_peaks_g[:, s.dof - 1]
        if peaks.size:
            full[f"{name}_peak_mean_g"] = Feature(float(peaks.mean()), float(peaks.std()),
                                                  int(peaks.size))
            full[f"{name}_peak_std_g"] = Feature(float(peaks.std()), math.nan, int(peaks.size))
    return EventSimulation(event_id=event.id, flow_gpm=event.flow_gpm,
                           wob_klbf=float(event.wob_klbf), f_exc_hz=r.f_exc_hz, sensor={},
                           full=full, z=r.z, scenario=r.scenario)


def _event_residuals(sim: EventSimulation, targets: Mapping[str, Feature],
                     resolution: str) -> dict[str, float]:
    out = event_residuals(sim, targets, resolution)
    for k, v in sim.z.items():  # impacts per cycle of the run itself, e.g. "z_impact"
        t = targets.get(f"z_{k}")
        if t is not None:
            out[f"z_{k}"] = (v - t.value) / t.spread
    return out


class _Objective:
    """The standardised residuals of a campaign at given parameter values (shared by
    :func:`calibrate` and :func:`calibration_cost`)."""

    def __init__(self, camp: Campaign, preset: Preset, targets, keys, resolution: str,
                 overrides: Mapping[str, float] | None, cycles: float, analyse_cycles: float,
                 pool: ThreadPoolExecutor) -> None:
        if resolution not in ("sensor", "full"):
            raise ValueError(f"resolution = {resolution!r} must be 'sensor' or 'full'")
        if isinstance(targets, str):
            if targets == "recorded":
                tgt = {ev.id: recorded_features(camp, ev, preset.params["alpha"] * ev.flow_gpm
                                                / (2 * math.pi)) for ev in camp.events}
            elif targets == "thesis-sim":
                tgt = thesis_targets(camp)
            else:
                raise ValueError(f"targets = {targets!r} must be 'recorded', 'thesis-sim' or "
                                 "a mapping")
        else:
            tgt = {k: dict(v) for k, v in targets.items()}
        self.pairs = [(ev.id, k) for ev in camp.events for k in tgt.get(ev.id, {})
                      if keys is None or k in keys]
        if not self.pairs:
            raise ValueError("no targets to fit (check keys and targets)")
        self.camp, self.preset, self.tgt, self.resolution = camp, preset, tgt, resolution
        self.overrides, self.cycles, self.analyse_cycles = overrides, cycles, analyse_cycles
        self.pool = pool

    def run_all(self, values: Mapping[str, float]) -> dict[str, EventSimulation | None]:
        ov = {**(self.overrides or {}), **values}
        camp, preset = self.camp, self.preset

        def one(ev):
            try:
                if self.resolution == "full":
                    return _full_resolution_event(camp, ev, preset, ov, self.cycles,
                                                  self.analyse_cycles)
                return simulate_event(camp, ev, preset=preset, overrides=ov, cycles=self.cycles,
                                      analyse_cycles=self.analyse_cycles)
            except (SolverError, ValueError):
                return None

        return dict(zip([ev.id for ev in camp.events],
                        self.pool.map(one, camp.events), strict=True))

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        sims = self.run_all(values)
        per_event: dict[str, dict[str, float]] = {}
        out = np.empty(len(self.pairs))
        for i, (eid, key) in enumerate(self.pairs):
            sim = sims[eid]
            if sim is None:
                out[i] = FAILED_RESIDUAL
                continue
            if eid not in per_event:
                per_event[eid] = _event_residuals(sim, self.tgt[eid], self.resolution)
            out[i] = per_event[eid].get(key, FAILED_RESIDUAL)
        return out

    def table(self, r: np.ndarray) -> pd.DataFrame:
        df = pd.DataFrame(index=[ev.id for ev in self.camp.events])
        for (eid, key), v in zip(self.pairs, r, strict=True):
            df.loc[eid, key] = v
        return df


def calibration_cost(
    campaign: str | os.PathLike[str] | Campaign,
    values: Mapping[str, float],
    *,
    targets: str | Mapping[str, Mapping[str, Feature]] = "recorded",
    keys: Sequence[str] | None = None,
    resolution: str = "sensor",
    overrides: Mapping[str, float] | None = None,
    cycles: float = 400,
    analyse_cycles: float = 200,
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
        residuals (events x feature keys; a failed run gives ``FAILED_RESIDUAL``).
    """
    camp = load_any_campaign(campaign)
    preset = preset or campaign_preset(camp)
    make_params({**preset.params, **(overrides or {}), **values})  # names checked first
    with ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
        obj = _Objective(camp, preset, targets, keys, resolution, overrides, cycles,
                         analyse_cycles, pool)
        r = obj.residuals({k: float(v) for k, v in values.items()})
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
    seconds: float = 0.0
    evaluations: int = 0
    settings: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> str:
        """A few lines a person can read."""
        lines = [f"calibrated {', '.join(self.names)} in {self.seconds:.0f} s "
                 f"({self.evaluations} campaign evaluations)"]
        for n in self.names:
            lines.append(f"  {n:>6} = {self.estimates[n]:.6g} +- {self.stderr[n]:.2g}   "
                         f"(start {self.start[n]:.6g})")
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
    cycles: float = 400,
    analyse_cycles: float = 200,
    workers: int | None = None,
    preset: Preset | None = None,
    callback: Callable[[str, int, float, dict[str, float]], None] | None = None,
) -> CalibrationResult:
    """Fit ``names`` to a campaign by robust least squares on standardised residuals.

    Parameters
    ----------
    campaign
        A campaign (folder, TOML, ``"thesis:7in-cde"``...) or a loaded :class:`Campaign`.
    names
        Parameters to fit (Table 2.1 names, ``l0``, ``wob``...).
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
        times ``alias_stripes`` more stripes are scanned beyond it.
    max_nfev
        Evaluations per local polish (``scipy.optimize.least_squares``).
    profile_points
        If > 0, also profile the cost along each parameter (others at the optimum).
    callback
        Called as ``callback(stage, evaluation, cost, params)``.

    Returns
    -------
    CalibrationResult
        ``stderr`` from the Jacobian of the standardised residuals at the optimum
        (``cov = s^2 (J^T J)^-1``, ``s^2`` the residual variance).
    """
    from scipy.optimize import differential_evolution, least_squares

    camp = load_any_campaign(campaign)
    preset = preset or campaign_preset(camp)
    if resolution not in ("sensor", "full"):
        raise ValueError(f"resolution = {resolution!r} must be 'sensor' or 'full'")
    names = list(names)
    if not names:
        raise ValueError("names is empty: nothing to calibrate")
    base = {**preset.params, **(overrides or {})}
    make_params(base)  # every name and override checked before any run
    for n in names:
        if n not in base:
            raise ValueError(f"unknown parameter {n!r}")
    x0 = {n: float((start or {}).get(n, base[n])) for n in names}
    lim = {}
    for n in names:
        if bounds and n in bounds:
            lim[n] = tuple(float(v) for v in bounds[n])
        elif n in DEFAULT_BOUNDS:
            lim[n] = DEFAULT_BOUNDS[n]
        else:
            lim[n] = (0.5 * x0[n], 2.0 * x0[n]) if x0[n] > 0 else (2.0 * x0[n], 0.5 * x0[n])
        lo, hi = lim[n]
        if not (lo < hi):
            raise ValueError(f"bounds of {n}: {lim[n]} must have lo < hi")
        if not (lo <= x0[n] <= hi):
            raise ValueError(f"start {n} = {x0[n]} is outside its bounds {lim[n]}")

    evals = [0]
    history: list[dict[str, float]] = []
    pool = ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1)
    try:
        obj = _Objective(camp, preset, targets, keys, resolution, overrides, cycles,
                         analyse_cycles, pool)
    except ValueError:
        pool.shutdown(wait=True)
        raise

    def residuals(values: Mapping[str, float]) -> np.ndarray:
        out = obj.residuals(values)
        evals[0] += 1
        history.append({**values, "cost": _soft_l1(out)})
        return out

    table = obj.table

    t0 = time.perf_counter()
    try:
        r_before = residuals(x0)
        scale = np.array([hi - lo for lo, hi in (lim[n] for n in names)])
        lo_u = np.array([lim[n][0] for n in names]) / scale
        hi_u = np.array([lim[n][1] for n in names]) / scale

        def g(u: np.ndarray) -> np.ndarray:
            vals = dict(zip(names, (float(v) for v in u * scale), strict=True))
            r = residuals(vals)
            if callback:
                callback("local", evals[0], _soft_l1(r), vals)
            return r

        def polish(x: Mapping[str, float]):
            u0 = np.clip(np.array([x[n] for n in names]) / scale, lo_u, hi_u)
            return least_squares(g, u0, bounds=(lo_u, hi_u), loss="soft_l1", diff_step=1e-3,
                                 max_nfev=max_nfev, x_scale=1.0)

        def alias_search(ls):
            # l0 enters the excitation F_H = Fo cos(w t + phi) sin(beta (x2 - x3) + psi) through
            # the static anvil-housing distance x2 - x3 ~ (L3 - LI - LOn) l0. A shift of the
            # phase by pi flips the sign of F_H, which is the same as shifting time by half an
            # excitation cycle, and a recording's time origin is arbitrary: steady features
            # repeat every half period pi / (beta (L3 - LI - LOn)) of l0 (0.0083 m for the 7in
            # tool, 1.2 % of l0), up to the small change of the gaps, which scale with l0.
            # Each such stripe is a valley under 0.001 m wide along which the other parameters
            # (wob) move freely, and its cost in them is rough (regime changes), so a local
            # polish from a neighbouring stripe keeps the other parameters where they were.
            # Scan instead: on each of the 2 alias_stripes + 1 stripes around the best fit,
            # a coarse grid of the other parameters, then a finer one around the best cells,
            # then polish the best distinct points.
            best = dict(zip(names, (float(v) for v in ls.x * scale), strict=True))
            p0 = {**base, **best}
            half = math.pi / (abs(p0["beta"]) * (p0["L3"] - p0["LI"] - p0["LOn"]))
            others = [n for n in names if n != "l0"]

            def stripe(k: int) -> float:
                return best["l0"] + k * half

            def in_bounds(k: int) -> bool:
                return lim["l0"][0] <= stripe(k) <= lim["l0"][1]

            def grid1(lo: float, hi: float, num: int) -> np.ndarray:
                if lo > 0 and hi / lo >= 4:
                    return np.geomspace(lo, hi, num)
                return np.linspace(lo, hi, num)

            scored: list[tuple[float, dict[str, float]]] = []
            by_stripe: dict[int, float] = {}

            def score(k: int, vals: dict[str, float]) -> None:
                c = _soft_l1(residuals(vals))
                scored.append((c, vals))
                by_stripe[k] = min(by_stripe.get(k, math.inf), c)
                if callback:
                    callback("alias", evals[0], c, vals)

            if len(others) == 1:
                coarse = grid1(*lim[others[0]], alias_grid)
                others_grid = [{others[0]: float(w)} for w in coarse]
            elif others:
                from scipy.stats import qmc

                m = max(1, math.ceil(math.log2(max(alias_grid * len(others), 2))))
                pts = qmc.Sobol(d=len(others), scramble=True, seed=seed + 1).random_base2(m)
                others_grid = [{n: lim[n][0] + float(ui) * (lim[n][1] - lim[n][0])
                                for n, ui in zip(others, u, strict=True)} for u in pts]
            else:
                others_grid = [{}]

            def scan_stripes(ks) -> None:
                for k in ks:
                    if k not in by_stripe and in_bounds(k):
                        for ov in others_grid:
                            score(k, {"l0": stripe(k), **ov})

            # The fit of the stripes trends over many of them (the gaps scale with l0), so
            # walk: while the best stripe is at an end of those scanned, scan further.
            scan_stripes(range(-alias_stripes, alias_stripes + 1))
            for _ in range(max_alias_rounds):
                if not by_stripe:
                    break
                k_best = min(by_stripe, key=by_stripe.__getitem__)
                lo_k, hi_k = min(by_stripe), max(by_stripe)
                new: list[int] = []
                if k_best >= hi_k - 1 and in_bounds(hi_k + 1):
                    new += range(hi_k + 1, hi_k + alias_stripes + 1)
                if k_best <= lo_k + 1 and in_bounds(lo_k - 1):
                    new += range(lo_k - alias_stripes, lo_k)
                if not new:
                    break
                scan_stripes(new)
            if len(others) == 1:
                # Finer: +-1 coarse step around the best cells of the n_starts best stripes.
                (o,) = others
                done: list[float] = []
                for _, vals in sorted(scored, key=lambda cv: cv[0]):
                    if len(done) >= n_starts:
                        break
                    if any(abs(vals["l0"] - v) < 0.5 * half for v in done):
                        continue
                    done.append(vals["l0"])
                    i = int(np.argmin(np.abs(coarse - vals[o])))
                    fine = grid1(coarse[max(i - 1, 0)], coarse[min(i + 1, coarse.size - 1)],
                                 alias_refine)
                    k = round((vals["l0"] - best["l0"]) / half)
                    for w in fine:
                        if not np.any(np.isclose(w, coarse)):
                            score(k, {"l0": vals["l0"], o: float(w)})
            ranked = sorted(scored, key=lambda cv: cv[0])
            starts: list[dict[str, float]] = []
            for _, vals in ranked:
                if len(starts) >= n_starts:
                    break
                if all(abs(vals["l0"] - c["l0"]) > 0.5 * half or any(
                        abs(vals[n] - c[n]) > 0.02 * (lim[n][1] - lim[n][0]) for n in others)
                       for c in starts):
                    starts.append(vals)
            for cand in starts:
                fit = polish(cand)
                if fit.cost < ls.cost:
                    ls = fit
            return ls

        candidates: list[dict[str, float]] = [dict(x0)]
        if global_stage in ("scan", True):
            from scipy.stats import qmc

            # Sobol' points balance only in powers of two: round n_global up to one.
            m = max(1, math.ceil(math.log2(max(n_global, 2))))
            pts = qmc.Sobol(d=len(names), scramble=True, seed=seed).random_base2(m)
            scored = []
            for u in pts:
                vals = {n: lim[n][0] + float(ui) * (lim[n][1] - lim[n][0])
                        for n, ui in zip(names, u, strict=True)}
                c = _soft_l1(residuals(vals))
                scored.append((c, vals))
                if callback:
                    callback("global", evals[0], c, vals)
            scored.sort(key=lambda cv: cv[0])
            # Distinct starts: at least 2 % of the range apart in some parameter.
            for _, vals in scored:
                if len(candidates) > n_starts:
                    break
                if all(max(abs(vals[n] - c[n]) / (lim[n][1] - lim[n][0]) for n in names) > 0.02
                       for c in candidates[1:]):
                    candidates.append(vals)
            candidates = candidates[1:]
        elif global_stage == "de":
            def f(x: np.ndarray) -> float:
                vals = dict(zip(names, (float(v) for v in x), strict=True))
                c = _soft_l1(residuals(vals))
                if callback:
                    callback("global", evals[0], c, vals)
                return c

            de = differential_evolution(
                f, [lim[n] for n in names], popsize=popsize, maxiter=maxiter, seed=seed,
                polish=False, init="sobol", tol=0.0, updating="deferred",
                x0=np.array([x0[n] for n in names]),
            )
            candidates = [dict(zip(names, (float(v) for v in de.x), strict=True))]
        elif global_stage is not False:
            raise ValueError(f"global_stage = {global_stage!r} must be 'scan', 'de' or False")
        fits = [polish(c) for c in candidates]
        ls = min(fits, key=lambda fr: fr.cost)
        if "l0" in names and alias_stripes > 0:
            ls = alias_search(ls)
        # least_squares only accepts steps that lower its cost, so the polished point is never
        # worse than its start, and ls.fun already holds its residuals: no re-evaluation.
        est = dict(zip(names, (float(v) for v in ls.x * scale), strict=True))
        r_after = np.asarray(ls.fun, dtype=float)
        # Uncertainty from the local Jacobian (in parameter units).
        jac = ls.jac / scale
        m, n = jac.shape
        dof = max(m - n, 1)
        s2 = float(np.sum(r_after ** 2)) / dof
        try:
            cov = np.linalg.pinv(jac.T @ jac) * s2
            stderr = {nm: float(math.sqrt(max(cov[i, i], 0.0))) for i, nm in enumerate(names)}
        except np.linalg.LinAlgError:
            stderr = {nm: math.nan for nm in names}
        profile: dict[str, pd.DataFrame] = {}
        if profile_points > 0:
            for nm in names:
                width = max(3 * stderr[nm], 0.02 * abs(est[nm])) if math.isfinite(
                    stderr[nm]) else 0.05 * abs(est[nm])
                grid = np.linspace(max(lim[nm][0], est[nm] - width),
                                   min(lim[nm][1], est[nm] + width), profile_points)
                costs = [_soft_l1(residuals({**est, nm: float(v)})) for v in grid]
                profile[nm] = pd.DataFrame({nm: grid, "cost": costs})
    finally:
        pool.shutdown(wait=True)
    return CalibrationResult(
        names=names, start=x0, estimates=est, stderr=stderr,
        cost_before=_soft_l1(r_before), cost_after=_soft_l1(r_after),
        residuals_before=table(r_before), residuals_after=table(r_after),
        history=pd.DataFrame(history), profile=profile, seconds=time.perf_counter() - t0,
        evaluations=evals[0],
        settings=dict(targets=targets if isinstance(targets, str) else "custom",
                      resolution=resolution, keys=list(keys) if keys else None,
                      bounds={n: list(lim[n]) for n in names}, popsize=popsize,
                      maxiter=maxiter, seed=seed, cycles=cycles, analyse_cycles=analyse_cycles,
                      global_stage=global_stage, alias_stripes=alias_stripes,
                      alias_grid=alias_grid, alias_refine=alias_refine,
                      max_alias_rounds=max_alias_rounds, max_nfev=max_nfev),
    )
