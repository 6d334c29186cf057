"""The search of one calibration and what it finds.

:class:`CalibrationSearch` runs :func:`~vadsim.fit.calibrate.calibrate`'s stages on the
comparison engine: a global stage (a scrambled-Sobol scan or differential evolution; the
landscape is rough: Z jumps at regime boundaries and ``l0`` enters the excitation's phase
``beta (x2 - x3)``, its features repeating every half period, 0.0083 in ``l0`` for the 7in
tool), a local robust least-squares polish, a search of those phase-alias stripes (a grid of
the other parameters on each), then an uncertainty estimate from the local Jacobian and a
95 % interval per parameter from the cost along it (the cost rise allowed from chi-square or
from a bootstrap of the fitted model's recordings: :mod:`vadsim.fit.bootstrap`). It returns a
:class:`CalibrationResult`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from vadsim.compare import CampaignEvaluator, ModelChange
from vadsim.fit.bootstrap import cost_rises
from vadsim.fit.calibration_targets import override_point, residuals_at, soft_l1

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult

__all__ = ["CHI2_95", "CalibrationResult", "CalibrationSearch"]


CHI2_95 = 3.841458820694124
"""The 95 % quantile of chi-square with one degree of freedom: a profile interval's cost rise
(in units of the residual variance)."""


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


def _grid1(lo: float, hi: float, num: int) -> np.ndarray:
    """A 1-D grid, log-spaced when the range spans 4x or more."""
    if lo > 0 and hi / lo >= 4:
        return np.geomspace(lo, hi, num)
    return np.linspace(lo, hi, num)


class CalibrationSearch:
    """One calibration: its evaluations, the global stage, the local polish, the search of
    l0's phase-alias stripes and the uncertainty at the optimum (see
    :func:`~vadsim.fit.calibrate.calibrate`)."""

    def __init__(self, obj: CampaignEvaluator, names: list[str], x0: dict[str, float],
                 lim: dict[str, tuple[float, float]],
                 callback: Callable[[str, int, float, dict[str, float]], None] | None, *,
                 global_stage: bool | str, n_global: int,
                 n_starts: int, alias_stripes: int, alias_grid: int, alias_refine: int,
                 max_alias_rounds: int, max_nfev: int, popsize: int, maxiter: int,
                 seed: int, bar: Any = None) -> None:
        """Set up the search (no evaluation yet).

        Why so many parameters: they are :func:`~vadsim.fit.calibrate.calibrate`'s search
        options, passed on one to one (and recorded in the result's settings), so that each
        has its meaning and its default in one place, that signature.

        Parameters
        ----------
        obj
            The calibration's comparison engine
            (:func:`~vadsim.fit.calibration_targets.calibration_evaluator`).
        names, x0, lim
            The fitted parameters, their starting values and their search ranges.
        callback
            Called as ``callback(stage, evaluation, cost, params)``, or None.
        global_stage, n_global, n_starts, max_nfev, popsize, maxiter, seed
            As for :func:`~vadsim.fit.calibrate.calibrate` (the global stage and the polish).
        alias_stripes, alias_grid, alias_refine, max_alias_rounds
            As for :func:`~vadsim.fit.calibrate.calibrate` (the search of l0's aliases).
        bar
            A progress bar to advance at every evaluation, or None.
        """
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
        """The standardised residuals at ``values``: counted, kept in the history with
        their cost, and shown on the progress bar."""
        out = residuals_at(self.obj, values)
        self.evals += 1
        cost = soft_l1(out)
        self.history.append({**values, "cost": cost})
        if self.bar is not None:
            self.best = min(self.best, cost)
            self.bar.update()
            self.bar.set_postfix_str(f"best cost {self.best:.4g}")
        return out

    def cost(self, stage: str, values: dict[str, float]) -> float:
        """The cost at ``values``, reported to the callback as evaluated in ``stage``."""
        c = soft_l1(self.residuals(values))
        if self.callback:
            self.callback(stage, self.evals, c, values)
        return c

    def _values(self, x: np.ndarray) -> dict[str, float]:
        return dict(zip(self.names, (float(v) for v in x), strict=True))

    def _g(self, u: np.ndarray) -> np.ndarray:
        vals = self._values(u * self.scale)
        r = self.residuals(vals)
        if self.callback:
            self.callback("local", self.evals, soft_l1(r), vals)
        return r

    def polish(self, x: Mapping[str, float]) -> OptimizeResult:
        """The local robust least-squares polish from ``x`` (at most ``max_nfev``
        evaluations), in units of the search ranges."""
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

    def alias_search(self, ls: OptimizeResult) -> OptimizeResult:
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

    def uncertainty(self, ls: OptimizeResult) -> dict[str, float]:
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
            costs = [soft_l1(self.residuals({**est, nm: float(v)})) for v in grid]
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
        :func:`~vadsim.fit.calibrate.calibrate`'s ``interval_method``)."""
        if method != "bootstrap":
            return dict.fromkeys(self.names, floor)
        points: dict[Any, int] = {}
        groups: dict[str, list[int]] = {}
        items: list[tuple[Any, ModelChange]] = []
        for nm in self.names:
            for x in pts[nm]:
                key, change = override_point({**est, nm: float(x)})
                if key not in points:
                    points[key] = len(items)
                    items.append((key, change))
                groups.setdefault(nm, []).append(points[key])
        got = self.obj.evaluate(items)  # every probe was evaluated for its cost: no run
        probes = [{e: got[(key, e)].sim for e in self.obj.event_ids} for key, _ in items]
        rises = cost_rises(self.obj, override_point(est)[1], probes, groups,
                           points[override_point(est)[0]],
                           soft_l1, n_boot=n_boot, noise_g=noise_g, seed=self.seed)
        return {nm: max(floor, float(np.quantile(rises[nm], 0.95))) for nm in self.names}

    def run(self, profile_points: int, method: str = "profile", *, n_boot: int = 50,
            noise_g: float = 0.3) -> CalibrationResult:
        """Every stage, from the global one to the intervals (see
        :func:`~vadsim.fit.calibrate.calibrate`'s ``profile_points`` and
        ``interval_method``, ``n_boot``, ``noise_g``)."""
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
        cost_min = soft_l1(r_after)
        # Residuals are standardised by the recordings' spreads: their variance is 1 unless
        # the fit is worse than the recordings' scatter, then it is the residual variance.
        s2 = max(float(np.sum(r_after ** 2)) / max(r_after.size - len(self.names), 1), 1.0)
        pts = {nm: self.probe_points(est, nm) for nm in self.names}
        costs = {nm: np.array([soft_l1(self.residuals({**est, nm: float(x)})) for x in p])
                 for nm, p in pts.items()}
        threshold = self.thresholds(est, pts, CHI2_95 * s2, method, n_boot, noise_g)
        interval = {nm: self.interval(est, nm, pts[nm], costs[nm], cost_min + threshold[nm])
                    for nm in self.names}
        return CalibrationResult(
            names=self.names, start=self.x0, estimates=est, stderr=stderr,
            cost_before=soft_l1(r_before), cost_after=soft_l1(r_after),
            residuals_before=self.obj.table(r_before), residuals_after=self.obj.table(r_after),
            history=pd.DataFrame(self.history), profile=prof, interval=interval,
            threshold=threshold, interval_method=method,
            seconds=time.perf_counter() - t0, evaluations=self.evals,
        )


class _AliasStripes:
    """The scan of l0's phase-alias stripes (:meth:`CalibrationSearch.alias_search`)."""

    def __init__(self, cal: CalibrationSearch, best: dict[str, float]) -> None:
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
