"""Designs judged over the constants the published numbers cannot fix.

Why this module exists: a design study run at one value of the excitation phase at rest
theta0 and of the anvil-spring gap answers for that value only, and the published lengths fix
neither (MODEL.md: theta0 to +-0.3-0.4 rad, the gap to +-32 %). A recommendation should hold
wherever the real tool sits in that region. :func:`robust_metrics` evaluates a design at each
point of a sample of the region, against the original design at the same point, and reports
the mean and the worst case of max J* and of the operating range; :func:`robust_optimise`
maximises the mean score over the sample.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vadsim.model.presets import get_preset
from vadsim.studies.design import STUDIES, design_metrics, design_sweep

__all__ = ["THETA0_SPREAD", "GAP_SPREAD", "RobustResult", "constants_sample", "robust_compare",
           "robust_metrics", "robust_optimise", "robust_study"]

THETA0_SPREAD = 0.35
"""Half-width (rad) of theta0's plausible region around a preset's: what the 0.01 rounding of
Table 2.1's lengths leaves (MODEL.md, +-0.3-0.4 rad)."""

GAP_SPREAD = 0.32
"""Relative half-width of the gap's plausible region: one standard deviation of a difference
of five rounded lengths (MODEL.md, +-32 %)."""


def constants_sample(preset: str = "7in-cde", n: int = 5) -> list[dict[str, float]]:
    """Points of the plausible (theta0, gap ratio) region around ``preset``'s constants.

    ``n = 1``: the preset's own; ``5``: it and the four ends of the region's axes; ``9``: a
    3 x 3 grid over it. A gap ratio multiplies the preset's gap.
    """
    t0 = get_preset(preset).theta0
    dt, dg = THETA0_SPREAD, GAP_SPREAD
    if n == 1:
        pts = [(0.0, 1.0)]
    elif n == 5:
        pts = [(0.0, 1.0), (-dt, 1.0), (dt, 1.0), (0.0, 1.0 - dg), (0.0, 1.0 + dg)]
    elif n == 9:
        pts = [(a, b) for a in (-dt, 0.0, dt) for b in (1.0 - dg, 1.0, 1.0 + dg)]
    else:
        raise ValueError(f"n = {n!r} must be 1, 5 or 9")
    return [dict(theta0=t0 + a, gap_ratio=b) for a, b in pts]


def _sweep_at(preset: str, flows: np.ndarray, design: Mapping[str, float],
              point: Mapping[str, float], kw: Mapping[str, Any]) -> Any:
    """A flow sweep of ``design`` with the constants of ``point`` (the design's own gap ratio
    multiplies the point's)."""
    ratio = float(point["gap_ratio"]) * float(design.get("gap_ratio", 1.0))
    return design_sweep(preset, flows, {**design, "theta0": float(point["theta0"]),
                                        "gap_ratio": ratio}, **kw)


def robust_metrics(design: Mapping[str, float], preset: str = "7in-cde",
                   sample: Sequence[Mapping[str, float]] | None = None,
                   flows: Sequence[float] | np.ndarray | None = None,
                   baseline: pd.DataFrame | None = None, **sweep_kwargs: Any) -> pd.DataFrame:
    """Max J* and the operating range of ``design`` and of the original at each sample point.

    Returns one row per point: ``theta0, gap_ratio, j_max, range_width_gpm`` of the design,
    ``j_max0, width0`` of the original there, and ``j_ratio, width_ratio``. ``baseline`` (a
    previous result for the original design) saves re-running it.
    """
    sample = list(sample or constants_sample(preset))
    q = np.arange(200.0, 650.0 + 1e-9, 10.0) if flows is None else np.asarray(flows, float)
    kw = {"progress": False, **sweep_kwargs}
    rows = []
    for i, pt in enumerate(sample):
        m = design_metrics(_sweep_at(preset, q, design, pt, kw))
        if baseline is not None:
            m0 = {"j_max": float(baseline.j_max.iloc[i]),
                  "range_width_gpm": float(baseline.range_width_gpm.iloc[i])}
        else:
            m0 = m if not design else design_metrics(_sweep_at(preset, q, {}, pt, kw))
        rows.append(dict(theta0=float(pt["theta0"]), gap_ratio=float(pt["gap_ratio"]),
                         j_max=m["j_max"], range_width_gpm=m["range_width_gpm"],
                         range_from_gpm=m["range_from_gpm"], range_to_gpm=m["range_to_gpm"],
                         j_max0=m0["j_max"], width0=m0["range_width_gpm"]))
    out = pd.DataFrame(rows)
    out["j_ratio"] = out.j_max / out.j_max0 - 1
    step = float(np.min(np.diff(q))) if q.size > 1 else 1.0
    out["width_ratio"] = (out.range_width_gpm + step) / (out.width0 + step) - 1
    return out


def summarise(per_point: pd.DataFrame, m_ref_kg: float | None = None) -> dict[str, float]:
    """Mean and worst case over the sample: max J* (N/kg; kN only with the m* given),
    operating-range width (gal/min), and both as changes from the original."""
    out = {"j_max_mean": float(per_point.j_max.mean()), "j_max_worst": float(per_point.j_max.min()),
           "width_mean_gpm": float(per_point.range_width_gpm.mean()),
           "width_worst_gpm": float(per_point.range_width_gpm.min()),
           "j_ratio_mean": float(per_point.j_ratio.mean()),
           "j_ratio_worst": float(per_point.j_ratio.min()),
           "width_ratio_mean": float(per_point.width_ratio.mean()),
           "width_ratio_worst": float(per_point.width_ratio.min())}
    if m_ref_kg is not None:
        out["j_max_mean_kN"] = out["j_max_mean"] * m_ref_kg / 1000.0
        out["m_ref_kg"] = float(m_ref_kg)
    return out


