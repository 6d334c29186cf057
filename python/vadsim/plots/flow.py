"""Figures along flow rate of one sweep: vibration peaks, impacts per cycle, impulse J*.

The dissertation's Figs 3.42 and 4.27b (:func:`peaks_vs_flow`, optionally over its own field
and simulated points), 4.27a (:func:`z_vs_flow`, on bands of the impact regime) and 4.28
(:func:`j_vs_flow`, points coloured by regime). Each takes a flow sweep of
:func:`vadsim.studies.sweep.sweep`; design dimensions of size 1 are dropped, larger ones refused.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from vadsim.data import field_events
from vadsim.plots.style import (
    REGIME_COLORS,
    SURFACE_COLORS,
    SURFACE_LABELS,
    check_path,
    describe,
    edges,
    finish,
    flow_line,
    force_unit,
    frequency_axis,
    hz_per_gpm,
    legend_below,
    m_ref,
    new_axes,
    regime_label,
    regime_patches,
    require_vars,
    scenario_codes,
    styled,
)

__all__ = ["THESIS_REFERENCES", "j_vs_flow", "peaks_vs_flow", "z_vs_flow"]

THESIS_REFERENCES: dict[str, tuple[str, str]] = {
    "thesis-7in-cde": ("7in", "CDE"),
    "thesis-7in-rc": ("7in", "RC"),
    "thesis-9.5in-pdc": ("9.5in", "PDC"),
}
"""Reference names accepted by :func:`peaks_vs_flow`: (tool, bit) rows of the shipped
``data/thesis/field_events.csv`` (dissertation Tables 3.1-3.3)."""

_SURFACE_MARKERS = {"spring": "o", "impact": "s", "off_bottom": "^", "on_bottom": "v", "rock": "D"}
_BAND_ALPHA = 0.22


def _mark_failed(ax: Axes, q: np.ndarray, codes: np.ndarray) -> None:
    failed = codes == -1
    if np.any(failed):
        ax.plot(q[failed], np.full(int(failed.sum()), 0.03), "x", color=REGIME_COLORS[-1],
                markersize=7, mew=1.5, transform=ax.get_xaxis_transform(), clip_on=False,
                label="failed run", zorder=5)




def _reference_series(
    reference: str | pd.DataFrame, sensor: str, func: str
) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray | None, dict[str, Any]]]:
    """(label, flow, peak, dispersion or None, style) for each reference series to draw."""
    field_style = dict(marker="s", color="k", ms=6, ls="-", lw=0.8)
    sim_style = dict(marker="D", color="#b2182b", mfc="white", mew=1.3, ms=6, ls="--", lw=0.8)
    if isinstance(reference, str):
        if reference not in THESIS_REFERENCES:
            raise ValueError(f"{func}: reference = {reference!r} must be a DataFrame or one of "
                             f"{', '.join(THESIS_REFERENCES)}")
        if sensor != "x1":
            raise ValueError(f"{func}: the dissertation's field table reports peaks at x1 only, "
                             f"not {sensor}")
        tool, bit = THESIS_REFERENCES[reference]
        table = field_events()
        table = table[(table["tool"] == tool) & (table["bit"] == bit)]
        names = [("field_peak_g", "field (dissertation)", field_style),
                 ("sim_peak_g", "simulated (dissertation)", sim_style)]
    elif isinstance(reference, pd.DataFrame):
        table = reference
        if "flow_gpm" not in table.columns:
            raise ValueError(f"{func}: the reference table has no 'flow_gpm' column "
                             f"(columns: {list(table.columns)})")
        names = [("field_peak_g", "field (reference)", field_style),
                 ("sim_peak_g", "simulated (reference)", sim_style),
                 (f"{sensor}_peak_mean_g", "reference",
                  dict(marker="o", color="#2166ac", mfc="white", mew=1.3, ms=6, ls=":", lw=1))]
        if not any(n in table.columns for n, _, _ in names):
            raise ValueError(
                f"{func}: the reference table needs a column 'field_peak_g', 'sim_peak_g' or "
                f"'{sensor}_peak_mean_g' (columns: {list(table.columns)})"
            )
    else:
        raise ValueError(f"{func}: reference must be a pandas DataFrame or one of "
                         f"{', '.join(THESIS_REFERENCES)}, got {type(reference).__name__}")
    out = []
    for column, label, style in names:
        if column not in table.columns:
            continue
        rows = table[["flow_gpm", column]].astype(float).dropna().sort_values("flow_gpm")
        if rows.empty:
            continue
        err = None
        std_col = column.replace("_mean_g", "_std_g")
        if std_col != column and std_col in table.columns:
            err = table.loc[rows.index, std_col].astype(float).to_numpy()
        out.append((label, rows["flow_gpm"].to_numpy(), rows[column].to_numpy(), err, style))
    return out


def _reference(reference: str | pd.DataFrame | None, sensor: str, line: xr.Dataset,
               func: str) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray | None,
                                        dict[str, Any]]]:
    """The reference series of :func:`peaks_vs_flow`, with a warning if a thesis reference is
    of another tool than the sweep's preset."""
    if reference is None:
        return []
    series = _reference_series(reference, sensor, func)
    if isinstance(reference, str):
        tool, bit = THESIS_REFERENCES[reference]
        preset = str(line.attrs.get("preset", ""))
        if preset and preset.lower() != f"{tool}-{bit}".lower():
            warnings.warn(f"{func}: overlaying {reference} on a sweep of preset {preset}",
                          stacklevel=4)  # the caller of peaks_vs_flow (under @styled)
    return series


