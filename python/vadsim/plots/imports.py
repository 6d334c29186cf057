"""The figure of an import: the downhole record, the surface log and the chosen stretches.

Why this module exists: whether an import cut the record in the right places is seen at a
glance and read only slowly from a table. :func:`import_figure` draws the record's vibration
envelope and the surface log's flow and WOB on the record's clock (the log shifted by the
clock offset), with each event's stretch shaded and named and each refused stretch hatched
and numbered as in the import's summary.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from vadsim.plots.style import check_path, finish, styled

if TYPE_CHECKING:
    from vadsim.campaigns.importing import ImportResult

__all__ = ["import_figure"]

#: Points per sensor the envelope is drawn with (a block's largest |a| each).
ENVELOPE_POINTS = 4000

_SENSOR_COLORS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")


def _envelope(result: ImportResult, ax: Axes) -> None:
    """Each sensor's largest |a| per block of samples, over every piece of the record."""
    total = max(1, result.record.n_samples)
    for k, name in enumerate(result.record.sensors):
        color = _SENSOR_COLORS[k % len(_SENSOR_COLORS)]
        for j, piece in enumerate(result.record.pieces):
            a = np.abs(piece.accel_g[name])
            block = max(1, int(np.ceil(total / ENVELOPE_POINTS)))
            n = a.size // block * block
            peaks = a[:n].reshape(-1, block).max(axis=1) if n else a
            t = piece.t0_s + (np.arange(peaks.size) * block + block / 2) / piece.rate_hz
            dof = result.record.sensors[name].dof
            ax.plot(t, peaks, lw=0.7, color=color,
                    label=f"{name} (dof {dof})" if j == 0 else None)
    ax.set_ylabel("largest |a| per block (g)")
    ax.legend(loc="upper left", fontsize=8)


def _shade(result: ImportResult, axes: list[Axes]) -> None:
    """Events green with their id; refused stretches grey, hatched, numbered r1, r2, ..."""
    offset = result.alignment.offset_s
    refused = 0
    for st in result.stretches:
        if st.accepted and st.kept_s is not None:
            for ax in axes:
                ax.axvspan(*st.kept_s, color="#009E73", alpha=0.18, lw=0)
            axes[0].annotate(st.event_id or "", (0.5 * (st.kept_s[0] + st.kept_s[1]), 1.0),
                             xycoords=("data", "axes fraction"), ha="center", va="bottom",
                             fontsize=8, color="#006d4f")
        else:
            refused += 1
            lo, hi = st.start_s - offset, st.end_s - offset
            for ax in axes:
                ax.axvspan(lo, max(hi, lo + 0.5), facecolor="none", edgecolor="0.6",
                           hatch="///", lw=0)
            axes[-1].annotate(f"r{refused}", (0.5 * (lo + hi), 0.0),
                              xycoords=("data", "axes fraction"), ha="center", va="bottom",
                              fontsize=7, color="0.35")


@styled
def import_figure(result: ImportResult,
                  path: str | os.PathLike[str] | None = None) -> Figure:
    """The record and the surface log on the record's clock, the chosen stretches shaded.

    Parameters
    ----------
    result
        What :func:`vadsim.campaigns.import_campaign` returned.
    path
        Save the figure there (``.png``, ``.pdf`` or ``.svg``).

    Returns
    -------
    matplotlib.figure.Figure
        Three panels sharing the time axis: the vibration envelope per sensor, the flow and
        the WOB; events shaded green and named, refused stretches hatched and numbered as in
        the summary's table.
    """
    out = check_path(path)
    fig = Figure(figsize=(11.0, 7.0), layout="constrained")
    axes = list(fig.subplots(3, 1, sharex=True))
    _envelope(result, axes[0])
    log, offset = result.surface, result.alignment.offset_s
    axes[1].plot(log.time_s - offset, log.flow_gpm, ".-", ms=2, lw=0.7, color="black")
    axes[1].set_ylabel("flow (gal/min)")
    axes[2].plot(log.time_s - offset, log.wob_klbf, ".-", ms=2, lw=0.7, color="#7b3294")
    axes[2].set_ylabel("WOB (klbf)")
    axes[2].set_xlabel(f"time on the downhole record's clock (s); surface log shifted by "
                       f"{-offset:+.2f} s")
    _shade(result, axes)
    lo = min(result.record.pieces[0].t0_s, float(log.time_s[0] - offset))
    hi = max(result.record.pieces[-1].t1_s, float(log.time_s[-1] - offset))
    axes[0].set_xlim(lo, hi)
    n_ref = sum(not s.accepted for s in result.stretches)
    fig.suptitle(f"Import of {result.campaign.name}: {len(result.campaign.events)} events "
                 f"(green), {n_ref} stretch{'es' if n_ref != 1 else ''} refused (hatched, "
                 f"r1... as in import.md)",
                 fontsize=10)
    return finish(fig, out)
