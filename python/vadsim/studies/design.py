"""Design studies: the dissertation's chapter 5, reproduced, and a multi-parameter optimisation.

Why this module exists: a tool designer wants to know which change (recoil spring stiffness,
anvil-spring gap, excitation force) raises the impulse per second J* delivered to the bit and
widens the range of flow over which it stays high. The dissertation answered with three
one-at-a-time maps and a recommended design; this module reproduces those studies with the
published ranges, compares its ratios with the published ones, and goes beyond with a global
optimisation of the three parameters together.

Metrics of one flow sweep (see :func:`design_metrics`):

* ``j_max``: the maximum over flow of J* (mean of max(F_I, 0), N/kg);
* operating range: the contiguous flow interval around the maximum where J* >= 0.9 j_max
  (dissertation section 5.4); its width in gal/min;
* the upper edge of regime 1 (regular spring and impact face).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from vadsim.data import parametric_rows
from vadsim.studies.sweep import flows_from_hz, sweep

__all__ = [
    "PUBLISHED",
    "RECOMMENDED",
    "STUDIES",
    "DesignResult",
    "OptimisationResult",
    "compare_designs",
    "design_metrics",
    "design_sweep",
    "one_at_a_time",
    "operating_range",
    "optimise",
    "study_table",
    "thesis_flows",
]

RECOMMENDED: dict[str, float] = {"kS": 472_400.0, "gap_ratio": 1.5, "Fo": 534.17}
"""The dissertation's recommended design (parametric.csv, row "recommended";
kS = 472.4 kN/(kg m) = 472,400 N/m per kg)."""

PUBLISHED: dict[str, float] = {
    "force_j_ratio": 0.56,        # "max J* 20 -> 31.2 kN (+56 %) for +78 % force"
    "gap_j_ratio": 0.14,          # "max J* 20 -> 22.8 kN (+14 %) at 150 %"
    "recommended_j_ratio": 0.85,  # "max J* 20 -> 37 kN (+85 %)"
    "recommended_range_ratio": 1.25,  # "270-310 gal/min -> 300-390 gal/min (+125 %)"
    "force_regime1_edge_hz_from": 34.0,  # "regime 1 upper edge from 34 Hz at 300.5 N/kg
    "force_regime1_edge_hz_to": 39.0,    #  to 39 Hz at 534.17 N/kg"
    "original_range_from_gpm": 270.0,
    "original_range_to_gpm": 310.0,
}
"""The numbers of parametric.csv's findings, as ratios (the csv states them in prose)."""


@dataclass(frozen=True)
class Study:
    """One of the dissertation's one-at-a-time studies."""

    name: str
    parameter: str
    lo: float
    hi: float
    step: float
    scale: float  # published unit -> model unit

    def values(self, steps: int | None = None) -> np.ndarray:
        """The studied values in model units; ``steps`` points, or the published step."""
        n = steps or int(round((self.hi - self.lo) / self.step)) + 1
        return np.linspace(self.lo, self.hi, n) * self.scale


def _studies() -> dict[str, Study]:
    rows = parametric_rows()
    scale = {"kS": 1000.0, "gap_ratio": 1.0, "Fo": 1.0}  # kN/(kg m) -> N/m/kg
    out = {}
    for name in ("spring", "gap", "force"):
        r = rows[name]
        out[name] = Study(name, r["parameter"], float(r["from"]), float(r["to"]),
                          float(r["step"]), scale[r["parameter"]])
    return out


STUDIES: dict[str, Study] = _studies()
"""The three studies of parametric.csv: ``spring`` (kS), ``gap`` (gap_ratio), ``force`` (Fo)."""


def thesis_flows(preset: str = "7in-cde", hz_step: float = 0.5) -> np.ndarray:
    """The dissertation's map flow axis: 21.3 to 69.3 Hz in ``hz_step`` steps, in gal/min."""
    rows = parametric_rows()
    lo, hi = float(rows["maps"]["from"]), float(rows["maps"]["to"])
    return flows_from_hz(preset, np.arange(lo, hi + 1e-9, hz_step))


def operating_range(flows: Sequence[float], j: Sequence[float], frac: float = 0.9
                    ) -> tuple[float, float]:
    """The contiguous flow interval around the maximum of J* where J* >= ``frac`` * max.

    Returns ``(from, to)`` in the flow units given; NaN values break the interval.
    """
    q = np.asarray(flows, dtype=float)
    jj = np.asarray(j, dtype=float)
    if q.shape != jj.shape or q.size == 0:
        raise ValueError("flows and j must be non-empty arrays of the same shape")
    if not np.any(np.isfinite(jj)):
        return math.nan, math.nan
    k = int(np.nanargmax(jj))
    ok = np.isfinite(jj) & (jj >= frac * jj[k])
    lo = hi = k
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    while hi < q.size - 1 and ok[hi + 1]:
        hi += 1
    return float(q[lo]), float(q[hi])


