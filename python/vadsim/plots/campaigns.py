"""Figures of campaigns: the mismatch heat map, recorded against model peaks along flow, the
held-out predictions of a diagnosis and its base model's mismatch.

The heat maps and the diagnosis figures name features in words with their units
(:func:`~vadsim.plots.style.feature_label`), flows in gal/min, and give the campaign's weight
on bit and the length of the model runs in their titles. Functions named ``*_figure`` (and
:func:`validation_peaks`, :func:`validation_mismatch`) return a
:class:`~matplotlib.figure.Figure`; :func:`heldout_features` and :func:`mismatch_base` save
theirs into a report folder and return the file names.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib as mpl
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from vadsim.plots.style import (
    check_path,
    feature_label,
    finish,
    fit_titles,
    new_axes,
    run_length,
    short_label,
    styled,
    wob_text,
)
from vadsim.signals.features import Feature

if TYPE_CHECKING:
    from vadsim.campaigns.format import Campaign
    from vadsim.fit.diagnosis import Diagnosis
    from vadsim.fit.validate import ValidationResult

__all__ = [
    "heldout_features",
    "heldout_features_figure",
    "mismatch_base",
    "mismatch_base_figure",
    "mismatch_heatmap",
    "validation_mismatch",
    "validation_peaks",
]

_DPI = 110  # of the figures saved into report folders
_NO_FEATURE = Feature(math.nan, math.nan, 0)


@styled
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

    Why so many parameters: a heat map of residuals takes the table and the choices of one
    figure (order, limits, labels, file); each with a default.

    A diverging colour map centred at 0 (colour limits -vmax..vmax), each cell annotated with
    its value; missing values are grey and annotated "n/a". A table too wide for its numbers
    (cells under 0.45 in at the 16 in maximum width, ~30 columns) is drawn without them, its
    labels upright.

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
    out = check_path(path)
    values, vmax = _heat_values(table, vmax, func)
    nrow, ncol = values.shape
    width = min(16.0, max(4.5, 2.2 + 0.95 * ncol))
    # Past ~30 columns a cell is too narrow for its number or a slanted label (a diagnosis'
    # folded features: 80+ columns, numbers printed over each other): labels stand upright
    # in a smaller font and the cells are left to their colour.
    crowded = (width - 2.2) / ncol < 0.45
    longest = max(len(str(c)) for c in table.columns)
    label_room = 0.075 * longest if crowded else 0.04 * longest  # upright / at 30 degrees
    height = min(14.0, max(3.0, 1.6 + 0.42 * nrow) + label_room)
    fig, ax = new_axes(ax, (width, height))
    cm = mpl.colormaps[cmap].with_extremes(bad="#e6e6e6")
    norm = Normalize(vmin=-vmax, vmax=vmax)
    image = ax.imshow(np.ma.masked_invalid(values), cmap=cm, norm=norm, aspect="auto",
                      interpolation="nearest")
    cbar = fig.colorbar(image, ax=ax, pad=0.02)
    cbar.set_label(colorbar_label)
    ax.grid(False)
    if crowded:
        ax.set_xticks(np.arange(ncol), [str(c) for c in table.columns], rotation=90,
                      fontsize=7)
    else:
        ax.set_xticks(np.arange(ncol), [str(c) for c in table.columns], rotation=30,
                      ha="right", rotation_mode="anchor")
    ax.set_yticks(np.arange(nrow), [short_label(i, 40) for i in table.index])
    ax.set_xticks(np.arange(-0.5, ncol), minor=True)
    ax.set_yticks(np.arange(-0.5, nrow), minor=True)
    ax.grid(which="minor", color="white", linewidth=1.5)
    ax.tick_params(which="minor", length=0)
    ax.set_xlabel(str(table.columns.name) if table.columns.name else "feature")
    ax.set_ylabel(str(table.index.name) if table.index.name else "event")
    if annotate and not crowded:
        _annotate(ax, values, fmt, vmax)
    ax.set_title(title)
    return finish(fig, out)



def _heat_values(table: pd.DataFrame, vmax: float | None, func: str) -> tuple[np.ndarray, float]:
    """The table's values as floats and the colour limit, refusing what cannot be drawn."""
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
    return values, vmax


