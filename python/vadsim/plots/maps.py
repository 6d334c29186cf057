"""Maps over excitation frequency and one design parameter: impact regime and impulse J*.

The dissertation's Figs 5.1, 5.3, 5.5 (:func:`regime_map`) and 5.2, 5.4, 5.6 (:func:`j_map`),
each with the operating range (J* >= :data:`~vadsim.plots.style.OPERATING_FRACTION` of its
maximum) outlined cell by cell and a star at the maximum.
"""

from __future__ import annotations

import os
from typing import Any

import matplotlib as mpl
import numpy as np
import xarray as xr
from matplotlib import patheffects
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from vadsim.plots.style import (
    OPERATING_FRACTION,
    REGIME_COLORS,
    check_path,
    describe,
    edges,
    finish,
    force_unit,
    hz_per_gpm,
    legend_below,
    m_ref,
    new_axes,
    regime_patches,
    require_dataset,
    require_vars,
    scenario_codes,
    styled,
)

__all__ = ["j_map", "regime_map"]

_DISPLAY_UNITS = {"N/m/kg": (1e-3, "kN/(kg m)")}
_DERIVED_AXES = {
    "gap_ratio": ("anvil-spring gap / preset gap", "\u2013"),
    "gap": ("anvil-spring gap", "l0"),
}


def _flow_axis(ax: Axes, k: float | None) -> None:
    """A top axis in flow rate for an axes whose x is excitation frequency."""
    if k is None:
        return
    top = ax.secondary_xaxis("top", functions=(lambda f: np.divide(f, k),
                                                   lambda q: np.multiply(q, k)))
    top.set_xlabel("flow rate (gal/min)")




def _param_axis(ds: xr.Dataset, name: str) -> tuple[float, str]:
    """Display factor and axis label (with unit) of a design axis."""
    if name in _DERIVED_AXES:
        meaning, unit = _DERIVED_AXES[name]
        return 1.0, f"{meaning}, {name} ({unit})"
    try:
        from vadsim.model.presets import param_table

        table = {row[0]: (row[1], row[2]) for row in param_table()}
    except ImportError:  # pragma: no cover - the core is always built with the package
        table = {}
    if name in table:
        unit, meaning = table[name]
        factor, unit = _DISPLAY_UNITS.get(unit, (1.0, unit))
        unit = "–" if unit == "-" else unit
        return factor, f"{meaning}, {name} ({unit})"
    coord_unit = ds[name].attrs.get("units") if name in ds.coords else None
    return 1.0, f"{name} ({coord_unit})" if coord_unit else name


def _map_grid(ds: Any, param: str | None, func: str) -> tuple[xr.Dataset, str]:
    """The dataset as a (param, flow_gpm) grid sorted along both axes."""
    ds = require_dataset(ds, func)
    design = [str(d) for d in ds.dims if d != "flow_gpm"]
    if param is None:
        varying = [d for d in design if ds.sizes[d] > 1]
        if len(design) == 1:
            param = design[0]
        elif len(varying) == 1:
            param = varying[0]
        elif not design:
            raise ValueError(
                f"{func} needs a design dimension besides 'flow_gpm', but the dataset has only "
                "'flow_gpm'; use j_vs_flow or z_vs_flow for a flow sweep"
            )
        else:
            raise ValueError(
                f"{func}: the dataset has {len(design)} design dimensions {design}; pass "
                f"param= one of them and select one value of the others, e.g. "
                f"{func}(ds.sel({design[-1]}=...), param={design[0]!r})"
            )
    elif param not in design:
        raise ValueError(f"{func}: param = {param!r} is not a design dimension of the dataset "
                         f"(design dimensions: {design})")
    others = [d for d in design if d != param]
    varying = [d for d in others if ds.sizes[d] > 1]
    if varying:
        raise ValueError(f"{func}: besides {param!r} the dataset also varies along {varying}; "
                         f"select one value first, e.g. ds.sel({varying[0]}=...)")
    grid = ds.isel({d: 0 for d in others}).transpose(param, "flow_gpm")
    return grid.sortby("flow_gpm").sortby(param), param


def _map_x(grid: xr.Dataset) -> tuple[np.ndarray, str, float | None]:
    """x values of a map: excitation frequency if the dataset has it, else flow."""
    k = hz_per_gpm(grid)
    if "f_exc_hz" in grid.coords and grid["f_exc_hz"].ndim == 1:
        return np.asarray(grid["f_exc_hz"].values, float), "excitation frequency (Hz)", k
    return np.asarray(grid["flow_gpm"].values, float), "flow rate (gal/min)", None


