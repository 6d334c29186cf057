"""Figures of the dissertation, one call per figure, from sweeps, runs and validation tables.

Why this module exists: the dissertation states its results as figures -- vibration peaks and
impacts per cycle against flow rate (Figs 3.42, 4.27), impulse per second J* coloured by impact
regime (Fig 4.28), regime and J* maps over excitation frequency and a design parameter (Figs
5.1-5.6), the original against the recommended design (Fig 5.7) and time traces of contact
forces, indentations and acceleration (Figs 4.2-4.6). This module draws each of them from the
objects the rest of vadsim returns (an :class:`xarray.Dataset` of :func:`vadsim.sweep.sweep`, a
:class:`vadsim.SimulationResult`, a pandas table of residuals), with one regime colour table
(:data:`REGIME_COLORS`) so that a regime has the same colour in every figure.

Conventions
-----------
* Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no global
  state, safe with any backend and in threads; never shown). Pass ``path`` (``.png``, ``.pdf``
  or ``.svg``) to save it; in Jupyter the returned figure displays itself.
* Functions that need one axes take ``ax=``: the figure is then drawn into it and the returned
  figure is the one that holds ``ax``.
* Flow rates are in gal/min, excitation frequencies in Hz, accelerations in g, J* and contact
  forces in kN when the dataset (or result) knows the reference mass m*, otherwise in N/kg.
* The operating range of a design is where J* >= :data:`OPERATING_FRACTION` times its maximum
  (dissertation chapter 5: "J* within 10 % of its max").
"""

from __future__ import annotations

import functools
import math
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ParamSpec

import matplotlib as mpl
import numpy as np
import pandas as pd
import xarray as xr
from matplotlib import patheffects
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from vadsim.data import field_events
from vadsim.signals.labels import regime_name

if TYPE_CHECKING:
    from vadsim.model.simulate import SimulationResult

__all__ = [
    "OPERATING_FRACTION",
    "heldout_features",
    "mismatch_base",
    "validation_peaks",
    "REGIME_COLORS",
    "SURFACE_COLORS",
    "SURFACE_LABELS",
    "THESIS_REFERENCES",
    "design_comparison",
    "j_map",
    "j_vs_flow",
    "mismatch_heatmap",
    "peaks_vs_flow",
    "regime_label",
    "regime_map",
    "time_traces",
    "z_vs_flow",
]

REGIME_COLORS: dict[int, str] = {
    -1: "#3d3d3d",  # failed run
    0: "#c8c8c8",  # no impacts
    1: "#0072B2",  # regular spring, regular impact face
    2: "#56B4E9",  # intermittent spring, regular impact face
    3: "#E69F00",  # intermittent spring, intermittent impact face
    4: "#D55E00",  # no spring impact, intermittent impact face
    5: "#009E73",  # no spring impact, regular impact face
    6: "#CC79A7",  # regular spring, intermittent impact face
    7: "#F0E442",  # spring impacts only
}
"""Colour of each scenario code (dissertation Table 4.2, :func:`vadsim.labels.scenario`; -1 is
a failed run). Okabe-Ito colours, distinguishable with the common colour-vision deficiencies;
the best regime (1, both surfaces regular) is the strong blue."""

SURFACE_COLORS: dict[str, str] = {
    "spring": "#1a1a1a",
    "impact": "#b2182b",
    "off_bottom": "#2166ac",
    "on_bottom": "#7b3294",
    "rock": "#8c6d31",
}
"""Line colour of each contact surface (dark, so that lines stay visible on regime bands)."""

SURFACE_LABELS: dict[str, str] = {
    "spring": "#1 recoil spring",
    "impact": "#2 impact face",
    "off_bottom": "#3 off-bottom shoulder",
    "on_bottom": "#4 on-bottom shoulder",
    "rock": "rock",
}
"""Legend label of each contact surface (MODEL.md numbering)."""

_SURFACE_MARKERS = {"spring": "o", "impact": "s", "off_bottom": "^", "on_bottom": "v", "rock": "D"}
_SURFACE_INDEX = {"spring": 0, "impact": 1, "off_bottom": 2, "on_bottom": 3, "rock": 4}

THESIS_REFERENCES: dict[str, tuple[str, str]] = {
    "thesis-7in-cde": ("7in", "CDE"),
    "thesis-7in-rc": ("7in", "RC"),
    "thesis-9.5in-pdc": ("9.5in", "PDC"),
}
"""Reference names accepted by :func:`peaks_vs_flow`: (tool, bit) rows of the shipped
``data/thesis/field_events.csv`` (dissertation Tables 3.1-3.3)."""

