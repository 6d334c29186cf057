"""The constants the published numbers cannot fix, scanned against every chapter 4-5 target.

Why this module exists: the dissertation's Table 2.1 rounds its lengths to 0.01 l0, and two
numbers the dynamics hinges on follow from them only to within their rounding (MODEL.md, last
section): the excitation phase at rest ``theta0`` (+-0.3-0.4 rad, one alias every 8.3 mm of
l0) and the anvil-spring gap ``L_gap`` (a difference of five rounded lengths, +-32 %). A
reproduction that misses a published number may be wrong, or may sit elsewhere in that
region. :func:`scan_constants` measures which: one flow sweep per (theta0, gap) point, each
published target scored on it, so that maps show which region satisfies which targets and
:func:`best_constants` picks the point that satisfies most (the ``*-thesis`` presets).

Targets (tolerances as ``vadsim thesis`` states them):

* the five regime bands of section 4.1 (regimes_7in.csv): both edges within 10 gal/min;
* the ten simulated CDE peaks and the six simulated RC peaks of chapter 4
  (field_events.csv): within 15 %;
* the J* ratios of chapter 5's studies (parametric.csv): Fo x 1.78 (+56 %), gap x 1.5
  (+14 %), the recommended design (+85 % J*, +125 % operating range); within 0.10 (J*) and
  0.25 (range) of the published ratio. Only ratios: J* in kN needs the reference mass m*,
  which the dissertation does not publish, and its 20-37 kN exceed what any m* allows.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from vadsim.data import field_events
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import get_preset
from vadsim.studies.design import PUBLISHED, RECOMMENDED, STUDIES, operating_range
from vadsim.studies.sweep import sweep
from vadsim.studies.thesis import compare_peaks, compare_regimes

__all__ = [
    "DESIGN_TARGETS",
    "SPRING_DESIGNS",
    "SPRING_J_TOL",
    "ConstantScan",
    "band_scores",
    "best_constants",
    "peak_scores",
    "scan_constants",
    "score_targets",
]

REGIME_TOL_GPM = 10.0
"""A regime band's edges must be within this many gal/min of the published ones."""

PEAK_TOL = 0.15
"""A simulated peak must be within this fraction of the dissertation's simulated peak."""

J_RATIO_TOL = 0.10
"""A design's J* ratio must be within this (absolute) of the published ratio."""

RANGE_RATIO_TOL = 0.25
"""The recommended design's operating-range ratio must be within this of the published one."""

DESIGN_TARGETS: dict[str, tuple[dict[str, float], str, float]] = {
    "force_j": ({"Fo": STUDIES["force"].hi}, "j", PUBLISHED["force_j_ratio"]),
    "gap_j": ({"gap_ratio": 1.5}, "j", PUBLISHED["gap_j_ratio"]),
    "recommended_j": (dict(RECOMMENDED), "j", PUBLISHED["recommended_j_ratio"]),
    "recommended_range": (dict(RECOMMENDED), "range", PUBLISHED["recommended_range_ratio"]),
}
"""Chapter 5's ratio targets: ``name: (design, "j" or "range", published ratio)``; the gap
ratio multiplies the scanned gap."""

SPRING_J_TOL = 0.15
"""The spring study's "peak J* hardly changes" (kS over its published range): the change of
max J* from the lowest to the highest kS must be within this fraction."""

SPRING_DESIGNS: dict[str, dict[str, float]] = {
    "spring_lo": {"kS": STUDIES["spring"].lo * STUDIES["spring"].scale},
    "spring_hi": {"kS": STUDIES["spring"].hi * STUDIES["spring"].scale},
}
"""The two ends of the spring study: the target ``spring_j`` is max J* at the highest kS over
that at the lowest, minus 1 (published: about 0)."""