def design_metrics(ds: xr.Dataset) -> dict[str, float]:
    """J* maximum, operating range and regime-1 edge of a 1-D flow sweep."""
    if set(ds.j_pos.dims) != {"flow_gpm"}:
        raise ValueError(f"design_metrics needs a flow sweep, got dims {ds.j_pos.dims}")
    q = ds.flow_gpm.values
    j = ds.j_pos.values
    k = int(np.nanargmax(j))
    lo, hi = operating_range(q, j)
    regular = q[ds.scenario.values == 1]
    alpha_hz = ds.f_exc_hz.values / q
    m_ref = float(ds.attrs.get("m_ref_kg", math.nan))
    return {
        "j_max": float(j[k]),
        "j_max_kN": float(j[k]) * m_ref / 1000.0,
        "flow_at_max_gpm": float(q[k]),
        "f_at_max_hz": float(ds.f_exc_hz.values[k]),
        "range_from_gpm": lo,
        "range_to_gpm": hi,
        "range_width_gpm": hi - lo,
        "regime1_edge_gpm": float(regular.max()) if regular.size else math.nan,
        "regime1_edge_hz": float(regular.max() * alpha_hz[0]) if regular.size else math.nan,
    }


def one_at_a_time(
    study: str,
    preset: str = "7in-cde",
    steps: int | None = 21,
    flows: Sequence[float] | None = None,
    gap_via: str = "spring",
    **sweep_kwargs: Any,
) -> xr.Dataset:
    """One of the dissertation's maps: flow x one parameter over its published range.

    Parameters
    ----------
    study
        ``"spring"`` (kS), ``"gap"`` (gap ratio) or ``"force"`` (Fo).
    steps
        Number of parameter values (None: the published step, i.e. thesis resolution).
    flows
        Flow axis (default: 21.3-69.3 Hz in 0.5 Hz steps, as the dissertation).
    gap_via
        Which length realises the gap change (``"spring"``, ``"anvil"``, ``"housing"``).
    sweep_kwargs
        Passed to :func:`vadsim.studies.sweep.sweep` (workers, scheduler, store, cycles...).
    """
    if study not in STUDIES:
        raise ValueError(f"unknown study {study!r}: choose one of {', '.join(STUDIES)}")
    s = STUDIES[study]
    q = thesis_flows(preset) if flows is None else np.asarray(flows, dtype=float)
    ds = sweep(preset, q, {s.parameter: s.values(steps)}, gap_via=gap_via, **sweep_kwargs)
    ds.attrs["study"] = study
    return ds


def study_table(ds: xr.Dataset) -> pd.DataFrame:
    """Per parameter value of a one-parameter map: the metrics of :func:`design_metrics`."""
    dims = [d for d in ds.j_pos.dims if d != "flow_gpm"]
    if len(dims) != 1:
        raise ValueError(f"study_table needs one design axis besides flow, got {dims}")
    param = dims[0]
    rows = []
    for v in ds[param].values:
        m = design_metrics(ds.sel({param: v}))
        rows.append({param: float(v), **m})
    return pd.DataFrame(rows).set_index(param)


@dataclass
class DesignResult:
    """Original vs changed design: both flow sweeps, their metrics and the ratios."""

    original: xr.Dataset
    changed: xr.Dataset
    metrics_original: dict[str, float]
    metrics_changed: dict[str, float]
    design: dict[str, float]
    gap_via: str

    @property
    def j_ratio(self) -> float:
        """Relative change of max J* (0.56 means +56 %)."""
        return self.metrics_changed["j_max"] / self.metrics_original["j_max"] - 1

    @property
    def range_ratio(self) -> float:
        """Relative change of the operating-range width (NaN if the original's is zero)."""
        w0 = self.metrics_original["range_width_gpm"]
        return self.metrics_changed["range_width_gpm"] / w0 - 1 if w0 > 0 else math.nan


def _design_overrides(design: Mapping[str, float]) -> tuple[dict[str, float], dict[str, list]]:
    overrides = {k: float(v) for k, v in design.items() if k not in ("gap_ratio", "gap")}
    axes = {k: [float(v)] for k, v in design.items() if k in ("gap_ratio", "gap")}
    return overrides, axes


def design_sweep(preset: str, flows: np.ndarray, design: Mapping[str, float],
                 gap_via: str = "spring", **kw: Any) -> xr.Dataset:
    """A flow sweep of ``preset`` with ``design`` applied: parameters (any name, ``theta0``
    included) as overrides, ``gap_ratio`` or ``gap`` realised by ``gap_via``; ``kw`` go to
    :func:`vadsim.studies.sweep.sweep`."""
    overrides, axes = _design_overrides(design)
    ds = sweep(preset, flows, axes or None, overrides=overrides, gap_via=gap_via, **kw)
    for name in axes:
        ds = ds.isel({name: 0})
    ds.attrs["design"] = str(dict(design))
    return ds