def _draw_series(ax: Axes, series: Sequence[tuple[str, np.ndarray, np.ndarray,
                                                  np.ndarray | None, dict[str, Any]]]) -> None:
    for label, rq, rp, rerr, style in series:
        if rerr is not None:
            ax.errorbar(rq, rp, yerr=rerr, capsize=3, label=label, zorder=4, **style)
        else:
            ax.plot(rq, rp, label=label, zorder=4, **style)


@styled
def peaks_vs_flow(
    ds: xr.Dataset,
    sensor: str = "x1",
    reference: str | pd.DataFrame | None = None,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Mean of the 200 ms acceleration peaks, with their std as error bars, against flow rate.

    The dissertation's Figs 3.42 (field against simulation) and 4.27b.

    Parameters
    ----------
    ds
        A flow sweep (:func:`vadsim.studies.sweep.flow_sweep`); design dimensions of size 1 are
        dropped, larger ones must be selected first.
    sensor
        ``"x1"`` (bit sub) or ``"x5"`` (above the motor): plots ``<sensor>_peak_mean_g`` with
        ``<sensor>_peak_std_g`` as error bars.
    reference
        Points to overlay. A name in :data:`THESIS_REFERENCES` (``"thesis-7in-cde"``,
        ``"thesis-7in-rc"``, ``"thesis-9.5in-pdc"``) draws the dissertation's field peaks and
        its own simulated peaks of those events (shipped ``field_events.csv``, x1 only). A
        DataFrame needs ``flow_gpm`` and any of ``field_peak_g``, ``sim_peak_g`` and
        ``<sensor>_peak_mean_g`` (with ``<sensor>_peak_std_g`` as error bars if present).
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
        If the dataset has no ``flow_gpm`` dimension or the needed variables, the sensor is
        unknown, or the reference cannot be read.
    """
    func = "peaks_vs_flow"
    out = check_path(path)
    if sensor not in ("x1", "x5"):
        raise ValueError(f"{func}: sensor = {sensor!r} must be 'x1' or 'x5'")
    line = flow_line(ds, func)
    mean_name, std_name = f"{sensor}_peak_mean_g", f"{sensor}_peak_std_g"
    require_vars(line, [mean_name, std_name], func)
    series = _reference(reference, sensor, line, func)

    fig, ax = new_axes(ax, (7.0, 4.6))
    q = np.asarray(line["flow_gpm"].values, float)
    mean = np.asarray(line[mean_name].values, float)
    std = np.asarray(line[std_name].values, float)
    ax.errorbar(q, mean, yerr=std, fmt="o-", color="#0072B2", ecolor="#0072B2", elinewidth=1,
                capsize=3, ms=5, lw=1.4, zorder=3,
                label="simulated (vadsim): mean \u00b1 std of 200 ms peaks")
    _draw_series(ax, series)
    if "scenario" in line:
        _mark_failed(ax, q, scenario_codes(line["scenario"].values, func))
    ax.set_xlabel("flow rate (gal/min)")
    ax.set_ylabel(f"{sensor} peak acceleration, mean of 200 ms peaks (g)")
    ax.set_ylim(bottom=0)
    ax.margins(x=0.04)
    frequency_axis(ax, hz_per_gpm(line))
    where = "bit sub" if sensor == "x1" else "sub above the motor"
    ax.set_title(f"Axial vibration peaks at {sensor} ({where})\n{describe(line)}")
    handles, labels = ax.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda i: (not labels[i].startswith("simulated (vadsim"),
                                                      labels[i] == "failed run"))
    legend_below(ax, [handles[i] for i in order])
    return finish(fig, out)


def _regime_bands(ax: Axes, q: np.ndarray, codes: np.ndarray) -> None:
    """Background bands of constant scenario along flow, each labelled with its code."""
    cells = edges(q)
    start = 0
    for i in range(1, len(q) + 1):
        if i == len(q) or codes[i] != codes[start]:
            c = int(codes[start])
            lo, hi = cells[start], cells[i]
            ax.axvspan(lo, hi, color=REGIME_COLORS[c], alpha=_BAND_ALPHA, lw=0, zorder=0)
            ax.text(0.5 * (lo + hi), 0.97, "F" if c == -1 else str(c),
                    transform=ax.get_xaxis_transform(), ha="center", va="top",
                    fontsize=9, fontweight="bold", color="0.15", zorder=6, clip_on=True)
            start = i
    ax.set_xlim(cells[0], cells[-1])


@styled
def z_vs_flow(
    ds: xr.Dataset,
    surfaces: Sequence[str] | None = None,
    bands: bool = True,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Impacts per cycle Z* at each surface against flow, on bands of the impact regime.

    The dissertation's Fig 4.27a. Each band is a run of flows with one scenario (Table 4.2),
    shaded in :data:`~vadsim.plots.style.REGIME_COLORS` and labelled with its code at the top;
    the regime legend below the axes names them.

    Parameters
    ----------
    ds
        A flow sweep with ``z_<surface>`` (and ``scenario`` for the bands).
    surfaces
        Surfaces to draw, from ``spring``, ``impact``, ``off_bottom``, ``on_bottom``,
        ``rock``; default the four impact surfaces.
    bands
        Shade the regimes (needs ``scenario``).
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
        If the dataset has no ``flow_gpm`` dimension, a surface is unknown or a variable is
        missing.
    """
    func = "z_vs_flow"
    out = check_path(path)
    surfaces = tuple(surfaces) if surfaces is not None else ("spring", "impact", "off_bottom",
                                                             "on_bottom")
    bad = [s for s in surfaces if s not in SURFACE_LABELS]
    if bad or not surfaces:
        raise ValueError(f"{func}: surfaces {bad or '()'} must be among {list(SURFACE_LABELS)}")
    line = flow_line(ds, func)
    require_vars(line, [f"z_{s}" for s in surfaces] + (["scenario"] if bands else []), func)

    fig, ax = new_axes(ax, (7.5, 5.6))
    q = np.asarray(line["flow_gpm"].values, float)
    regime_handles: list[Patch] = []
    if bands:
        codes = scenario_codes(line["scenario"].values, func)
        _regime_bands(ax, q, codes)
        regime_handles = regime_patches(codes, alpha=min(1.0, 2 * _BAND_ALPHA))
    zmax = 1.0
    for s in surfaces:
        z = np.asarray(line[f"z_{s}"].values, float)
        if np.any(np.isfinite(z)):
            zmax = max(zmax, float(np.nanmax(z)))
        ax.plot(q, z, marker=_SURFACE_MARKERS[s], color=SURFACE_COLORS[s], ms=5, lw=1.3,
                label=SURFACE_LABELS[s], zorder=3)
    ax.set_ylim(-0.04 * zmax, 1.22 * zmax)
    ax.set_xlabel("flow rate (gal/min)")
    ax.set_ylabel("Z* (impacts/cycle)")
    frequency_axis(ax, hz_per_gpm(line))
    ax.set_title(f"Impacts per cycle at each surface\n{describe(line)}")
    surf_legend = ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), title="surface")
    if regime_handles:
        ax.add_artist(surf_legend)
        surf_legend.set_clip_on(False)  # add_artist clips to the axes; this legend is outside
        legend_below(ax, regime_handles, title="impact regime (scenario)")
    return finish(fig, out)


