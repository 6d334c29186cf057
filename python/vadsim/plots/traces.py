"""Time traces of one run: contact forces, indentations and bit acceleration.

The dissertation's Figs 4.2-4.6 (:func:`time_traces`), from a
:class:`vadsim.SimulationResult` that recorded its time series.
"""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from vadsim.plots.style import (
    SURFACE_COLORS,
    SURFACE_LABELS,
    check_path,
    finish,
    force_unit,
    m_ref,
    regime_label,
    run_length,
    styled,
)

if TYPE_CHECKING:
    from vadsim.model.result import SimulationResult

__all__ = ["time_traces"]

_SURFACE_INDEX = {"spring": 0, "impact": 1, "off_bottom": 2, "on_bottom": 3, "rock": 4}
_SYMBOLS = {"spring": "F_S", "impact": "F_I", "off_bottom": "F_Off", "on_bottom": "F_On"}


@styled
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
    out = check_path(path)
    if np.asarray(getattr(result, "t", np.empty(0))).size < 2:
        raise ValueError(f"{func}: the result holds no time series; run vadsim.simulate with "
                         "record='window' or record='all'")
    if not (isinstance(cycles, (int, float)) and math.isfinite(cycles) and cycles > 0):
        raise ValueError(f"{func}: cycles = {cycles!r} must be a positive number")
    factor, unit_label = force_unit(m_ref(result.m_ref_kg), unit, func)
    w = _last_cycles(result, cycles, factor)
    t, forces = w["t"], w["forces"]

    fig = Figure(figsize=(9.0, 8.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    ax_f, ax_d, ax_a = axes
    drawn = ["spring", "impact"] + [s for s in ("off_bottom", "on_bottom")
                                    if np.any(forces[:, _SURFACE_INDEX[s]] != 0)]
    for s in drawn:
        ax_f.plot(t, forces[:, _SURFACE_INDEX[s]], color=SURFACE_COLORS[s], lw=1.2,
                  label=f"${_SYMBOLS[s].replace('_', '_{')}}}$ {SURFACE_LABELS[s]}")
    ax_f.set_ylabel(f"contact force ({unit_label})")
    ax_d.plot(t, 1e3 * w["d_spring"], color=SURFACE_COLORS["spring"], lw=1.2,
              label=f"$d_S$ {SURFACE_LABELS['spring']}")
    ax_d.plot(t, 1e3 * w["d_impact"], color=SURFACE_COLORS["impact"], lw=1.2,
              label=f"$d_I$ {SURFACE_LABELS['impact']}")
    ax_d.axhline(0.0, color="0.4", lw=0.8, ls="--", label="contact when d > 0")
    ax_d.set_ylabel("indentation d (mm)")
    ax_a.plot(t, w["accel"], color="#0072B2", lw=1.0, label="$a_1$ bit sub (x1)")
    ax_a.set_ylabel("x1 acceleration (g)")
    ax_a.set_xlabel("time (s)")
    ax_a.set_xlim(t[0], t[-1])
    _mark_onsets(list(axes), result.events, t, drawn)
    for a in axes:
        a.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(_title(result, (t[-1] - t[0]) * float(result.f_exc_hz)))
    return finish(fig, out)


def _last_cycles(result: SimulationResult, cycles: float, factor: float) -> dict[str, np.ndarray]:
    """Time, contact forces (times ``factor``), indentations (m) of the spring and impact face
    (MODEL.md) and x1 acceleration (g) over the last ``cycles`` cycles of the recording."""
    t_all = np.asarray(result.t, float)
    t_start = max(float(t_all[0]), float(t_all[-1]) - cycles / float(result.f_exc_hz))
    sel = t_all >= t_start - 1e-12
    x = np.asarray(result.x, float)[sel]
    p = result.params
    l0 = float(p["l0"])
    return {
        "t": t_all[sel],
        "forces": np.asarray(result.contact_forces, float)[sel] * factor,
        "accel": np.asarray(result.a, float)[sel, 0] / 9.80665,
        "d_spring": (x[:, 2] + p["LS"] * l0) - (x[:, 1] - p["L2"] * l0),
        "d_impact": x[:, 1] - x[:, 0],
    }


def _mark_onsets(axes: list[Axes], events: pd.DataFrame | None, t: np.ndarray,
                 drawn: list[str]) -> None:
    """A dotted vertical line per contact onset of a drawn surface, in every panel; the
    legend entry (one per surface) goes to the last panel."""
    if events is None or not len(events):
        return
    onsets = events[(events["kind"] == "onset") & (events["time_s"] >= t[0])
                    & (events["time_s"] <= t[-1])]
    for s in drawn:
        times = onsets.loc[onsets["surface"] == s, "time_s"].to_numpy(float)
        for i, te in enumerate(times):
            for a in axes:
                a.axvline(te, color=SURFACE_COLORS[s], lw=0.9, ls=":", alpha=0.9, zorder=1,
                          label=f"{SURFACE_LABELS[s]} onset" if (a is axes[-1] and i == 0)
                          else None)


def _title(result: SimulationResult, shown: float) -> str:
    try:
        regime = f", scenario {regime_label(int(result.scenario))}"
    except (ValueError, KeyError, AttributeError, ZeroDivisionError):
        regime = ""
    run = run_length(getattr(result, "cycles", None), getattr(result, "analyse_cycles", None))
    return (f"{result.preset or 'custom model'}: Q = {result.flow_gpm:g} gal/min "
            f"({result.f_exc_hz:.1f} Hz), last {shown:.3g} cycles{regime}"
            + (f"\nrun of {run}" if run else ""))
