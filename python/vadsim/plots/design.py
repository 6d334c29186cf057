"""The original against the recommended design: J* along flow and each operating range.

The dissertation's Fig 5.7 (:func:`design_comparison`): the operating range of a design is the
contiguous run of flows around the maximum where J* >= 90 % of it.
"""

from __future__ import annotations

import math
import os

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from vadsim.plots.style import (
    OPERATING_FRACTION,
    check_path,
    finish,
    flow_line,
    force_unit,
    frequency_axis,
    hz_per_gpm,
    legend_below,
    m_ref,
    new_axes,
    require_vars,
    run_length,
    styled,
    wob_text,
)

__all__ = ["design_comparison"]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [i0, i1] (inclusive) of the True runs of a 1-D mask."""
    out: list[tuple[int, int]] = []
    start = None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        elif not m and start is not None:
            out.append((start, i - 1))
            start = None
    if start is not None:
        out.append((start, len(mask) - 1))
    return out




def _operating_range(q: np.ndarray, j: np.ndarray) -> tuple[float, float, float, float, list]:
    """(q_lo, q_hi, jmax, q_at_max, runs) of J* >= OPERATING_FRACTION * max along flow.

    ``q_lo..q_hi`` is the contiguous run of flows around the maximum (the dissertation's
    "operating range"); ``runs`` are all runs as (q_first, q_last).
    """
    if not np.any(np.isfinite(j)):
        return math.nan, math.nan, math.nan, math.nan, []
    imax = int(np.nanargmax(j))
    jmax = float(j[imax])
    inside = np.nan_to_num(j, nan=-np.inf) >= OPERATING_FRACTION * jmax
    runs = _runs(inside)
    main = next(r for r in runs if r[0] <= imax <= r[1])
    return (float(q[main[0]]), float(q[main[1]]), jmax, float(q[imax]),
            [(float(q[a]), float(q[b])) for a, b in runs])


def _change(a: float, b: float) -> str:
    if not (math.isfinite(a) and math.isfinite(b)) or a == 0:
        return "n/a"
    return f"\u00d7{b / a:.2f}, {100 * (b / a - 1):+.0f} %"


@styled
def design_comparison(
    ds_original: xr.Dataset,
    ds_recommended: xr.Dataset,
    labels: tuple[str, str] = ("original", "recommended"),
    unit: str = "auto",
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """J* against flow for two designs, with each operating range marked (Fig 5.7).

    The operating range of a design (J* >= 90 % of its maximum, the contiguous run of flows
    around the maximum) is drawn as a thick bar at the 90 % level in the design's colour, the
    maxima as stars; the legend title gives the ratio of the peaks and of the range widths
    (dissertation: 20 -> 37 kN, +85 %; 270-310 -> 300-390 gal/min, +125 %).

    Parameters
    ----------
    ds_original, ds_recommended
        Flow sweeps with ``j_pos`` (design dimensions of size 1 are dropped).
    labels
        Legend names of the two designs.
    unit
        ``"auto"``, ``"kN"``, ``"N"`` or ``"N/kg"`` (see :func:`~vadsim.plots.flow.j_vs_flow`);
        ``"auto"`` is kN only if both datasets record ``m_ref_kg``.
    ax
        Axes to draw into; None: a new figure.
    path
        Save the figure there (``.png``, ``.pdf`` or ``.svg``).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        If either dataset has no ``flow_gpm`` dimension or no ``j_pos``, or the unit needs a
        reference mass a dataset lacks.
    """
    func = "design_comparison"
    out = check_path(path)
    if len(labels) != 2:
        raise ValueError(f"{func}: labels must name the two designs, got {labels!r}")
    lines = [flow_line(ds_original, func), flow_line(ds_recommended, func)]
    for line in lines:
        require_vars(line, ["j_pos"], func)
    scales = _scales(lines, unit, func)
    unit_label = scales[0][1]

    fig, ax = new_axes(ax, (7.4, 5.0))
    ranges = [
        _draw_design(ax, np.asarray(line["flow_gpm"].values, float),
                     np.asarray(line["j_pos"].values, float) * factor, label, color, marker)
        for line, (factor, _), label, color, marker
        in zip(lines, scales, labels, ("0.35", "#0072B2"), ("o", "s"), strict=True)
    ]
    (lo0, hi0, j0), (lo1, hi1, j1) = ranges
    title = (f"peak J*: {j0:.3g} \u2192 {j1:.3g} {unit_label} ({_change(j0, j1)})\n"
             f"operating range width: {hi0 - lo0:g} \u2192 {hi1 - lo1:g} gal/min "
             f"({_change(hi0 - lo0, hi1 - lo1)})")
    ax.set_ylim(bottom=0)
    ax.margins(x=0.04)
    ax.set_xlabel("flow rate (gal/min)")
    ax.set_ylabel(f"J*, mean of max($F_I$, 0) ({unit_label})")
    ks = [hz_per_gpm(line) for line in lines]
    if ks[0] is not None and ks[1] is not None and math.isclose(ks[0], ks[1], rel_tol=1e-6):
        frequency_axis(ax, ks[0])
    ax.set_title(f"Original and recommended design: J* and operating range "
                 f"(J* \u2265 {OPERATING_FRACTION:.0%} of max)\n{_conditions(lines)}")
    legend_below(ax, ax.get_legend_handles_labels()[0], ncol=2, title=title,
                 alignment="left")
    return finish(fig, out)


def _scales(lines: list[xr.Dataset], unit: str, func: str) -> list[tuple[float, str]]:
    """Factor and label of the force unit of each design; ``"auto"`` is kN only if both
    datasets record m*."""
    m_refs = [m_ref(line.attrs) for line in lines]
    if unit == "auto":
        unit = "kN" if all(m is not None for m in m_refs) else "N/kg"
    return [force_unit(m, unit, func) for m in m_refs]


def _draw_design(ax: Axes, q: np.ndarray, j: np.ndarray, label: str, color: str,
                 marker: str) -> tuple[float, float, float]:
    """One design's J* line, its operating range as a bar at the 90 % level and a star at
    its maximum; returns (q_lo, q_hi, jmax) of the range."""
    lo, hi, jmax, qmax, runs = _operating_range(q, j)
    ax.plot(q, j, marker=marker, color=color, ms=5, lw=1.5, label=label, zorder=3)
    if not math.isfinite(jmax):
        return lo, hi, jmax
    level = OPERATING_FRACTION * jmax
    for a, b in runs:
        ax.plot([a, b], [level, level], color=color, lw=6, alpha=0.45,
                solid_capstyle="butt", zorder=2)
        ax.plot([a, b], [level, level], ls="none", marker="|", ms=14, mew=2, color=color,
                zorder=2)
    ax.plot([qmax], [jmax], "*", ms=16, mfc=color, mec="k", mew=0.8, zorder=4)
    ax.plot([], [], color=color, lw=6, alpha=0.45,
            label=f"{label}: operating range {lo:g}\u2013{hi:g} gal/min")
    return lo, hi, jmax


def _conditions(lines: list[xr.Dataset]) -> str:
    """'7in-cde, WOB 20 klbf, runs of 400 cycles (last 200 analysed)' of the two designs."""
    presets = sorted({str(line.attrs.get("preset", "unknown preset")) for line in lines})
    lengths = {run_length(line.attrs.get("cycles"), line.attrs.get("analyse_cycles"))
               for line in lines}
    parts = [", ".join(presets), wob_text([line.attrs.get("wob_klbf") for line in lines])]
    if len(lengths) == 1 and "" not in lengths:
        parts.append(f"runs of {lengths.pop()}")
    return ", ".join(p for p in parts if p)
