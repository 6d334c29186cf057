"""What every figure of :mod:`vadsim.plots` shares: colours, the style, saving, units, titles.

Why this module exists: a regime, a surface or a feature must look and read the same in every
figure, whichever module draws it, so the colour tables, the matplotlib style, the checks of a
dataset, the unit conversions and the human names of features live here, once. Every name is
public because the figure modules (:mod:`~vadsim.plots.flow`, :mod:`~vadsim.plots.maps`,
:mod:`~vadsim.plots.design`, :mod:`~vadsim.plots.traces`, :mod:`~vadsim.plots.campaigns`) use
them; only the colour tables, :data:`OPERATING_FRACTION` and :func:`regime_label` are
re-exported by :mod:`vadsim.plots`.
"""

from __future__ import annotations

import functools
import math
import os
import re
import textwrap
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ParamSpec, TypeVar

import matplotlib as mpl
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from vadsim.signals.labels import regime_name

if TYPE_CHECKING:
    from matplotlib.typing import RcKeyType

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
"""Colour of each scenario code (dissertation Table 4.2, :func:`vadsim.signals.labels.scenario`;
-1 is a failed run). Okabe-Ito colours, distinguishable with the common colour-vision
deficiencies; the best regime (1, both surfaces regular) is the strong blue."""

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

OPERATING_FRACTION: float = 0.9
"""A flow (or map point) is in the operating range when J* >= this fraction of the maximum."""

