"""Reproduction of the dissertation's published numbers.

Why this module exists: vadsim starts from a dissertation whose tables are the only ground
truth (shipped in ``data/thesis``). This module compares a flow sweep with them: the impact
regime boundaries of the 7in flow sweep (regimes_7in.csv, section 4.1) and the simulated
vibration peaks of the field events (field_events.csv), so that every claim of agreement is a
table anyone can regenerate (``vadsim thesis``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from vadsim.data import field_events, published_regimes

__all__ = [
    "compare_peaks",
    "compare_regimes",
    "field_events",
    "published_regimes",
    "regime_intervals",
]


def regime_intervals(ds: xr.Dataset) -> pd.DataFrame:
    """Contiguous runs of the same scenario along flow: ``scenario, from_gpm, to_gpm, n``."""
    if set(ds.scenario.dims) != {"flow_gpm"}:
        raise ValueError(f"regime_intervals needs a flow sweep, got dims {ds.scenario.dims}")
    q = ds.flow_gpm.values
    sc = ds.scenario.values
    rows = []
    start = 0
    for i in range(1, len(q) + 1):
        if i == len(q) or sc[i] != sc[start]:
            rows.append({"scenario": int(sc[start]), "from_gpm": float(q[start]),
                         "to_gpm": float(q[i - 1]), "n": i - start})
            start = i
    return pd.DataFrame(rows)


def compare_regimes(ds: xr.Dataset, tolerance_gpm: float = 10.0) -> pd.DataFrame:
    """Published regime intervals against the sweep's.

    For each published scenario, the sweep's interval is the longest contiguous run of that
    scenario that overlaps the published interval (isolated one-point excursions elsewhere are
    reported by :func:`regime_intervals`, not here). ``d_from``/``d_to`` are sweep minus
    published, in gal/min; ``ok`` is both within ``tolerance_gpm``.
    """
    pub = published_regimes()
    runs = regime_intervals(ds)
    out = []
    for _, p in pub.iterrows():
        cand = runs[(runs.scenario == p.scenario) & (runs.to_gpm >= p.flow_from_gpm - 10)
                    & (runs.from_gpm <= p.flow_to_gpm + 10)]
        if cand.empty:
            out.append({"scenario": int(p.scenario), "published_from": p.flow_from_gpm,
                        "published_to": p.flow_to_gpm, "vadsim_from": np.nan,
                        "vadsim_to": np.nan, "d_from": np.nan, "d_to": np.nan, "ok": False})
            continue
        best = cand.loc[cand.n.idxmax()]
        d_from = best.from_gpm - p.flow_from_gpm
        d_to = best.to_gpm - p.flow_to_gpm
        out.append({"scenario": int(p.scenario), "published_from": p.flow_from_gpm,
                    "published_to": p.flow_to_gpm, "vadsim_from": best.from_gpm,
                    "vadsim_to": best.to_gpm, "d_from": d_from, "d_to": d_to,
                    "ok": bool(abs(d_from) <= tolerance_gpm and abs(d_to) <= tolerance_gpm)})
    return pd.DataFrame(out)


def compare_peaks(ds: xr.Dataset, tool: str = "7in", bit: str = "CDE",
                  tolerance: float = 0.15) -> pd.DataFrame:
    """Mean x1 peaks of a sweep at the field events' flows vs the dissertation's simulated
    and field peaks; ``ok`` when within ``tolerance`` (relative) of the simulated value."""
    ev = field_events(tool, bit)
    rows = []
    for _, e in ev.iterrows():
        if e.flow_gpm not in ds.flow_gpm.values:
            continue
        v = float(ds.x1_peak_mean_g.sel(flow_gpm=e.flow_gpm))
        rows.append({"event": int(e.event), "flow_gpm": e.flow_gpm, "vadsim_peak_g": v,
                     "thesis_sim_peak_g": e.sim_peak_g, "field_peak_g": e.field_peak_g,
                     "rel_diff_sim": v / e.sim_peak_g - 1,
                     "ok": bool(abs(v / e.sim_peak_g - 1) <= tolerance)})
    return pd.DataFrame(rows)