@dataclass
class ConstantScan:
    """Flow sweeps over (theta0, gap ratio) and every target scored on them.

    Attributes
    ----------
    cde, rc
        Flow sweeps of the CDE and RC presets, dims ``(theta0, gap_ratio, flow_gpm)``.
    designs
        Per design name (``"force"``, ``"gap"``, ``"recommended"``) the CDE sweep with that
        design applied, on the (possibly coarser) design grid; empty if not scanned.
    scores
        One row per (theta0, gap_ratio, target): ``group, target, value, published, error,
        tolerance, ok`` (see :func:`score_targets`).
    settings
        How the scan was run (JSON-ready).
    """

    cde: xr.Dataset
    rc: xr.Dataset
    designs: dict[str, xr.Dataset]
    scores: pd.DataFrame
    settings: dict[str, Any]

    def summary(self) -> pd.DataFrame:
        """Per (theta0, gap_ratio): targets met per group and in all, best first."""
        return _summary(self.scores)

    def to_netcdf(self, path: str) -> None:
        """The sweeps as one netCDF file (groups ``cde``, ``rc``, ``design_<name>``)."""
        self.cde.to_netcdf(path, group="cde", mode="w")
        self.rc.to_netcdf(path, group="rc", mode="a")
        for name, ds in self.designs.items():
            ds.to_netcdf(path, group=f"design_{name}", mode="a")


def scan_constants(
    preset: str = "7in-cde",
    theta0: Sequence[float] | np.ndarray | None = None,
    gap_ratio: Sequence[float] | np.ndarray | None = None,
    *,
    flows: Sequence[float] | np.ndarray | None = None,
    design_every: int = 2,
    designs: bool = True,
    cycles: float = DEFAULTS.cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    workers: int | None = None,
    progress: bool = True,
) -> ConstantScan:
    """Sweep flow over a grid of (theta0, gap ratio) and score every published target.

    Why so many parameters: the scan is the constants' ranges, the published numbers it is held
    against and the run settings of each point; keyword-only with defaults.

    Parameters
    ----------
    preset
        The CDE preset whose constants are scanned (its RC twin is ``7in-rc`` for the 7in
        tool: the same with the RC bit's mass).
    theta0
        Phases at rest (rad; default 24 over ``[0, pi)``: theta0 + pi is the same steady
        state).
    gap_ratio
        Gaps as multiples of Table 2.1's (default 0.6 to 1.4 in steps of 0.1).
    flows
        The CDE sweep's flows (default 200-650 gal/min every 10, the resolution of the
        published regime bands); the RC sweep runs at the RC field events' flows.
    design_every
        The design sweeps (five per point: force, gap, recommended and the two ends of the
        spring study; the costliest part) run on every ``design_every``-th theta0 and gap
        ratio.
    designs
        False: no design sweeps (no J* ratio targets).
    cycles, analyse_cycles
        Run length and analysed window (excitation cycles).
    workers, progress
        As :func:`vadsim.studies.sweep`.
    """
    pr = get_preset(preset)
    th = np.linspace(0.0, math.pi, 24, endpoint=False) if theta0 is None else np.asarray(
        theta0, float)
    gr = np.round(np.arange(0.6, 1.4 + 1e-9, 0.1), 10) if gap_ratio is None else np.asarray(
        gap_ratio, float)
    _check_grid(th, gr, design_every)
    q = np.arange(200.0, 650.0 + 1e-9, 10.0) if flows is None else np.asarray(flows, float)
    gap0 = float(pr.gap)  # in l0, for the record
    kw: dict[str, Any] = dict(cycles=cycles, analyse_cycles=analyse_cycles, workers=workers,
                              progress=progress)

    def grid(name: str, flows_: np.ndarray, t: np.ndarray, g: np.ndarray,
             design: Mapping[str, float] | None = None) -> xr.Dataset:
        design = dict(design or {})
        factor = float(design.pop("gap_ratio", 1.0))
        # the sweep's gap_ratio moves the spring's end by exactly 0 at 1.0: the nominal
        # points are the preset's own runs, bit for bit
        ds = sweep(name, flows_, {"theta0": t, "gap_ratio": g * factor}, overrides=design,
                   **kw)
        ds = ds.assign_coords(gap_ratio=g)
        ds.gap_ratio.attrs.update(units="1", long_name="anvil-spring gap / Table 2.1's")
        return ds

    cde = grid(pr.name, q, th, gr)
    rc_name = pr.name.replace("-cde", "-rc")
    rc_flows = np.asarray(field_events(pr.tool, "RC").flow_gpm, float)
    rc = grid(rc_name, rc_flows, th, gr) if rc_flows.size and rc_name != pr.name else xr.Dataset()
    sweeps: dict[str, xr.Dataset] = {}
    if designs:
        td, gd = th[::design_every], gr[::design_every]
        for name, design in (("force", DESIGN_TARGETS["force_j"][0]),
                             ("gap", DESIGN_TARGETS["gap_j"][0]),
                             ("recommended", RECOMMENDED), *SPRING_DESIGNS.items()):
            sweeps[name] = grid(pr.name, q, td, gd, design)
    scores = score_targets(cde, rc, sweeps, tool=pr.tool)
    settings = dict(preset=pr.name, theta0=th.tolist(), gap_ratio=gr.tolist(), flows=q.tolist(),
                    gap0_l0=gap0, design_every=design_every, designs=designs, cycles=cycles,
                    analyse_cycles=analyse_cycles)
    return ConstantScan(cde, rc, sweeps, scores, settings)