def compare_designs(
    design: Mapping[str, float] = RECOMMENDED,
    preset: str = "7in-cde",
    flows: Sequence[float] | None = None,
    gap_via: str = "spring",
    **sweep_kwargs: Any,
) -> DesignResult:
    """Flow sweeps of the preset and of the preset with ``design`` applied (dissertation
    Fig. 5.7: 200-650 gal/min in 10 gal/min steps by default)."""
    q = np.arange(200.0, 650.0 + 1e-9, 10.0) if flows is None else np.asarray(flows, float)
    original = sweep(preset, q, **sweep_kwargs)
    changed = design_sweep(preset, q, design, gap_via, **sweep_kwargs)
    return DesignResult(original, changed, design_metrics(original), design_metrics(changed),
                        dict(design), gap_via)


@dataclass
class OptimisationResult:
    """The best design found, how it was scored, and every design evaluated."""

    best: dict[str, float]
    score: float
    metrics: dict[str, float]
    baseline: dict[str, float]
    history: pd.DataFrame
    verified: DesignResult | None = None
    seconds: float = 0.0
    settings: dict[str, Any] = field(default_factory=dict)


def optimise(
    preset: str = "7in-cde",
    bounds: Mapping[str, tuple[float, float]] | None = None,
    flows: Sequence[float] | None = None,
    gap_via: str = "spring",
    cycles: float = 200,
    analyse_cycles: float = 100,
    popsize: int = 6,
    maxiter: int = 8,
    seed: int = 1,
    weight_range: float = 1.0,
    verify: bool = True,
    workers: int | None = None,
    callback: Callable[[int, float, dict[str, float]], None] | None = None,
) -> OptimisationResult:
    """Maximise J* and the operating range together over kS, gap ratio and Fo.

    Why so many parameters: the optimisation is a design space (parameters, bounds), an
    objective over flows and the run settings of each evaluation; each with a default.

    The score of a design is ``j_max / j_max0 + weight_range * width / width0`` (both relative
    to the preset), evaluated on a flow sweep (coarser and shorter than the dissertation's, so
    that hundreds of designs fit in minutes). The search is SciPy's differential evolution
    within the published ranges (the landscape is rough: J* jumps at regime boundaries, so a
    gradient method would stall). The best design is then verified on the full 400-cycle,
    10 gal/min sweep.

    Parameters
    ----------
    bounds
        ``{name: (lo, hi)}`` in model units; default: the three published ranges.
    flows
        Flow axis of the search (default 200-650 gal/min in 25 gal/min steps).
    popsize, maxiter, seed
        Differential-evolution settings (population = popsize * number of parameters).
    weight_range
        Weight of the operating range against J* in the score.
    callback
        Called after each generation with ``(generation, best_score, best_design)``.
    """
    from scipy.optimize import differential_evolution

    if bounds is None:
        bounds = {s.parameter: (s.lo * s.scale, s.hi * s.scale) for s in STUDIES.values()}
    names = list(bounds)
    q = np.arange(200.0, 650.0 + 1e-9, 25.0) if flows is None else np.asarray(flows, float)
    # The same sweep options for the baseline and every candidate (of mixed types, as sweep's).
    kw: dict[str, Any] = dict(cycles=cycles, analyse_cycles=analyse_cycles, progress=False,
                              workers=workers, detail="map")
    base_ds = sweep(preset, q, **kw)
    base = design_metrics(base_ds)
    width0 = max(base["range_width_gpm"], float(np.min(np.diff(q))) if q.size > 1 else 1.0)
    history: list[dict[str, float]] = []

    def score_of(m: dict[str, float]) -> float:
        width = max(m["range_width_gpm"], 0.0)
        return m["j_max"] / base["j_max"] + weight_range * width / width0

    def objective(x: np.ndarray) -> float:
        design = dict(zip(names, (float(v) for v in x), strict=True))
        ds = design_sweep(preset, q, design, gap_via, **kw)
        m = design_metrics(ds)
        s = score_of(m)
        history.append({**design, **m, "score": s})
        return -s

    gen = [0]

    def de_callback(xk: np.ndarray, convergence: float = 0.0) -> bool:
        gen[0] += 1
        if callback:
            best = max(history, key=lambda h: h["score"])
            callback(gen[0], best["score"], {n: best[n] for n in names})
        return False

    t0 = time.perf_counter()
    res = differential_evolution(
        objective, [tuple(bounds[n]) for n in names], popsize=popsize, maxiter=maxiter,
        seed=seed, polish=False, init="sobol", updating="deferred", workers=1,
        callback=de_callback, tol=0.0,
    )
    best = dict(zip(names, (float(v) for v in res.x), strict=True))
    table = pd.DataFrame(history)
    top = table.loc[table["score"].idxmax()]
    best = {n: float(top[n]) for n in names}
    verified = compare_designs(best, preset, gap_via=gap_via, workers=workers,
                               progress=False, detail="map") if verify else None
    return OptimisationResult(
        best=best, score=float(top["score"]),
        metrics={k: float(top[k]) for k in base}, baseline=base, history=table,
        verified=verified, seconds=time.perf_counter() - t0,
        settings=dict(preset=preset, bounds=dict(bounds), flows=q.tolist(), gap_via=gap_via,
                      cycles=cycles, analyse_cycles=analyse_cycles, popsize=popsize,
                      maxiter=maxiter, seed=seed, weight_range=weight_range),
    )
