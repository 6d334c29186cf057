"""Figures of campaigns: recorded vs model peaks along flow, the held-out predictions of a
diagnosis and its base model's mismatch heat map."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from vadsim.signals.features import Feature

if TYPE_CHECKING:
    from vadsim.fit.diagnose import Diagnosis
    from vadsim.fit.validate import ValidationResult

__all__ = ["heldout_features", "mismatch_base", "validation_peaks"]


def validation_peaks(result: ValidationResult):
    from matplotlib.figure import Figure

    sensors = [s for s in result.campaign.sensors
               if any(f"{s}_peak_mean_g" in r for r in result.recorded.values())]
    sensors = sensors or list(result.campaign.sensors)[:1]
    fig = Figure(figsize=(6.5 * len(sensors), 4.6), layout="constrained")
    axes = fig.subplots(1, len(sensors), squeeze=False)[0]
    flows = np.array([ev.flow_gpm for ev in result.campaign.events])
    order = np.argsort(flows)
    for ax, s in zip(axes, sensors, strict=True):
        key = f"{s}_peak_mean_g"
        rec = np.array([result.recorded[ev.id].get(key, Feature(math.nan, math.nan, 0)).value
                        for ev in result.campaign.events])
        spread = np.array([result.recorded[ev.id].get(key, Feature(math.nan, math.nan, 0))
                           .spread for ev in result.campaign.events])
        sim = np.array([result.simulations[ev.id].sensor.get(key, Feature(math.nan, 0, 0))
                        .value for ev in result.campaign.events])
        full = np.array([result.simulations[ev.id].full.get(key, Feature(math.nan, 0, 0))
                         .value for ev in result.campaign.events])
        ax.errorbar(flows[order], rec[order], yerr=spread[order], fmt="s", color="black",
                    capsize=3, label="recorded (spread)")
        ax.plot(flows[order], sim[order], "o-", color="#0072B2",
                label="model through the sensor chain")
        ax.plot(flows[order], full[order], "^--", color="#D55E00",
                label="model at full resolution")
        ax.set_xlabel("flow rate (gal/min)")
        ax.set_ylabel(f"{s} mean of 200 ms peaks (g)")
        ax.set_title(f"{s}: recorded vs model")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{result.campaign.name}\naxial vibration peaks vs flow, preset "
                 f"{result.preset.name}", fontsize=10)
    return fig


def heldout_features(diag: Diagnosis, folder: Path, n_features: int = 6) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    eids = [e.id for e in diag.campaign.events]
    flows = np.array([e.flow_gpm for e in diag.campaign.events])
    order = np.argsort(flows)
    # features with the largest held-out error of the base model
    err: dict[str, float] = {}
    for e in eids:
        for k, z in diag.baseline.heldout.get(e, {}).items():
            err[k] = err.get(k, 0.0) + z * z
    top = sorted(err, key=lambda k: -err[k])[:n_features]
    if not top:
        return []
    ncol = min(3, len(top))
    nrow = math.ceil(len(top) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
    after = diag.chosen
    for ax, key in zip(axes.flat, top, strict=False):
        rec = np.array([diag.recorded[e].get(key, Feature(math.nan, math.nan, 0)).value
                        for e in eids])
        spr = np.array([diag.recorded[e].get(key, Feature(math.nan, math.nan, 0)).spread
                        for e in eids])
        before = np.array([diag.baseline.heldout_sim.get(e, {}).get(key, math.nan)
                           for e in eids])
        ax.errorbar(flows[order], rec[order], yerr=spr[order], fmt="s", color="black",
                    capsize=3, label="recorded")
        ax.plot(flows[order], before[order], "o--", color="tab:red", label="base model")
        if after is not None:
            aft = np.array([after.heldout_sim.get(e, {}).get(key, math.nan) for e in eids])
            ax.plot(flows[order], aft[order], "^-", color="tab:blue",
                    label=f"+ {after.key} (held out)")
        ax.set_title(key, fontsize=9)
        ax.set_xlabel("flow (gal/min)")
    for ax in list(axes.flat)[len(top):]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("Held-out predictions (leave one flow out), features with the largest "
                 "base-model error", fontsize=10)
    fig.tight_layout()
    path = folder / "heldout_features.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path.name]


def mismatch_base(diag: Diagnosis, folder: Path) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vadsim.plots import mismatch_heatmap

    eids = [e.id for e in diag.campaign.events]
    table = pd.DataFrame({e: diag.baseline.heldout.get(e, {}) for e in eids}).T.reindex(eids)
    table.index = [f"{e} ({diag.campaign.events[i].flow_gpm:g})" for i, e in enumerate(eids)]
    fig = mismatch_heatmap(table, title="Base model: (model - recorded) / spread")
    path = folder / "mismatch_base.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path.name]