@dataclass
class RobustResult:
    """Designs compared over the constants' sample."""

    table: pd.DataFrame  # one row per design: summarise()'s columns and the design values
    per_point: dict[str, pd.DataFrame]
    sample: list[dict[str, float]]
    settings: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0


def robust_compare(designs: Mapping[str, Mapping[str, float]], preset: str = "7in-cde",
                   sample: Sequence[Mapping[str, float]] | None = None,
                   flows: Sequence[float] | np.ndarray | None = None,
                   **sweep_kwargs: Any) -> RobustResult:
    """:func:`robust_metrics` of several named designs (``{}`` is the original), summarised
    in one table (J* in N/kg, and in kN with the preset's m*)."""
    t0 = time.perf_counter()
    points: list[dict[str, float]] = [dict(p) for p in (sample or constants_sample(preset))]
    base = robust_metrics({}, preset, points, flows, **sweep_kwargs)
    per = {"original": base}
    for name, d in designs.items():
        if d:
            per[name] = robust_metrics(d, preset, points, flows, baseline=base,
                                       **sweep_kwargs)
    m_ref = get_preset(preset).m_ref_kg
    rows = []
    for name, df in per.items():
        d = dict(designs.get(name, {}))
        rows.append({"design": name, **{k: d.get(k, math.nan) for k in ("kS", "gap_ratio", "Fo")},
                     **summarise(df, m_ref)})
    return RobustResult(pd.DataFrame(rows).set_index("design"), per, points,
                        dict(preset=preset, n_sample=len(points)), time.perf_counter() - t0)


def robust_study(study: str, preset: str = "7in-cde", steps: int = 7,
                 sample: Sequence[Mapping[str, float]] | None = None,
                 flows: Sequence[float] | np.ndarray | None = None,
                 **sweep_kwargs: Any) -> pd.DataFrame:
    """A one-at-a-time study (``"spring"``, ``"gap"``, ``"force"``) judged over the sample:
    per studied value, :func:`summarise` of :func:`robust_metrics` (mean and worst case of max
    J* and of the operating range, and their changes from the original at each point)."""
    if study not in STUDIES:
        raise ValueError(f"unknown study {study!r}: choose one of {', '.join(STUDIES)}")
    s = STUDIES[study]
    points = [dict(p) for p in (sample or constants_sample(preset))]
    base = robust_metrics({}, preset, points, flows, **sweep_kwargs)
    rows = []
    for v in s.values(steps):
        pp = robust_metrics({s.parameter: float(v)}, preset, points, flows, baseline=base,
                            **sweep_kwargs)
        rows.append({s.parameter: float(v), **summarise(pp, get_preset(preset).m_ref_kg)})
    return pd.DataFrame(rows).set_index(s.parameter)


def robust_optimise(preset: str = "7in-cde", n_sample: int = 5,
                    bounds: Mapping[str, tuple[float, float]] | None = None,
                    flows: Sequence[float] | np.ndarray | None = None,
                    popsize: int = 5, maxiter: int = 6, seed: int = 1,
                    weight_range: float = 1.0, cycles: float = 200,
                    analyse_cycles: float = 100, workers: int | None = None,
                    callback: Any = None) -> tuple[dict[str, float], pd.DataFrame]:
    """The design (kS, gap ratio, Fo) maximising the mean, over the constants' sample, of
    ``j_max / j_max0 + weight_range * (width + dq) / (width0 + dq)`` (each relative to the
    original design at the same constants; dq the flow step).

    Why so many parameters: a robust design adds the region of the uncertain constants and its
    sampling to :func:`vadsim.studies.design.optimise`'s parameters; each with a default.

    Differential evolution within the published ranges, on a coarse sweep (25 gal/min, 200
    cycles), as :func:`vadsim.studies.design.optimise`. Returns the best design and every
    evaluated one.
    """
    from scipy.optimize import differential_evolution

    if bounds is None:
        bounds = {s.parameter: (s.lo * s.scale, s.hi * s.scale) for s in STUDIES.values()}
    names = list(bounds)
    q = np.arange(200.0, 650.0 + 1e-9, 25.0) if flows is None else np.asarray(flows, float)
    sample = constants_sample(preset, n_sample)
    kw: dict[str, Any] = dict(cycles=cycles, analyse_cycles=analyse_cycles, workers=workers,
                              detail="map")
    base = robust_metrics({}, preset, sample, q, **kw)
    history: list[dict[str, float]] = []

    def objective(x: np.ndarray) -> float:
        design = dict(zip(names, (float(v) for v in x), strict=True))
        pp = robust_metrics(design, preset, sample, q, baseline=base, **kw)
        score = float((1 + pp.j_ratio + weight_range * (1 + pp.width_ratio)).mean())
        history.append({**design, **summarise(pp), "score": score})
        if callback:
            callback(len(history), score, design)
        return -score

    differential_evolution(objective, [tuple(bounds[n]) for n in names], popsize=popsize,
                           maxiter=maxiter, seed=seed, polish=False, init="sobol",
                           updating="deferred", workers=1, tol=0.0)
    table = pd.DataFrame(history)
    top = table.loc[table.score.idxmax()]
    return {n: float(top[n]) for n in names}, table