OPERATING_FRACTION: float = 0.9
"""A flow (or map point) is in the operating range when J* >= this fraction of the maximum."""

_STYLE: dict[str, Any] = {
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "legend.fontsize": 8.5,
    "legend.title_fontsize": 8.5,
    "legend.framealpha": 0.9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "savefig.dpi": 150,
}
_SAVE_SUFFIXES = (".png", ".pdf", ".svg")
_BAND_ALPHA = 0.22
_MODE_TEXT = {"independent": "independent runs", "continuation": "continuation sweep"}
_DISPLAY_UNITS = {"N/m/kg": (1e-3, "kN/(kg m)")}
_DERIVED_AXES = {
    "gap_ratio": ("anvil-spring gap / preset gap", "–"),
    "gap": ("anvil-spring gap", "l0"),
}

_P = ParamSpec("_P")


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------


def _styled(func: Callable[_P, Figure]) -> Callable[_P, Figure]:
    """Draw (and save) under the module's style, without touching global rcParams."""

    @functools.wraps(func)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> Figure:
        with mpl.rc_context(_STYLE):
            return func(*args, **kwargs)

    return wrapper


def _check_path(path: str | os.PathLike[str] | None) -> Path | None:
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() not in _SAVE_SUFFIXES:
        raise ValueError(f"path {str(p)!r} must end in {', '.join(_SAVE_SUFFIXES)}")
    return p


def _finish(fig: Figure, path: Path | None) -> Figure:
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, bbox_inches="tight")
    return fig


