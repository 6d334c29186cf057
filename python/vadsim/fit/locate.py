"""Locate a mismatch between model and recordings: which feature, sensor and flows.

Why this module exists: before naming the physics a model misses, one must say where it
misses: which features of which sensor disagree, at which operating points, and whether the
disagreement grows with flow (as the dissertation saw at the bit sub: a good match at low
flow, over-prediction at high flow). This module turns the standardised residuals of a
validation into such statements, with a significance rule that is tested on campaigns the
true model wrote (no mismatch: no flag).

Rule (per feature, over the events that have it):

* **offset**: the mean standardised residual m is flagged when it is both significant (its
  95 % t-interval excludes 0) and large (``|m|`` > ``min_effect``, default 1.5 spreads);
* **trend**: the least-squares slope of z against flow is flagged when its 95 % t-interval
  excludes 0 and the change it predicts across the campaign's flow range exceeds
  ``2 * min_effect``.

Both conditions are needed: with many events a tiny, physically irrelevant offset is
"significant"; with few events a large one may be noise.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from scipy import stats

__all__ = ["Mismatch", "locate"]


@dataclass(frozen=True)
class Mismatch:
    """Where and how one feature disagrees."""

    feature: str
    sensor: str
    kind: str                      # "offset", "trend" or "offset+trend"
    mean_z: float
    mean_ci: tuple[float, float]
    slope_per_100gpm: float
    slope_ci: tuple[float, float]
    n_events: int
    events: tuple[str, ...]        # events with |z| > 2
    flow_range_gpm: tuple[float, float]

    def as_dict(self) -> dict:
        """Plain data (JSON-ready)."""
        return asdict(self)

    def describe(self) -> str:
        """One sentence."""
        side = "over-predicts" if self.mean_z > 0 else "under-predicts"
        trend = ""
        if "trend" in self.kind:
            trend = (f", by {self.slope_per_100gpm:+.1f} spreads per 100 gal/min "
                     f"(95 % CI {self.slope_ci[0]:+.1f} to {self.slope_ci[1]:+.1f})")
        where = (f" at {', '.join(self.events)}" if self.events else "")
        return (f"{self.feature}: the model {side} (mean z {self.mean_z:+.1f}){trend}"
                f"{where}; flows {self.flow_range_gpm[0]:g}-{self.flow_range_gpm[1]:g}")


def _sensor_of(feature: str) -> str:
    return feature.split("_", 1)[0] if "_" in feature else ""


def locate(residuals: pd.DataFrame, flows: pd.Series | dict, min_effect: float = 1.5,
           level: float = 0.95) -> list[Mismatch]:
    """Flag the features whose standardised residuals are offset or trend with flow.

    Parameters
    ----------
    residuals
        Events x features standardised residuals (e.g. ``ValidationResult.residuals``).
    flows
        Flow (gal/min) per event id.
    min_effect
        Smallest offset (spreads) worth flagging; a trend must change z by twice that over
        the flow range.
    level
        Confidence level of the intervals.

    Returns
    -------
    list of Mismatch
        Most severe first (by ``|mean z|`` plus the predicted change over the range).
    """
    if not (0.5 < level < 1):
        raise ValueError(f"level = {level} must be in (0.5, 1)")
    if not (min_effect > 0):
        raise ValueError(f"min_effect = {min_effect} must be > 0")
    q = pd.Series(flows, dtype=float)
    out: list[tuple[float, Mismatch]] = []
    for feature in residuals.columns:
        z = residuals[feature].astype(float).dropna()
        z = z[np.isfinite(z)]
        ids = [e for e in z.index if e in q.index]
        if len(ids) < 3:
            continue
        z = z.loc[ids]
        x = q.loc[ids].to_numpy()
        zz = z.to_numpy()
        n = len(zz)
        tcrit = stats.t.ppf(0.5 + level / 2, n - 1)
        m = float(zz.mean())
        se = float(zz.std(ddof=1)) / math.sqrt(n)
        mean_ci = (m - tcrit * se, m + tcrit * se)
        offset = (mean_ci[0] > 0 or mean_ci[1] < 0) and abs(m) > min_effect
        slope = ci_lo = ci_hi = 0.0
        trend = False
        span = float(x.max() - x.min())
        if n >= 3 and span > 0:
            fit = stats.linregress(x, zz)
            t2 = stats.t.ppf(0.5 + level / 2, n - 2)
            slope = float(fit.slope)
            ci_lo, ci_hi = slope - t2 * fit.stderr, slope + t2 * fit.stderr
            trend = (ci_lo > 0 or ci_hi < 0) and abs(slope) * span > 2 * min_effect
        if not (offset or trend):
            continue
        kind = "offset+trend" if offset and trend else ("offset" if offset else "trend")
        big = tuple(e for e, v in z.items() if abs(v) > 2)
        mm = Mismatch(feature=feature, sensor=_sensor_of(feature), kind=kind, mean_z=m,
                      mean_ci=mean_ci, slope_per_100gpm=100 * slope,
                      slope_ci=(100 * ci_lo, 100 * ci_hi), n_events=n, events=big,
                      flow_range_gpm=(float(x.min()), float(x.max())))
        out.append((abs(m) + abs(slope) * span, mm))
    out.sort(key=lambda sm: -sm[0])
    return [mm for _, mm in out]