def _annotate(ax: Axes, values: np.ndarray, fmt: str, vmax: float) -> None:
    """Each cell's value (``"n/a"`` if missing), white on strong colours."""
    nrow, ncol = values.shape
    size = 8.5 if ncol * nrow <= 120 else 7
    for i in range(nrow):
        for k in range(ncol):
            v = values[i, k]
            if math.isfinite(v):
                text, color = fmt.format(v), ("white" if abs(v) > 0.6 * vmax else "0.1")
            else:
                text, color = "n/a", "0.45"
            ax.text(k, i, text, ha="center", va="center", fontsize=size, color=color)


def _conditions(campaign: Campaign, settings: dict[str, Any]) -> str:
    """``"WOB 20 klbf, runs of 400 cycles (last 200 analysed)"`` of a campaign and the settings
    of its model runs (what they do not carry is left out)."""
    wobs = ([campaign.wob_klbf] if campaign.wob_klbf is not None
            else [e.wob_klbf for e in campaign.events])
    runs = run_length(settings.get("cycles"), settings.get("analyse_cycles"))
    return ", ".join(p for p in (wob_text(wobs), f"runs of {runs}" if runs else "") if p)


def _event_labels(campaign: Campaign, ids: list[str]) -> list[str]:
    flows = {e.id: e.flow_gpm for e in campaign.events}
    return [f"{short_label(e, 24)} ({flows[e]:g} gal/min)" for e in ids]


def _recorded_label(key: str) -> str:
    if key.endswith("_peak_std_g"):
        return "recorded \u00b1 its sampling std"
    return "recorded: mean \u00b1 std over 200 ms windows"


@styled
def validation_peaks(result: ValidationResult) -> Figure:
    """Recorded and model mean of the 200 ms peaks against flow, one panel per sensor that
    records them: the recording (mean ± std over 200 ms windows), the model through the
    sensor chain and the model at full resolution."""
    sensors = [s for s in result.campaign.sensors
               if any(f"{s}_peak_mean_g" in r for r in result.recorded.values())]
    sensors = sensors or list(result.campaign.sensors)[:1]
    fig = Figure(figsize=(6.5 * len(sensors), 4.8), layout="constrained")
    axes = fig.subplots(1, len(sensors), squeeze=False)[0]
    events = result.campaign.events
    flows = np.array([ev.flow_gpm for ev in events])
    order = np.argsort(flows)
    for ax, s in zip(axes, sensors, strict=True):
        key = f"{s}_peak_mean_g"
        rec = [result.recorded[ev.id].get(key, _NO_FEATURE) for ev in events]
        sim = np.array([result.simulations[ev.id].sensor.get(key, _NO_FEATURE).value
                        for ev in events])
        full = np.array([result.simulations[ev.id].full.get(key, _NO_FEATURE).value
                         for ev in events])
        ax.errorbar(flows[order], np.array([f.value for f in rec])[order],
                    yerr=np.array([f.spread for f in rec])[order], fmt="s", color="black",
                    capsize=3, label=_recorded_label(key))
        ax.plot(flows[order], sim[order], "o-", color="#0072B2",
                label="model through the sensor chain")
        ax.plot(flows[order], full[order], "^--", color="#D55E00",
                label="model at full resolution")
        ax.set_xlabel("flow rate (gal/min)")
        ax.set_ylabel(feature_label(key))
        ax.set_title(f"{s}: recorded vs model")
        ax.legend(fontsize=8)
    fig.suptitle(f"{short_label(result.campaign.name)}\naxial vibration peaks vs flow, preset "
                 f"{result.preset.name}; {_conditions(result.campaign, result.settings)}",
                 fontsize=10)
    return fit_titles(fig)


def validation_mismatch(result: ValidationResult) -> Figure | None:
    """Heat map of a validation's standardised residuals, through the sensor chain and at full
    resolution, events (with their flow) as rows, features in words as columns; None if no
    feature was compared."""
    res = result.residuals.dropna(axis=1, how="all")
    if res.empty:
        return None
    full = result.residuals_full.dropna(axis=1, how="all")
    table = pd.concat([res.rename(columns=feature_label),
                       full.rename(columns=lambda k: f"{feature_label(k)} [full res.]")], axis=1)
    table.index = _event_labels(result.campaign, list(table.index))
    name = short_label(result.campaign.name)
    return mismatch_heatmap(table, title=f"{name}\n(model - recorded) / spread; "
                            f"{_conditions(result.campaign, result.settings)}")