def _cell_outline(inside: np.ndarray, xe: np.ndarray, ye: np.ndarray) -> list[np.ndarray]:
    """Segments of the boundary of the True cells of a (ny, nx) mask on edges ``xe``, ``ye``."""
    ny, nx = inside.shape
    padded = np.zeros((ny + 2, nx + 2), bool)
    padded[1:-1, 1:-1] = inside
    segments = []
    for iy, ix in zip(*np.nonzero(inside), strict=True):
        x0, x1, y0, y1 = xe[ix], xe[ix + 1], ye[iy], ye[iy + 1]
        if not padded[iy, ix + 1]:  # below
            segments.append(np.array([[x0, y0], [x1, y0]]))
        if not padded[iy + 1, ix + 2]:  # right
            segments.append(np.array([[x1, y0], [x1, y1]]))
        if not padded[iy + 2, ix + 1]:  # above
            segments.append(np.array([[x0, y1], [x1, y1]]))
        if not padded[iy + 1, ix]:  # left
            segments.append(np.array([[x0, y0], [x0, y1]]))
    return segments


def _operating_overlay(ax: Axes, x: np.ndarray, y: np.ndarray, j: np.ndarray, color: str,
                       unit: str) -> list[Line2D]:
    """Outline of the cells with J* >= OPERATING_FRACTION * max and a star at the max.

    The outline follows the cell edges of the map (no interpolation between grid points), so
    a cell is inside exactly when its own J* is in range. Returns the legend handles.
    """
    finite = np.isfinite(j)
    if not np.any(finite) or np.nanmax(j) <= 0:
        return []
    jmax = float(np.nanmax(j))
    iy, ix = np.unravel_index(int(np.nanargmax(j)), j.shape)
    inside = finite & (np.nan_to_num(j, nan=-np.inf) >= OPERATING_FRACTION * jmax)
    # A light line gets a dark outline (and vice versa) so that it shows on every colour.
    halo = "k" if color == "white" else "w"
    outline = [patheffects.withStroke(linewidth=3.6, foreground=halo)]
    segments = _cell_outline(inside, edges(x), edges(y))
    # The halo is a collection of its own under the line: per-segment path effects would
    # notch the line wherever two segments meet.
    for c, width, z in ((halo, 3.6, 3.0), (color, 1.8, 3.1)):
        ax.add_collection(LineCollection(segments, colors=c, linewidths=width, zorder=z,
                                         capstyle="projecting"), autolim=False)
    ax.plot(x[ix], y[iy], "*", ms=15, mfc="white", mec="k", mew=0.8, zorder=4)
    return [
        Line2D([], [], color=color, lw=1.8, path_effects=outline,
               label=f"J* \u2265 {OPERATING_FRACTION:.0%} of max (operating range)"),
        Line2D([], [], ls="none", marker="*", ms=12, mfc="white", mec="k",
               label=f"max J* = {jmax:.3g} {unit}"),
    ]




_REGIME_CODES = sorted(REGIME_COLORS)
_REGIME_CMAP = ListedColormap([REGIME_COLORS[c] for c in _REGIME_CODES], name="vadsim_regimes")
_REGIME_NORM = BoundaryNorm(np.arange(_REGIME_CODES[0] - 0.5, _REGIME_CODES[-1] + 1.0),
                            _REGIME_CMAP.N)