def _check_grid(th: np.ndarray, gr: np.ndarray, design_every: int) -> None:
    if th.ndim != 1 or th.size == 0 or not np.all(np.isfinite(th)):
        raise ValueError(f"theta0 = {th!r} must be a non-empty 1-D array of finite phases")
    if gr.ndim != 1 or gr.size == 0 or not np.all(np.isfinite(gr) & (gr > 0)):
        raise ValueError(f"gap_ratio = {gr!r} must be a non-empty 1-D array of ratios > 0")
    if not (isinstance(design_every, int) and design_every >= 1):
        raise ValueError(f"design_every = {design_every!r} must be an integer >= 1")


# ------------------------------------------------------------------------------ scoring

def score_targets(cde: xr.Dataset, rc: xr.Dataset, designs: Mapping[str, xr.Dataset],
                  tool: str = "7in") -> pd.DataFrame:
    """Every published target at every (theta0, gap_ratio) point of the sweeps.

    Returns one row per point and target: ``theta0, gap_ratio, group, target, value,
    published, error, tolerance, ok``. ``error`` is in the target's unit (gal/min for a band:
    the larger edge miss; relative for a peak; absolute ratio for J*); a band the sweep does
    not show at all has ``error = inf``.
    """
    rows: list[dict[str, Any]] = []
    for t in cde.theta0.values:
        for g in cde.gap_ratio.values:
            point = dict(theta0=float(t), gap_ratio=float(g))
            one = cde.sel(theta0=t, gap_ratio=g)
            rows += [{**point, **r} for r in band_scores(one)]
            rows += [{**point, **r} for r in peak_scores(one, tool, "CDE")]
            if rc.data_vars:
                rows += [{**point, **r} for r in peak_scores(rc.sel(theta0=t, gap_ratio=g),
                                                             tool, "RC")]
            if designs and all(t in d.theta0.values and g in d.gap_ratio.values
                               for d in designs.values()):
                rows += [{**point, **r} for r in _design_rows(one, designs, t, g)]
    return pd.DataFrame(rows)


def band_scores(ds: xr.Dataset) -> list[dict[str, Any]]:
    """The five published regime bands scored on a flow sweep (rows of
    :func:`score_targets` without the point), from :func:`~vadsim.studies.thesis.compare_regimes`:
    the error is the larger edge miss, infinite for a band the sweep does not show."""
    out = []
    for _, r in compare_regimes(ds, REGIME_TOL_GPM).iterrows():
        absent = math.isnan(r.vadsim_from)
        err = math.inf if absent else max(abs(r.d_from), abs(r.d_to))
        out.append(dict(group="regime band", target=f"regime {int(r.scenario)}",
                        value="absent" if absent else f"{r.vadsim_from:g}-{r.vadsim_to:g}",
                        published=f"{r.published_from:g}-{r.published_to:g}", error=err,
                        tolerance=REGIME_TOL_GPM, ok=bool(r.ok)))
    return out


def peak_scores(ds: xr.Dataset, tool: str, bit: str) -> list[dict[str, Any]]:
    """The dissertation's simulated peaks of ``tool``/``bit`` scored on a flow sweep, from
    :func:`~vadsim.studies.thesis.compare_peaks` (the error relative, infinite for no peak)."""
    out = []
    for _, r in compare_peaks(ds, tool, bit, PEAK_TOL).iterrows():
        v = float(r.vadsim_peak_g)
        out.append(dict(group=f"{bit} peak", target=f"{bit} {r.flow_gpm:g} gal/min",
                        value=round(v, 1), published=float(r.thesis_sim_peak_g),
                        error=abs(r.rel_diff_sim) if math.isfinite(v) else math.inf,
                        tolerance=PEAK_TOL, ok=bool(r.ok)))
    return out