@styled
def j_vs_flow(
    ds: xr.Dataset,
    unit: str = "auto",
    variable: str = "j_pos",
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Impulse per second J* against flow, each point coloured by its impact regime.

    The dissertation's Fig 4.28.

    Parameters
    ----------
    ds
        A flow sweep with ``variable`` and ``scenario``.
    unit
        ``"auto"`` (kN if the dataset has attribute ``m_ref_kg``, else N/kg), ``"kN"``,
        ``"N"`` or ``"N/kg"``.
    variable
        ``"j_pos"`` (mean of max(F_I, 0), the default) or ``"j_mean"`` (plain mean of F_I).
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
        If the dataset has no ``flow_gpm`` dimension or the variables, or the unit needs a
        reference mass the dataset does not record.
    """
    func = "j_vs_flow"
    out = check_path(path)
    if variable not in ("j_pos", "j_mean"):
        raise ValueError(f"{func}: variable = {variable!r} must be 'j_pos' or 'j_mean'")
    line = flow_line(ds, func)
    require_vars(line, [variable, "scenario"], func)
    factor, unit_label = force_unit(m_ref(line.attrs), unit, func)

    fig, ax = new_axes(ax, (7.0, 5.4))
    q = np.asarray(line["flow_gpm"].values, float)
    j = np.asarray(line[variable].values, float) * factor
    codes = scenario_codes(line["scenario"].values, func)
    ax.plot(q, j, "-", color="0.55", lw=1.0, zorder=2)
    for c in sorted(set(codes.tolist()) - {-1}):
        sel = codes == c
        ax.scatter(q[sel], j[sel], s=42, color=REGIME_COLORS[c], edgecolors="k",
                   linewidths=0.5, zorder=3, label=regime_label(c))
    _mark_failed(ax, q, codes)
    ax.set_ylim(bottom=min(0.0, float(np.nanmin(j))) if np.any(np.isfinite(j)) else 0.0)
    ax.margins(x=0.04)
    ax.set_xlabel("flow rate (gal/min)")
    what = "mean of max($F_I$, 0)" if variable == "j_pos" else "mean of $F_I$"
    ax.set_ylabel(f"J* ({unit_label})")
    frequency_axis(ax, hz_per_gpm(line))
    ax.set_title(f"Impulse per second J* ({what}) by impact regime\n{describe(line)}")
    handles, _ = ax.get_legend_handles_labels()
    legend_below(ax, handles, title="impact regime (scenario)")
    return finish(fig, out)