def _new_axes(ax: Axes | None, figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    if ax is None:
        fig = Figure(figsize=figsize, layout="constrained")
        return fig, fig.add_subplot()
    fig = ax.figure
    root = getattr(fig, "figure", None)  # a SubFigure's root figure
    return (root if isinstance(root, Figure) else fig), ax


def regime_label(code: int) -> str:
    """Legend text of a scenario code: ``"1: regular spring, regular impact face"``.

    Parameters
    ----------
    code
        Scenario code 0..7 (:func:`vadsim.labels.scenario`) or -1 for a failed run.
    """
    code = int(code)
    return "failed run" if code == -1 else f"{code}: {regime_name(code)}"


def _scenario_codes(values: Any, func: str) -> np.ndarray:
    arr = np.asarray(values, dtype=float)
    codes = np.where(np.isfinite(arr), arr, -1).astype(int)
    bad = sorted(set(np.unique(codes).tolist()) - set(REGIME_COLORS))
    if bad:
        raise ValueError(f"{func}: scenario codes {bad} are not in -1..7")
    return codes


def _regime_patches(codes: np.ndarray, alpha: float = 1.0) -> list[Patch]:
    return [
        Patch(facecolor=REGIME_COLORS[c], edgecolor="0.3", linewidth=0.5, alpha=alpha,
              label=regime_label(c))
        for c in sorted(set(np.asarray(codes).ravel().tolist()), key=lambda c: (c == -1, c))
    ]


def _require_dataset(ds: Any, func: str) -> xr.Dataset:
    if not isinstance(ds, xr.Dataset):
        raise ValueError(f"{func}: expected an xarray.Dataset from vadsim.sweep, got "
                         f"{type(ds).__name__}")
    if "flow_gpm" not in ds.dims:
        raise ValueError(
            f"{func}: the dataset has no 'flow_gpm' dimension (dims: {tuple(ds.dims)}); "
            "pass a sweep from vadsim.sweep.sweep / flow_sweep"
        )
    return ds


def _require_vars(ds: xr.Dataset, names: Sequence[str], func: str) -> None:
    missing = [n for n in names if n not in ds.data_vars]
    if missing:
        raise ValueError(f"{func}: the dataset has no variable(s) {missing} "
                         f"(it has {sorted(map(str, ds.data_vars))})")


def _flow_line(ds: Any, func: str) -> xr.Dataset:
    """The dataset as one flow sweep: design dims of size 1 dropped, sorted by flow."""
    ds = _require_dataset(ds, func)
    extra = [str(d) for d in ds.dims if d != "flow_gpm"]
    varying = [d for d in extra if ds.sizes[d] > 1]
    if varying:
        d = varying[0]
        raise ValueError(
            f"{func} draws one flow sweep, but the dataset also varies along {varying}; "
            f"select one value first, e.g. ds.isel({d}=0) or ds.sel({d}=...)"
        )
    return ds.isel({d: 0 for d in extra}).sortby("flow_gpm")


def _hz_per_gpm(ds: xr.Dataset) -> float | None:
    """The constant f_exc_hz / flow_gpm of a dataset, or None if unknown or not constant."""
    if "f_exc_hz" not in ds.coords:
        return None
    q = np.asarray(ds["flow_gpm"].values, dtype=float)
    f = np.asarray(ds["f_exc_hz"].values, dtype=float)
    if f.shape != q.shape or q.size == 0 or np.any(q <= 0):
        return None
    ratio = f / q
    k = float(np.median(ratio))
    if not (math.isfinite(k) and k > 0 and np.allclose(ratio, k, rtol=1e-6)):
        return None
    return k


def _frequency_axis(ax: Axes, k: float | None) -> None:
    """A top axis in excitation frequency for an axes whose x is flow."""
    if k is None:
        return
    top = ax.secondary_xaxis("top", functions=(lambda q: q * k, lambda f: f / k))
    top.set_xlabel("excitation frequency (Hz)")


def _flow_axis(ax: Axes, k: float | None) -> None:
    """A top axis in flow rate for an axes whose x is excitation frequency."""
    if k is None:
        return
    top = ax.secondary_xaxis("top", functions=(lambda f: f / k, lambda q: q * k))
    top.set_xlabel("flow rate (gal/min)")


def _describe(ds: xr.Dataset) -> str:
    """'7in-cde, independent runs, kS = 2.5e+05' from a dataset's attributes."""
    parts = [str(ds.attrs.get("preset", "unknown preset"))]
    mode = ds.attrs.get("mode")
    if mode:
        parts.append(_MODE_TEXT.get(str(mode), str(mode)))
    for name, coord in ds.coords.items():
        if name in ("flow_gpm", "f_exc_hz") or coord.ndim != 0:
            continue
        try:
            parts.append(f"{name} = {float(coord.values):.4g}")
        except (TypeError, ValueError):
            continue
    return ", ".join(parts)


def _m_ref(attrs: Any) -> float | None:
    value = attrs.get("m_ref_kg") if hasattr(attrs, "get") else attrs
    try:
        m = float(value)
    except (TypeError, ValueError):
        return None
    return m if math.isfinite(m) and m > 0 else None


def _force_unit(m_ref_kg: float | None, unit: str, func: str) -> tuple[float, str]:
    """Factor from N/kg to ``unit`` and the unit's label."""
    if unit == "auto":
        unit = "kN" if m_ref_kg is not None else "N/kg"
    if unit == "N/kg":
        return 1.0, "N/kg"
    if unit in ("kN", "N"):
        if m_ref_kg is None:
            raise ValueError(f"{func}: unit = {unit!r} needs the reference mass (attribute "
                             "'m_ref_kg'); use unit='N/kg'")
        return (m_ref_kg / 1000.0 if unit == "kN" else m_ref_kg), unit
    raise ValueError(f"{func}: unit = {unit!r} must be 'auto', 'kN', 'N' or 'N/kg'")


def _edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges around sorted cell centres (for pcolormesh)."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        half = 0.05 * abs(c[0]) if c[0] != 0 else 0.5
        return np.array([c[0] - half, c[0] + half])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


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


def _mark_failed(ax: Axes, q: np.ndarray, codes: np.ndarray) -> None:
    failed = codes == -1
    if np.any(failed):
        ax.plot(q[failed], np.full(int(failed.sum()), 0.03), "x", color=REGIME_COLORS[-1],
                markersize=7, mew=1.5, transform=ax.get_xaxis_transform(), clip_on=False,
                label="failed run", zorder=5)


def _legend_below(ax: Axes, handles: Sequence[Any], ncol: int = 2, **kw: Any) -> None:
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=ncol,
              frameon=False, **kw)


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
    unit = ds[name].attrs.get("units") if name in ds.coords else None
    return 1.0, f"{name} ({unit})" if unit else name


def _map_grid(ds: Any, param: str | None, func: str) -> tuple[xr.Dataset, str]:
    """The dataset as a (param, flow_gpm) grid sorted along both axes."""
    ds = _require_dataset(ds, func)
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
    k = _hz_per_gpm(grid)
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
    segments = _cell_outline(inside, _edges(x), _edges(y))
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


# --------------------------------------------------------------------------------------------
# Flow sweeps
# --------------------------------------------------------------------------------------------