STYLE: dict[RcKeyType, Any] = {
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
SAVE_SUFFIXES = (".png", ".pdf", ".svg")
MODE_TEXT = {"independent": "independent runs", "continuation": "continuation sweep"}

_P = ParamSpec("_P")
_F = TypeVar("_F", bound="Figure | None")  # a figure, or None when there is nothing to draw


def styled(func: Callable[_P, _F]) -> Callable[_P, _F]:
    """Draw (and save) under the module's style, without touching global rcParams."""

    @functools.wraps(func)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _F:
        with mpl.rc_context(STYLE):
            return func(*args, **kwargs)

    return wrapper


#: Width of an average character of the style's sans-serif font, in units of its size: what
#: :func:`wrap_title` divides the room by (DejaVu Sans averages ~0.55 em; 0.6 leaves a margin).
CHAR_EM = 0.6


def wrap_title(text: str, width_in: float, fontsize: float) -> str:
    """``text`` with its lines broken at spaces so that each fits ``width_in`` inches at
    ``fontsize`` points: a title wider than its figure is cut off at both edges (it is
    centred), in the saved file and on every page that shows it."""
    chars = max(20, int(width_in * 72.0 / (CHAR_EM * fontsize)))
    return "\n".join(textwrap.fill(line, chars, break_on_hyphens=False) or line
                     for line in text.split("\n"))


def fit_titles(fig: Figure) -> Figure:
    """Re-wrap the figure's title and its axes' titles until each lies inside the figure.

    A centred title wider than its figure, or centred over an axes that sits right of the
    figure's centre, is cut off at its edges in the saved image; each such title is measured
    after a draw and broken into more lines (at spaces) until it fits. Returns ``fig``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    texts = [t for t in [getattr(fig, "_suptitle", None), *(ax.title for ax in fig.axes)]
             if t is not None and t.get_text()]
    for text in texts:
        original = text.get_text()
        width = fig.get_figwidth()
        for _ in range(12):
            with warnings.catch_warnings():  # a tiny figure's layout warns again when drawn
                warnings.simplefilter("ignore", UserWarning)
                canvas.draw()
            box = text.get_window_extent(canvas.get_renderer())
            if box.x0 >= -0.5 and box.x1 <= fig.bbox.width + 0.5:
                break
            width *= 0.85
            text.set_text(wrap_title(original, width, float(text.get_fontsize())))
    return fig


def check_path(path: str | os.PathLike[str] | None) -> Path | None:
    """``path`` as a Path (None stays None), refused unless it ends in a saved format."""
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() not in SAVE_SUFFIXES:
        raise ValueError(f"path {str(p)!r} must end in {', '.join(SAVE_SUFFIXES)}")
    return p


def finish(fig: Figure, path: Path | None) -> Figure:
    """Save ``fig`` to ``path`` (creating its folder) unless ``path`` is None; return it."""
    fit_titles(fig)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, bbox_inches="tight")
    return fig


def new_axes(ax: Axes | None, figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    """A new figure with one axes, or the root figure of a given ``ax`` and ``ax`` itself."""
    if ax is None:
        fig = Figure(figsize=figsize, layout="constrained")
        return fig, fig.add_subplot()
    parent = ax.figure
    root = getattr(parent, "figure", None)  # a SubFigure's root figure
    if isinstance(root, Figure):
        return root, ax
    assert isinstance(parent, Figure)  # a SubFigure always has a root figure (above)
    return parent, ax


def regime_label(code: int) -> str:
    """Legend text of a scenario code: ``"1: regular spring, regular impact face"``.

    Parameters
    ----------
    code
        Scenario code 0..7 (:func:`vadsim.signals.labels.scenario`) or -1 for a failed run.
    """
    code = int(code)
    return "failed run" if code == -1 else f"{code}: {regime_name(code)}"


def scenario_codes(values: Any, func: str) -> np.ndarray:
    """Scenario codes as ints (NaN, a failed run, becomes -1), refused outside -1..7."""
    arr = np.asarray(values, dtype=float)
    codes = np.where(np.isfinite(arr), arr, -1).astype(int)
    bad = sorted(set(np.unique(codes).tolist()) - set(REGIME_COLORS))
    if bad:
        raise ValueError(f"{func}: scenario codes {bad} are not in -1..7")
    return codes


def regime_patches(codes: np.ndarray, alpha: float = 1.0) -> list[Patch]:
    """One legend patch per scenario code present, in code order, failed runs last."""
    return [
        Patch(facecolor=REGIME_COLORS[c], edgecolor="0.3", linewidth=0.5, alpha=alpha,
              label=regime_label(c))
        for c in sorted(set(np.asarray(codes).ravel().tolist()), key=lambda c: (c == -1, c))
    ]


def require_dataset(ds: Any, func: str) -> xr.Dataset:
    if not isinstance(ds, xr.Dataset):
        raise ValueError(f"{func}: expected an xarray.Dataset from vadsim.studies.sweep, got "
                         f"{type(ds).__name__}")
    if "flow_gpm" not in ds.dims:
        raise ValueError(
            f"{func}: the dataset has no 'flow_gpm' dimension (dims: {tuple(ds.dims)}); "
            "pass a sweep from vadsim.studies.sweep.sweep / flow_sweep"
        )
    return ds


def require_vars(ds: xr.Dataset, names: Sequence[str], func: str) -> None:
    missing = [n for n in names if n not in ds.data_vars]
    if missing:
        raise ValueError(f"{func}: the dataset has no variable(s) {missing} "
                         f"(it has {sorted(map(str, ds.data_vars))})")


def flow_line(ds: Any, func: str) -> xr.Dataset:
    """The dataset as one flow sweep: design dims of size 1 dropped, sorted by flow."""
    ds = require_dataset(ds, func)
    extra = [str(d) for d in ds.dims if d != "flow_gpm"]
    varying = [d for d in extra if ds.sizes[d] > 1]
    if varying:
        d = varying[0]
        raise ValueError(
            f"{func} draws one flow sweep, but the dataset also varies along {varying}; "
            f"select one value first, e.g. ds.isel({d}=0) or ds.sel({d}=...)"
        )
    return ds.isel({d: 0 for d in extra}).sortby("flow_gpm")


def hz_per_gpm(ds: xr.Dataset) -> float | None:
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


def frequency_axis(ax: Axes, k: float | None) -> None:
    """A top axis in excitation frequency for an axes whose x is flow."""
    if k is None:
        return
    top = ax.secondary_xaxis("top", functions=(lambda q: np.multiply(q, k),
                                                   lambda f: np.divide(f, k)))
    top.set_xlabel("excitation frequency (Hz)")


def describe(ds: xr.Dataset) -> str:
    """Two title lines from a sweep's attributes and scalar coordinates.

    ``"7in-cde, WOB 20 klbf, kS = 2.5e+05"`` and ``"independent runs of 400 cycles (last 200
    analysed)"``; what the dataset does not record is left out.
    """
    parts = [str(ds.attrs.get("preset", "unknown preset")), wob_text([ds.attrs.get("wob_klbf")])]
    for name, coord in ds.coords.items():
        if name in ("flow_gpm", "f_exc_hz") or coord.ndim != 0:
            continue
        try:
            parts.append(f"{name} = {float(coord.values):.4g}")
        except (TypeError, ValueError):
            continue
    mode = ds.attrs.get("mode")
    how = MODE_TEXT.get(str(mode), str(mode)) if mode else ""
    runs = run_length(ds.attrs.get("cycles"), ds.attrs.get("analyse_cycles"))
    if runs:
        how = (f"{how} of {runs}" if how.endswith("runs")
               else f"{how}, runs of {runs}" if how else f"runs of {runs}")
    first = ", ".join(p for p in parts if p)
    return f"{first}\n{how}" if how else first


def _finite(value: Any) -> float | None:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def wob_text(values: Sequence[Any]) -> str:
    """``"WOB 20 klbf"`` (or ``"WOB 15-25 klbf"`` if it varies) from klbf values; ``""`` if
    none of them is a number."""
    known = sorted({v for v in map(_finite, values) if v is not None})
    if not known:
        return ""
    if len(known) == 1:
        return f"WOB {known[0]:g} klbf"
    return f"WOB {known[0]:g}\u2013{known[-1]:g} klbf"


def run_length(cycles: Any, analyse_cycles: Any = None) -> str:
    """``"400 cycles (last 200 analysed)"`` of a run's settings; ``""`` if unknown."""
    n = _finite(cycles)
    if n is None:
        return ""
    last = _finite(analyse_cycles)
    return f"{n:g} cycles" + (f" (last {last:g} analysed)" if last is not None else "")