@styled
def regime_map(
    ds: xr.Dataset,
    param: str | None = None,
    operating_range: bool = True,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
    show_simulated: bool = True,
) -> Figure:
    """The impact regime over excitation frequency (x) and a design parameter (y).

    The dissertation's Figs 5.1, 5.3 and 5.5: each grid point is coloured by its scenario
    (:data:`~vadsim.plots.style.REGIME_COLORS`, legend of regime names); optionally the
    operating range (J* within 10 % of its maximum) is outlined in black with a star at the
    maximum.

    Parameters
    ----------
    ds
        A sweep with one design dimension besides ``flow_gpm`` (others of size 1 are dropped).
    param
        The design dimension for the y axis; default the dataset's only one.
    operating_range
        Outline J* >= :data:`~vadsim.plots.style.OPERATING_FRACTION` of its max (needs ``j_pos``).
    ax
        Axes to draw into; None: a new figure.
    path
        Save the figure there (``.png``, ``.pdf`` or ``.svg``).
    show_simulated
        For an adaptive map (variable ``simulated``), mark the points that were run with
        dots: the rest were filled from the agreeing cell around them.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    ValueError
        If the dataset has no ``flow_gpm`` dimension, no design dimension, several design
        dimensions and no ``param``, or lacks ``scenario``.
    """
    func = "regime_map"
    out = check_path(path)
    grid, param = _map_grid(ds, param, func)
    require_vars(grid, ["scenario"], func)
    codes = scenario_codes(grid["scenario"].values, func)
    x, xlabel, k = _map_x(grid)
    factor, ylabel = _param_axis(grid, param)
    y = np.asarray(grid[param].values, float) * factor

    fig, ax = new_axes(ax, (10.0, 5.6))
    ax.pcolormesh(edges(x), edges(y), codes, cmap=_REGIME_CMAP, norm=_REGIME_NORM,
                  shading="flat", edgecolors="face", linewidth=0.0, zorder=1)
    handles: list[Any] = regime_patches(codes)
    if operating_range and "j_pos" in grid:
        jfactor, junit = force_unit(m_ref(grid.attrs), "auto", func)
        j = np.asarray(grid["j_pos"].values, float) * jfactor
        handles += _operating_overlay(ax, x, y, j, "k", junit)
    if show_simulated and "simulated" in grid:
        ran = np.asarray(grid["simulated"].values, bool)
        xx, yy = np.broadcast_to(x, ran.shape), np.broadcast_to(y[:, None], ran.shape)
        handles.append(ax.scatter(xx[ran], yy[ran], s=4.0, c="k", alpha=0.5, linewidths=0,
                                  zorder=3, label=f"run ({ran.mean():.0%}; the rest filled)"))
    ax.grid(False)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    _flow_axis(ax, k)
    ax.set_title(f"Impact regime map over excitation frequency and {param}\n{describe(grid)}")
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              title="impact regime (scenario)")
    return finish(fig, out)


@styled
def j_map(
    ds: xr.Dataset,
    param: str | None = None,
    unit: str = "auto",
    operating_range: bool = True,
    cmap: str = "viridis",
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """J* over excitation frequency (x) and a design parameter (y), as a colour map.

    The dissertation's Figs 5.2, 5.4 and 5.6, with a colour bar in kN (or N/kg) and,
    optionally, the operating range (J* within 10 % of its max) outlined in white.

    Parameters
    ----------
    ds
        A sweep with one design dimension besides ``flow_gpm`` and variable ``j_pos``.
    param
        The design dimension for the y axis; default the dataset's only one.
    unit
        ``"auto"``, ``"kN"``, ``"N"`` or ``"N/kg"`` (see :func:`~vadsim.plots.flow.j_vs_flow`).
    operating_range
        Outline J* >= :data:`~vadsim.plots.style.OPERATING_FRACTION` of its max and star the
        maximum.
    cmap
        A continuous matplotlib colour map name.
    ax
        Axes to draw into; None: a new figure.
    path
        Save the figure there (``.png``, ``.pdf`` or ``.svg``).

    Returns
    -------
    matplotlib.figure.Figure
        With two axes: the map and its colour bar.

    Raises
    ------
    ValueError
        As :func:`regime_map`, or if the unit needs a reference mass the dataset lacks.
    """
    func = "j_map"
    out = check_path(path)
    grid, param = _map_grid(ds, param, func)
    require_vars(grid, ["j_pos"], func)
    jfactor, junit = force_unit(m_ref(grid.attrs), unit, func)
    j = np.asarray(grid["j_pos"].values, float) * jfactor
    x, xlabel, k = _map_x(grid)
    factor, ylabel = _param_axis(grid, param)
    y = np.asarray(grid[param].values, float) * factor

    fig, ax = new_axes(ax, (7.6, 5.4))
    cm = mpl.colormaps[cmap].with_extremes(bad="#d9d9d9")
    mesh = ax.pcolormesh(edges(x), edges(y), np.ma.masked_invalid(j), cmap=cm,
                         shading="flat", zorder=1)
    cbar = fig.colorbar(mesh, ax=ax, pad=0.02)
    cbar.set_label(f"J*, mean of max($F_I$, 0) ({junit})")
    ax.grid(False)
    handles: list[Any] = []
    if operating_range:
        handles = _operating_overlay(ax, x, y, j, "white", junit)
    if np.any(~np.isfinite(j)):
        handles.append(Patch(facecolor="#d9d9d9", edgecolor="0.3", label="failed run"))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    _flow_axis(ax, k)
    ax.set_title(f"Impulse per second J* over excitation frequency and {param}\n"
                 f"{describe(grid)}")
    if handles:
        legend_below(ax, handles, ncol=len(handles))
    return finish(fig, out)