@_styled
def peaks_vs_flow(
    ds: xr.Dataset,
    sensor: str = "x1",
    reference: str | pd.DataFrame | None = None,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Mean of the 200 ms acceleration peaks, with their dispersion, against flow rate.

    The dissertation's Figs 3.42 (field against simulation) and 4.27b.

    Parameters
    ----------
    ds
        A flow sweep (:func:`vadsim.sweep.flow_sweep`); design dimensions of size 1 are
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
    out = _check_path(path)
    if sensor not in ("x1", "x5"):
        raise ValueError(f"{func}: sensor = {sensor!r} must be 'x1' or 'x5'")
    line = _flow_line(ds, func)
    mean_name, std_name = f"{sensor}_peak_mean_g", f"{sensor}_peak_std_g"
    _require_vars(line, [mean_name, std_name], func)
    series = _reference_series(reference, sensor, func) if reference is not None else []
    if isinstance(reference, str):
        tool, bit = THESIS_REFERENCES[reference]
        preset = str(line.attrs.get("preset", ""))
        if preset and preset.lower() != f"{tool}-{bit}".lower():
            warnings.warn(f"{func}: overlaying {reference} on a sweep of preset {preset}",
                          stacklevel=3)

    fig, ax = _new_axes(ax, (7.0, 4.6))
    q = np.asarray(line["flow_gpm"].values, float)
    mean = np.asarray(line[mean_name].values, float)
    std = np.asarray(line[std_name].values, float)
    ax.errorbar(q, mean, yerr=std, fmt="o-", color="#0072B2", ecolor="#0072B2", elinewidth=1,
                capsize=3, ms=5, lw=1.4, label="simulated (vadsim): mean \u00b1 dispersion",
                zorder=3)
    for label, rq, rp, rerr, style in series:
        if rerr is not None:
            ax.errorbar(rq, rp, yerr=rerr, capsize=3, label=label, zorder=4, **style)
        else:
            ax.plot(rq, rp, label=label, zorder=4, **style)
    if "scenario" in line:
        _mark_failed(ax, q, _scenario_codes(line["scenario"].values, func))
    ax.set_xlabel("flow rate (gal/min)")
    ax.set_ylabel(f"{sensor} peak acceleration, mean of 200 ms peaks (g)")
    ax.set_ylim(bottom=0)
    ax.margins(x=0.04)
    _frequency_axis(ax, _hz_per_gpm(line))
    where = "bit sub" if sensor == "x1" else "sub above the motor"
    ax.set_title(f"Axial vibration peaks at {sensor} ({where})\n{_describe(line)}")
    handles, labels = ax.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda i: (not labels[i].startswith("simulated (vadsim"),
                                                      labels[i] == "failed run"))
    _legend_below(ax, [handles[i] for i in order])
    return _finish(fig, out)


def _regime_bands(ax: Axes, q: np.ndarray, codes: np.ndarray) -> None:
    """Background bands of constant scenario along flow, each labelled with its code."""
    edges = _edges(q)
    start = 0
    for i in range(1, len(q) + 1):
        if i == len(q) or codes[i] != codes[start]:
            c = int(codes[start])
            lo, hi = edges[start], edges[i]
            ax.axvspan(lo, hi, color=REGIME_COLORS[c], alpha=_BAND_ALPHA, lw=0, zorder=0)
            ax.text(0.5 * (lo + hi), 0.97, "F" if c == -1 else str(c),
                    transform=ax.get_xaxis_transform(), ha="center", va="top",
                    fontsize=9, fontweight="bold", color="0.15", zorder=6, clip_on=True)
            start = i
    ax.set_xlim(edges[0], edges[-1])


@_styled
def z_vs_flow(
    ds: xr.Dataset,
    surfaces: Sequence[str] | None = None,
    bands: bool = True,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Impacts per cycle Z* at each surface against flow, on bands of the impact regime.

    The dissertation's Fig 4.27a. Each band is a run of flows with one scenario (Table 4.2),
    shaded in :data:`REGIME_COLORS` and labelled with its code at the top; the regime legend
    below the axes names them.

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
    out = _check_path(path)
    surfaces = tuple(surfaces) if surfaces is not None else ("spring", "impact", "off_bottom",
                                                             "on_bottom")
    bad = [s for s in surfaces if s not in SURFACE_LABELS]
    if bad or not surfaces:
        raise ValueError(f"{func}: surfaces {bad or '()'} must be among {list(SURFACE_LABELS)}")
    line = _flow_line(ds, func)
    _require_vars(line, [f"z_{s}" for s in surfaces] + (["scenario"] if bands else []), func)

    fig, ax = _new_axes(ax, (7.5, 5.6))
    q = np.asarray(line["flow_gpm"].values, float)
    regime_handles: list[Patch] = []
    if bands:
        codes = _scenario_codes(line["scenario"].values, func)
        _regime_bands(ax, q, codes)
        regime_handles = _regime_patches(codes, alpha=min(1.0, 2 * _BAND_ALPHA))
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
    _frequency_axis(ax, _hz_per_gpm(line))
    ax.set_title(f"Impacts per cycle at each surface\n{_describe(line)}")
    surf_legend = ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), title="surface")
    if regime_handles:
        ax.add_artist(surf_legend)
        surf_legend.set_clip_on(False)  # add_artist clips to the axes; this legend is outside
        _legend_below(ax, regime_handles, title="impact regime (scenario)")
    return _finish(fig, out)