def _design_rows(one: xr.Dataset, designs: Mapping[str, xr.Dataset], t: float, g: float
                 ) -> list[dict[str, Any]]:
    base_j, base_w = _j_and_width(one)
    out = []
    for target, (_design, kind, published) in DESIGN_TARGETS.items():
        ds = designs[target.rsplit("_", 1)[0]].sel(theta0=t, gap_ratio=g)
        j, w = _j_and_width(ds)
        if kind == "j":
            ratio = j / base_j - 1 if base_j > 0 else math.nan
            tol = J_RATIO_TOL
        else:
            ratio = w / base_w - 1 if base_w > 0 else math.nan
            tol = RANGE_RATIO_TOL
        err = abs(ratio - published) if math.isfinite(ratio) else math.inf
        out.append(dict(group="design ratio", target=target, value=round(ratio, 3),
                        published=published, error=err, tolerance=tol, ok=bool(err <= tol)))
    if set(SPRING_DESIGNS) <= set(designs):  # scans written before the spring ends lack them
        j_lo, _ = _j_and_width(designs["spring_lo"].sel(theta0=t, gap_ratio=g))
        j_hi, _ = _j_and_width(designs["spring_hi"].sel(theta0=t, gap_ratio=g))
        ratio = j_hi / j_lo - 1 if j_lo > 0 else math.nan
        err = abs(ratio) if math.isfinite(ratio) else math.inf
        out.append(dict(group="design ratio", target="spring_j", value=round(ratio, 3),
                        published=0.0, error=err, tolerance=SPRING_J_TOL,
                        ok=bool(err <= SPRING_J_TOL)))
    return out


def _j_and_width(ds: xr.Dataset) -> tuple[float, float]:
    j = ds.j_pos.values
    if not np.any(np.isfinite(j)):
        return math.nan, math.nan
    lo, hi = operating_range(ds.flow_gpm.values, j)
    return float(np.nanmax(j)), hi - lo


def _summary(scores: pd.DataFrame) -> pd.DataFrame:
    met = scores.pivot_table(index=["theta0", "gap_ratio"], columns="group", values="ok",
                             aggfunc="sum")
    met["all"] = met.sum(axis=1)
    n = scores.groupby(["theta0", "gap_ratio"]).size().rename("targets")
    out = met.join(n).reset_index()
    return out.sort_values(["all", "theta0"], ascending=[False, True]).reset_index(drop=True)


def best_constants(scan: ConstantScan | pd.DataFrame, groups: Sequence[str] | None = None
                   ) -> dict[str, Any]:
    """The (theta0, gap_ratio) that meets most targets (of ``groups``, default all scored at
    every point), ties broken by the smallest sum of errors in units of their tolerances.

    Returns ``theta0, gap_ratio, met, of`` and the targets missed there.
    """
    scores = scan.scores if isinstance(scan, ConstantScan) else scan
    if groups is None:
        per_point = scores.groupby(["theta0", "gap_ratio"]).group.agg(lambda g: frozenset(g))
        groups = sorted(frozenset.intersection(*per_point.values)) if len(per_point) else []
    sel = scores[scores.group.isin(list(groups))].copy()
    if sel.empty:
        raise ValueError(f"no target of groups {list(groups)!r} was scored")
    sel["cost"] = np.minimum(sel.error / sel.tolerance, 10.0)
    agg = sel.groupby(["theta0", "gap_ratio"]).agg(met=("ok", "sum"), of=("ok", "size"),
                                                    cost=("cost", "sum")).reset_index()
    best = agg.sort_values(["met", "cost"], ascending=[False, True]).iloc[0]
    here = sel[(sel.theta0 == best.theta0) & (sel.gap_ratio == best.gap_ratio)]
    return dict(theta0=float(best.theta0), gap_ratio=float(best.gap_ratio), met=int(best.met),
                of=int(best.of), groups=list(groups),
                missed=here.loc[~here.ok, ["target", "value", "published"]].to_dict("records"))