def m_ref(attrs: Any) -> float | None:
    """The reference mass m* (kg) from attributes (or a number), None if unknown."""
    value = attrs.get("m_ref_kg") if hasattr(attrs, "get") else attrs
    try:
        m = float(value)
    except (TypeError, ValueError):
        return None
    return m if math.isfinite(m) and m > 0 else None


def force_unit(m_ref_kg: float | None, unit: str, func: str) -> tuple[float, str]:
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


def edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges around sorted cell centres (for pcolormesh)."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        half = 0.05 * abs(c[0]) if c[0] != 0 else 0.5
        return np.array([c[0] - half, c[0] + half])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def legend_below(ax: Axes, handles: Sequence[Any], ncol: int = 2, **kw: Any) -> None:
    """A frameless legend centred under the axes."""
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=ncol,
              frameon=False, **kw)




_FEATURE_PATTERNS: tuple[tuple[re.Pattern[str], str], ...] = tuple(
    (re.compile(pattern), text) for pattern, text in (
        (r"^(?P<a>.+)_(?P<b>[^_]+)_peak_ratio$", "{a}/{b} ratio of 200 ms peaks (\u2013)"),
        (r"^(?P<s>.+)_peak_mean_g$", "{s} mean of 200 ms peaks (g)"),
        (r"^(?P<s>.+)_peak_std_g$", "{s} std of 200 ms peaks (g)"),
        (r"^(?P<s>.+)_band_(?P<lo>[0-9p]+)_(?P<hi>[0-9p]+)_g$", "{s} band RMS {lo}-{hi} Hz (g)"),
        (r"^(?P<s>.+)_impact_hz$", "{s} impact rate (Hz)"),
        (r"^(?P<s>.+)_impacts_per_cycle$", "{s} impacts per cycle (\u2013)"),
        (r"^(?P<s>.+)_clipped_windows$", "{s} fraction of clipped windows (\u2013)"),
        (r"^z_(?P<surface>spring|impact|off_bottom|on_bottom|rock)$",
         "Z* at {surface} (impacts/cycle)"),
    )
)
_UNIT_SUFFIXES = {"_g": "g", "_hz": "Hz", "_s": "s", "_gpm": "gal/min", "_klbf": "klbf"}


def feature_label(key: str) -> str:
    """Human name with unit of a feature key (:mod:`vadsim.signals.features`).

    ``x1_peak_mean_g`` -> ``"x1 mean of 200 ms peaks (g)"``, ``x5_band_100_200_g`` -> ``"x5
    band RMS 100-200 Hz (g)"``, ``x1_impact_hz`` -> ``"x1 impact rate (Hz)"``; ratios and counts
    per cycle are dimensionless, ``(–)``. A key of no known form keeps its words, with the
    unit its suffix names (``_g``, ``_hz``, ...) or ``(–)``.
    """
    key = str(key)
    for pattern, text in _FEATURE_PATTERNS:
        m = pattern.match(key)
        if m:
            parts = {k: v.replace("p", ".") if k in ("lo", "hi") else v
                     for k, v in m.groupdict().items()}
            if "surface" in parts:
                parts["surface"] = SURFACE_LABELS[parts["surface"]]
            return text.format(**parts)
    for suffix, unit in _UNIT_SUFFIXES.items():
        if key.endswith(suffix):
            return f"{key[: -len(suffix)].replace('_', ' ')} ({unit})"
    return f"{key.replace('_', ' ')} (\u2013)"


LABEL_CHARS = 120
"""Most characters of a name or id drawn into a figure title or axis label: a campaign's name
may be long (its file allows 200 characters, an in-memory one any), a figure's title may not.
Titles wrap (:func:`fit_titles`), so a real campaign's long name (a test id, the rig and the
well) stays whole over two lines; only a name past this is cut."""


def short_label(text: object, limit: int = LABEL_CHARS) -> str:
    """``text`` on one line and cut to ``limit`` characters (an ellipsis marks the cut)."""
    one = " ".join(str(text).split())
    return one if len(one) <= limit else one[: limit - 1] + "\u2026"