@_styled
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
    out = _check_path(path)
    if variable not in ("j_pos", "j_mean"):
        raise ValueError(f"{func}: variable = {variable!r} must be 'j_pos' or 'j_mean'")
    line = _flow_line(ds, func)
    _require_vars(line, [variable, "scenario"], func)
    factor, unit_label = _force_unit(_m_ref(line.attrs), unit, func)

    fig, ax = _new_axes(ax, (7.0, 5.4))
    q = np.asarray(line["flow_gpm"].values, float)
    j = np.asarray(line[variable].values, float) * factor
    codes = _scenario_codes(line["scenario"].values, func)
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
    _frequency_axis(ax, _hz_per_gpm(line))
    ax.set_title(f"Impulse per second J* ({what}) by impact regime\n{_describe(line)}")
    handles, _ = ax.get_legend_handles_labels()
    _legend_below(ax, handles, title="impact regime (scenario)")
    return _finish(fig, out)


# --------------------------------------------------------------------------------------------
# Maps over flow and one design parameter
# --------------------------------------------------------------------------------------------


_REGIME_CODES = sorted(REGIME_COLORS)
_REGIME_CMAP = ListedColormap([REGIME_COLORS[c] for c in _REGIME_CODES], name="vadsim_regimes")
_REGIME_NORM = BoundaryNorm(np.arange(_REGIME_CODES[0] - 0.5, _REGIME_CODES[-1] + 1.0),
                            _REGIME_CMAP.N)


@_styled
def regime_map(
    ds: xr.Dataset,
    param: str | None = None,
    operating_range: bool = True,
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """The impact regime over excitation frequency (x) and a design parameter (y).

    The dissertation's Figs 5.1, 5.3 and 5.5: each grid point is coloured by its scenario
    (:data:`REGIME_COLORS`, legend of regime names); optionally the operating range (J* within
    10 % of its maximum) is outlined in black with a star at the maximum.

    Parameters
    ----------
    ds
        A sweep with one design dimension besides ``flow_gpm`` (others of size 1 are dropped).
    param
        The design dimension for the y axis; default the dataset's only one.
    operating_range
        Outline J* >= :data:`OPERATING_FRACTION` of its max (needs ``j_pos``).
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
        If the dataset has no ``flow_gpm`` dimension, no design dimension, several design
        dimensions and no ``param``, or lacks ``scenario``.
    """
    func = "regime_map"
    out = _check_path(path)
    grid, param = _map_grid(ds, param, func)
    _require_vars(grid, ["scenario"], func)
    codes = _scenario_codes(grid["scenario"].values, func)
    x, xlabel, k = _map_x(grid)
    factor, ylabel = _param_axis(grid, param)
    y = np.asarray(grid[param].values, float) * factor

    fig, ax = _new_axes(ax, (10.0, 5.6))
    ax.pcolormesh(_edges(x), _edges(y), codes, cmap=_REGIME_CMAP, norm=_REGIME_NORM,
                  shading="flat", edgecolors="face", linewidth=0.0, zorder=1)
    handles: list[Any] = _regime_patches(codes)
    if operating_range and "j_pos" in grid:
        jfactor, junit = _force_unit(_m_ref(grid.attrs), "auto", func)
        j = np.asarray(grid["j_pos"].values, float) * jfactor
        handles += _operating_overlay(ax, x, y, j, "k", junit)
    ax.grid(False)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    _flow_axis(ax, k)
    ax.set_title(f"Impact regime map over excitation frequency and {param}\n{_describe(grid)}")
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
              title="impact regime (scenario)")
    return _finish(fig, out)