def _largest_errors(diag: Diagnosis, n_features: int) -> list[str]:
    """Features with the largest held-out error of the base model, largest first."""
    err: dict[str, float] = {}
    for e in diag.campaign.events:
        for k, z in diag.none_fit.heldout.get(e.id, {}).items():
            err[k] = err.get(k, 0.0) + z * z
    return sorted(err, key=lambda k: -err[k])[:n_features]


@styled
def heldout_features_figure(diag: Diagnosis, n_features: int = 6) -> Figure | None:
    """The recorded features with the largest held-out error of the base model against flow,
    with the base model's and the chosen physics' held-out predictions; None if nothing was
    held out. One panel per feature, its y axis the feature in words with its unit."""
    top = _largest_errors(diag, n_features)
    if not top:
        return None
    eids = [e.id for e in diag.campaign.events]
    flows = np.array([e.flow_gpm for e in diag.campaign.events])
    order = np.argsort(flows)
    ncol = min(3, len(top))
    nrow = math.ceil(len(top) / ncol)
    fig = Figure(figsize=(4.4 * ncol, 3.4 * nrow + 0.6), layout="constrained")
    axes = list(fig.subplots(nrow, ncol, squeeze=False).flat)
    after = diag.chosen
    for ax, key in zip(axes, top, strict=False):
        rec = [diag.recorded[e].get(key, _NO_FEATURE) for e in eids]
        before = np.array([diag.none_fit.heldout_sim.get(e, {}).get(key, math.nan)
                           for e in eids])
        ax.errorbar(flows[order], np.array([f.value for f in rec])[order],
                    yerr=np.array([f.spread for f in rec])[order], fmt="s", color="black",
                    capsize=3, label=_recorded_label(key))
        ax.plot(flows[order], before[order], "o--", color="tab:red", label="base model")
        if after is not None:
            aft = np.array([after.heldout_sim.get(e, {}).get(key, math.nan) for e in eids])
            ax.plot(flows[order], aft[order], "^-", color="tab:blue",
                    label=f"+ {after.key} (held out)")
        ax.set_title(key, fontsize=9)
        ax.set_xlabel("flow rate (gal/min)")
        ax.set_ylabel(feature_label(key), fontsize=8.5)
    for ax in axes[len(top):]:
        ax.set_visible(False)
    axes[0].legend(fontsize=7)
    fig.suptitle("Held-out predictions (leave one flow out), features with the largest "
                 f"base-model error\n{short_label(diag.campaign.name)}: "
                 f"{_conditions(diag.campaign, diag.settings)}", fontsize=10)
    return fit_titles(fig)


def mismatch_base_figure(diag: Diagnosis) -> Figure:
    """Heat map of the base model's held-out standardised residuals, events (with their flow)
    as rows, features in words as columns."""
    eids = [e.id for e in diag.campaign.events]
    table = pd.DataFrame({e: diag.none_fit.heldout.get(e, {}) for e in eids}).T.reindex(eids)
    table = table.rename(columns=feature_label)
    table.index = _event_labels(diag.campaign, eids)
    name = short_label(diag.campaign.name)
    return mismatch_heatmap(table, title="Base model: (model - recorded) / spread\n"
                            f"{name}: {_conditions(diag.campaign, diag.settings)}")


def heldout_features(diag: Diagnosis, folder: Path, n_features: int = 6) -> list[str]:
    """Save :func:`heldout_features_figure` as ``heldout_features.png`` into ``folder``; the
    file names written (none if nothing was held out)."""
    fig = heldout_features_figure(diag, n_features)
    if fig is None:
        return []
    path = Path(folder) / "heldout_features.png"
    fig.savefig(path, dpi=_DPI)
    return [path.name]


def mismatch_base(diag: Diagnosis, folder: Path) -> list[str]:
    """Save :func:`mismatch_base_figure` as ``mismatch_base.png`` into ``folder``; the file
    names written."""
    path = Path(folder) / "mismatch_base.png"
    mismatch_base_figure(diag).savefig(path, dpi=_DPI)
    return [path.name]
