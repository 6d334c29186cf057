"""Maps of the unidentifiable constants: which (theta0, gap) satisfies which published target.

Why this module exists: a scan of the excitation phase at rest and the anvil-spring gap
(:func:`vadsim.studies.constants.scan_constants`) scores 25 targets at each of some 200
points; read as a table that is 5,000 rows. As maps it answers at a glance whether the
dissertation's numbers agree with one another somewhere in the region the published lengths
allow, and where.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure

from vadsim.plots.style import check_path, edges, finish, styled

__all__ = ["constants_maps", "target_maps"]

_GROUP_ORDER = ("regime band", "CDE peak", "RC peak", "design ratio")


def _grid(values: pd.Series) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta0, gap_ratio, values[gap, theta0]) of a per-point series."""
    table = values.unstack("theta0").sort_index()
    return (np.asarray(table.columns, float), np.asarray(table.index, float),
            table.to_numpy(dtype=float))


def _mark(ax: Any, best: dict[str, Any] | None) -> None:
    if best:
        ax.plot(best["theta0"], best["gap_ratio"], marker="*", ms=14, mec="k", mfc="w",
                zorder=5)


@styled
def constants_maps(scores: pd.DataFrame, best: dict[str, Any] | None = None,
                   path: str | os.PathLike[str] | None = None) -> Figure:
    """Targets met per group over (theta0, gap ratio), and in all.

    Parameters
    ----------
    scores
        :attr:`vadsim.studies.constants.ConstantScan.scores`.
    best
        :func:`vadsim.studies.constants.best_constants`'s result: marked with a star.
    path
        Save the figure there.
    """
    out = check_path(path)
    if scores.empty:
        raise ValueError("constants_maps: the scores table is empty")
    groups = [g for g in _GROUP_ORDER if g in set(scores.group)]
    fig = Figure(figsize=(4.2 * (len(groups) + 1), 4.0), layout="constrained")
    axes = fig.subplots(1, len(groups) + 1, sharey=True, squeeze=False)[0]
    panels = [(g, scores[scores.group == g]) for g in groups] + [("all targets", scores)]
    for ax, (title, sub) in zip(axes, panels, strict=True):
        met = sub.groupby(["theta0", "gap_ratio"]).ok.sum()
        total = sub.groupby(["theta0", "gap_ratio"]).ok.size()
        th, gr, z = _grid(met)
        _, _, n = _grid(total)
        z = np.where(np.isfinite(n), z, np.nan)
        top = int(np.nanmax(n)) if np.isfinite(n).any() else 1
        cmap = ListedColormap(_ramp(top + 1))
        norm = BoundaryNorm(np.arange(-0.5, top + 1.5), cmap.N)
        mesh = ax.pcolormesh(edges(th), edges(gr), z, cmap=cmap, norm=norm, shading="flat")
        fig.colorbar(mesh, ax=ax, label=f"targets met (of {top})", ticks=_ticks(top),
                     shrink=0.85)
        _mark(ax, best)
        ax.set_title(title)
        ax.set_xlabel("theta0, phase at rest (rad)")
        ax.grid(False)
    axes[0].set_ylabel("anvil-spring gap / Table 2.1's")
    fig.suptitle("Published targets met over the constants Table 2.1 cannot fix"
                 + (f" (star: theta0 = {best['theta0']:.3f}, gap x {best['gap_ratio']:.2f},"
                    f" {best['met']} of {best['of']})" if best else ""))
    return finish(fig, out)


@styled
def target_maps(scores: pd.DataFrame, best: dict[str, Any] | None = None,
                path: str | os.PathLike[str] | None = None) -> Figure:
    """One small map per target: its error in units of its tolerance (met where <= 1,
    outlined), over (theta0, gap ratio)."""
    out = check_path(path)
    if scores.empty:
        raise ValueError("target_maps: the scores table is empty")
    targets = list(dict.fromkeys(scores.sort_values("group", key=_group_key).target))
    ncol = 6
    nrow = math.ceil(len(targets) / ncol)
    fig = Figure(figsize=(3.0 * ncol, 2.6 * nrow + 0.6), layout="constrained")
    axes = fig.subplots(nrow, ncol, sharex=True, sharey=True, squeeze=False).ravel()
    mesh = None
    for ax, target in zip(axes, targets, strict=False):
        sub = scores[scores.target == target]
        at = sub.set_index(["theta0", "gap_ratio"])
        err = (at.error / at.tolerance).clip(upper=5.0)
        th, gr, z = _grid(err)
        mesh = ax.pcolormesh(edges(th), edges(gr), z, cmap="viridis_r", vmin=0, vmax=5,
                             shading="flat")
        if np.nanmin(z) <= 1 < np.nanmax(z):
            ax.contour(th, gr, z, levels=[1.0], colors="w", linewidths=1.2)
        _mark(ax, best)
        ax.set_title(target, fontsize=9)
        ax.grid(False)
    for ax in axes[len(targets):]:
        ax.set_visible(False)
    if mesh is not None:
        fig.colorbar(mesh, ax=list(axes[:len(targets)]), shrink=0.6,
                     label="error / tolerance (met <= 1, white line)")
    fig.supxlabel("theta0, phase at rest (rad)")
    fig.supylabel("anvil-spring gap / Table 2.1's")
    return finish(fig, out)


def _group_key(col: pd.Series) -> pd.Series:
    return col.map({g: i for i, g in enumerate(_GROUP_ORDER)})


def _ramp(n: int) -> list[tuple[float, float, float, float]]:
    from matplotlib import colormaps
    cm = colormaps["viridis"]
    return [cm(i / max(n - 1, 1)) for i in range(n)]


def _ticks(top: int) -> list[int]:
    step = max(1, top // 6)
    return list(range(0, top + 1, step))