@_styled
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
        ``"auto"``, ``"kN"``, ``"N"`` or ``"N/kg"`` (see :func:`j_vs_flow`).
    operating_range
        Outline J* >= :data:`OPERATING_FRACTION` of its max and star the maximum.
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
    out = _check_path(path)
    grid, param = _map_grid(ds, param, func)
    _require_vars(grid, ["j_pos"], func)
    jfactor, junit = _force_unit(_m_ref(grid.attrs), unit, func)
    j = np.asarray(grid["j_pos"].values, float) * jfactor
    x, xlabel, k = _map_x(grid)
    factor, ylabel = _param_axis(grid, param)
    y = np.asarray(grid[param].values, float) * factor

    fig, ax = _new_axes(ax, (7.6, 5.4))
    cm = mpl.colormaps[cmap].with_extremes(bad="#d9d9d9")
    mesh = ax.pcolormesh(_edges(x), _edges(y), np.ma.masked_invalid(j), cmap=cm,
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
                 f"{_describe(grid)}")
    if handles:
        _legend_below(ax, handles, ncol=len(handles))
    return _finish(fig, out)


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


@_styled
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
        ``"auto"``, ``"kN"``, ``"N"`` or ``"N/kg"`` (see :func:`j_vs_flow`); ``"auto"`` is kN
        only if both datasets record ``m_ref_kg``.
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
    out = _check_path(path)
    if len(labels) != 2:
        raise ValueError(f"{func}: labels must name the two designs, got {labels!r}")
    lines = [_flow_line(ds_original, func), _flow_line(ds_recommended, func)]
    for line in lines:
        _require_vars(line, ["j_pos"], func)
    m_refs = [_m_ref(line.attrs) for line in lines]
    if unit == "auto":
        unit = "kN" if all(m is not None for m in m_refs) else "N/kg"
    scales = [_force_unit(m, unit, func) for m in m_refs]
    unit_label = scales[0][1]

    fig, ax = _new_axes(ax, (7.4, 5.0))
    colors = ("0.35", "#0072B2")
    markers = ("o", "s")
    ranges = []
    for line, (factor, _), label, color, marker in zip(lines, scales, labels, colors, markers,
                                                       strict=True):
        q = np.asarray(line["flow_gpm"].values, float)
        j = np.asarray(line["j_pos"].values, float) * factor
        lo, hi, jmax, qmax, runs = _operating_range(q, j)
        ranges.append((lo, hi, jmax))
        ax.plot(q, j, marker=marker, color=color, ms=5, lw=1.5, label=label, zorder=3)
        if not math.isfinite(jmax):
            continue
        level = OPERATING_FRACTION * jmax
        for a, b in runs:
            ax.plot([a, b], [level, level], color=color, lw=6, alpha=0.45,
                    solid_capstyle="butt", zorder=2)
            ax.plot([a, b], [level, level], ls="none", marker="|", ms=14, mew=2, color=color,
                    zorder=2)
        ax.plot([qmax], [jmax], "*", ms=16, mfc=color, mec="k", mew=0.8, zorder=4)
        ax.plot([], [], color=color, lw=6, alpha=0.45,
                label=f"{label}: operating range {lo:g}\u2013{hi:g} gal/min")
    (lo0, hi0, j0), (lo1, hi1, j1) = ranges
    title = (f"peak J*: {j0:.3g} \u2192 {j1:.3g} {unit_label} ({_change(j0, j1)})\n"
             f"operating range width: {hi0 - lo0:g} \u2192 {hi1 - lo1:g} gal/min "
             f"({_change(hi0 - lo0, hi1 - lo1)})")
    ax.set_ylim(bottom=0)
    ax.margins(x=0.04)
    ax.set_xlabel("flow rate (gal/min)")
    ax.set_ylabel(f"J*, mean of max($F_I$, 0) ({unit_label})")
    ks = [_hz_per_gpm(line) for line in lines]
    if ks[0] is not None and ks[1] is not None and math.isclose(ks[0], ks[1], rel_tol=1e-6):
        _frequency_axis(ax, ks[0])
    presets = sorted({str(line.attrs.get("preset", "unknown preset")) for line in lines})
    ax.set_title(f"Original and recommended design: J* and operating range "
                 f"(J* \u2265 {OPERATING_FRACTION:.0%} of max)\n{', '.join(presets)}")
    _legend_below(ax, ax.get_legend_handles_labels()[0], ncol=2, title=title,
                  alignment="left")
    return _finish(fig, out)


# --------------------------------------------------------------------------------------------
# One run
# --------------------------------------------------------------------------------------------


@_styled
def time_traces(
    result: SimulationResult,
    cycles: float = 3,
    unit: str = "auto",
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Contact forces, indentations and bit acceleration over the last cycles of a run.

    The dissertation's Figs 4.2-4.6, as three stacked panels sharing the time axis: the
    recoil-spring and impact-face forces F_S and F_I (and the shoulders' forces when they are
    not zero), the indentations of the spring and impact face (MODEL.md, in mm; contact where
    d > 0), and the x1 acceleration in g. Contact onsets (``result.events``) are marked as
    dotted vertical lines in the surface's colour.

    Parameters
    ----------
    result
        A :class:`vadsim.SimulationResult` recorded with ``record="window"`` or ``"all"``.
    cycles
        How many excitation cycles, counted back from the end of the recording.
    unit
        Force unit: ``"auto"`` (kN if the result knows m*, else N/kg), ``"kN"``, ``"N"``,
        ``"N/kg"``.
    path
        Save the figure there (``.png``, ``.pdf`` or ``.svg``).

    Returns
    -------
    matplotlib.figure.Figure
        With three axes (forces, indentations, acceleration).

    Raises
    ------
    ValueError
        If the result holds no time series, ``cycles`` is not positive, or the unit needs m*.
    """
    func = "time_traces"
    out = _check_path(path)
    t_all = np.asarray(getattr(result, "t", np.empty(0)), float)
    if t_all.size < 2:
        raise ValueError(f"{func}: the result holds no time series; run vadsim.simulate with "
                         "record='window' or record='all'")
    if not (isinstance(cycles, (int, float)) and math.isfinite(cycles) and cycles > 0):
        raise ValueError(f"{func}: cycles = {cycles!r} must be a positive number")
    factor, unit_label = _force_unit(_m_ref(result.m_ref_kg), unit, func)
    period = 1.0 / float(result.f_exc_hz)
    t_end = float(t_all[-1])
    t_start = max(float(t_all[0]), t_end - cycles * period)
    sel = t_all >= t_start - 1e-12
    t = t_all[sel]
    x = np.asarray(result.x, float)[sel]
    forces = np.asarray(result.contact_forces, float)[sel] * factor
    accel = np.asarray(result.a, float)[sel, 0] / 9.80665
    p = result.params
    l0 = float(p["l0"])
    d_spring = (x[:, 2] + p["LS"] * l0) - (x[:, 1] - p["L2"] * l0)
    d_impact = x[:, 1] - x[:, 0]
    shown = (t[-1] - t[0]) / period

    fig = Figure(figsize=(9.0, 8.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    ax_f, ax_d, ax_a = axes
    drawn = ["spring", "impact"] + [s for s in ("off_bottom", "on_bottom")
                                    if np.any(forces[:, _SURFACE_INDEX[s]] != 0)]
    symbols = {"spring": "F_S", "impact": "F_I", "off_bottom": "F_Off", "on_bottom": "F_On"}
    for s in drawn:
        ax_f.plot(t, forces[:, _SURFACE_INDEX[s]], color=SURFACE_COLORS[s], lw=1.2,
                  label=f"${symbols[s].replace('_', '_{')}}}$ {SURFACE_LABELS[s]}")
    ax_f.set_ylabel(f"contact force ({unit_label})")
    ax_d.plot(t, 1e3 * d_spring, color=SURFACE_COLORS["spring"], lw=1.2,
              label=f"$d_S$ {SURFACE_LABELS['spring']}")
    ax_d.plot(t, 1e3 * d_impact, color=SURFACE_COLORS["impact"], lw=1.2,
              label=f"$d_I$ {SURFACE_LABELS['impact']}")
    ax_d.axhline(0.0, color="0.4", lw=0.8, ls="--", label="contact when d > 0")
    ax_d.set_ylabel("indentation d (mm)")
    ax_a.plot(t, accel, color="#0072B2", lw=1.0, label="$a_1$ bit sub (x1)")
    ax_a.set_ylabel("x1 acceleration (g)")
    ax_a.set_xlabel("time (s)")
    ax_a.set_xlim(t[0], t[-1])

    events = result.events
    if events is not None and len(events):
        onsets = events[(events["kind"] == "onset") & (events["time_s"] >= t[0])
                        & (events["time_s"] <= t[-1])]
        for s in drawn:
            times = onsets.loc[onsets["surface"] == s, "time_s"].to_numpy(float)
            for i, te in enumerate(times):
                for a in axes:
                    a.axvline(te, color=SURFACE_COLORS[s], lw=0.9, ls=":", alpha=0.9, zorder=1,
                              label=f"{SURFACE_LABELS[s]} onset" if (a is ax_a and i == 0)
                              else None)
    for a in axes:
        a.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    try:
        code = int(result.scenario)
        regime = f", scenario {regime_label(code)}"
    except (ValueError, KeyError, AttributeError, ZeroDivisionError):
        regime = ""
    fig.suptitle(f"{result.preset or 'custom model'}: Q = {result.flow_gpm:g} gal/min "
                 f"({result.f_exc_hz:.1f} Hz), last {shown:.3g} cycles{regime}")
    return _finish(fig, out)


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------


@_styled
def mismatch_heatmap(
    table: pd.DataFrame,
    vmax: float | None = None,
    annotate: bool = True,
    fmt: str = "{:+.1f}",
    cmap: str = "RdBu_r",
    title: str = "Standardised residuals",
    colorbar_label: str = "standardised residual (\u03c3)",
    ax: Axes | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Heat map of standardised residuals, events as rows and features as columns.

    A diverging colour map centred at 0 (colour limits -vmax..vmax), each cell annotated with
    its value; missing values are grey and annotated "n/a".

    Parameters
    ----------
    table
        Numeric DataFrame, ``index`` = events, ``columns`` = features; the index and column
        names (if set) become the axis labels.
    vmax
        Colour limit; default the largest absolute value, at least 1.
    annotate
        Write each value in its cell.
    fmt
        Format of the annotations.
    cmap
        A diverging matplotlib colour map name.
    title, colorbar_label
        Texts of the figure.
    ax
        Axes to draw into; None: a new figure sized to the table.
    path
        Save the figure there (``.png``, ``.pdf`` or ``.svg``).

    Returns
    -------
    matplotlib.figure.Figure
        With two axes: the map and its colour bar.

    Raises
    ------
    ValueError
        If the table is not a non-empty DataFrame of numbers, or ``vmax`` is not positive.
    """
    func = "mismatch_heatmap"
    out = _check_path(path)
    if not isinstance(table, pd.DataFrame):
        raise ValueError(f"{func}: table must be a pandas DataFrame, got {type(table).__name__}")
    if table.shape[0] == 0 or table.shape[1] == 0:
        raise ValueError(f"{func}: the table is empty (shape {table.shape})")
    non_numeric = [str(c) for c in table.columns
                   if not (pd.api.types.is_numeric_dtype(table[c])
                           and not pd.api.types.is_bool_dtype(table[c]))]
    if non_numeric:
        raise ValueError(f"{func}: columns {non_numeric} are not numeric")
    values = table.to_numpy(dtype=float)
    finite = np.isfinite(values)
    if vmax is None:
        vmax = max(1.0, float(np.max(np.abs(values[finite])))) if finite.any() else 1.0
    elif not (math.isfinite(vmax) and vmax > 0):
        raise ValueError(f"{func}: vmax = {vmax!r} must be positive")
    nrow, ncol = values.shape
    width = min(16.0, max(4.5, 2.2 + 0.95 * ncol))
    height = min(14.0, max(3.0, 1.6 + 0.42 * nrow))
    fig, ax = _new_axes(ax, (width, height))
    cm = mpl.colormaps[cmap].with_extremes(bad="#e6e6e6")
    norm = Normalize(vmin=-vmax, vmax=vmax)
    image = ax.imshow(np.ma.masked_invalid(values), cmap=cm, norm=norm, aspect="auto",
                      interpolation="nearest")
    cbar = fig.colorbar(image, ax=ax, pad=0.02)
    cbar.set_label(colorbar_label)
    ax.grid(False)
    ax.set_xticks(np.arange(ncol), [str(c) for c in table.columns], rotation=30, ha="right",
                  rotation_mode="anchor")
    ax.set_yticks(np.arange(nrow), [str(i) for i in table.index])
    ax.set_xticks(np.arange(-0.5, ncol), minor=True)
    ax.set_yticks(np.arange(-0.5, nrow), minor=True)
    ax.grid(which="minor", color="white", linewidth=1.5)
    ax.tick_params(which="minor", length=0)
    ax.set_xlabel(str(table.columns.name) if table.columns.name else "feature")
    ax.set_ylabel(str(table.index.name) if table.index.name else "event")
    if annotate:
        size = 8.5 if ncol * nrow <= 120 else 7
        for i in range(nrow):
            for k in range(ncol):
                v = values[i, k]
                if math.isfinite(v):
                    text, color = fmt.format(v), ("white" if abs(v) > 0.6 * vmax else "0.1")
                else:
                    text, color = "n/a", "0.45"
                ax.text(k, i, text, ha="center", va="center", fontsize=size, color=color)
    ax.set_title(title)
    return _finish(fig, out)


# Figures of campaigns, validations and diagnoses (imported last: they use the above).
from vadsim.plots.campaigns import heldout_features, mismatch_base, validation_peaks  # noqa: E402
