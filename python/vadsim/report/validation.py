"""The validation report: findings, a summary per feature, peaks vs flow, the mismatch heat
map and one table per event (Markdown or HTML, with its figures).

This module gathers what the report says (tables as DataFrames, figures as files); the text
and the layout are the template ``templates/validation.j2``, rendered by
:func:`vadsim.report.rendering.render`.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vadsim import plots
from vadsim._version import __version__ as _version
from vadsim.fit.validate import ValidationResult
from vadsim.report.rendering import check_format, render, write

__all__ = ["findings", "write_validation_report"]

_DPI = 110


def findings(result: ValidationResult, threshold: float = 1.0) -> list[str]:
    """Plain-language statements of where the model matches and where it does not: for each
    compared feature (through the sensor chain and at full resolution), the mean
    standardised residual over the lower and the upper half of the campaign's flows."""
    flows = pd.Series({ev.id: ev.flow_gpm for ev in result.campaign.events})
    median = float(flows.median())
    low = flows.index[flows <= median]
    high = flows.index[flows > median]
    out = []
    for label, res in (("through the sensor chain", result.residuals),
                       ("at full resolution", result.residuals_full)):
        for key in res.columns:
            col = res[key].dropna()
            if col.empty:
                continue
            parts = []
            for name, ids in ((f"flows <= {median:g} gal/min", low),
                              (f"flows > {median:g} gal/min", high)):
                z = col.reindex(ids).dropna()
                if z.empty:
                    continue
                m = float(z.mean())
                verdict = ("over-predicts" if m > threshold else
                           "under-predicts" if m < -threshold else "matches")
                parts.append(f"{verdict} at {name} (mean z {m:+.1f}, {len(z)} events)")
            if parts:
                out.append(f"{key} {label}: the model " + "; ".join(parts) + ".")
    missing = result.not_compared()
    for key, group in missing.groupby("feature", sort=False):
        out.append(f"{key} could not be compared at {len(group)} event(s): "
                   f"{group['reason'].iloc[0]}.")
    return out


def write_validation_report(result: ValidationResult, folder: str | os.PathLike[str],
                            fmt: str = "md", command: str | None = None) -> Path:
    """Write ``report.md`` (or ``report.html``) with its figures into ``folder``.

    The report has: what was compared and how; a per-feature summary of the standardised
    residuals; the peaks-vs-flow figure (recorded, model through the sensor chain, model at
    full resolution); the mismatch heat map; one table per event. ``events.csv`` holds one
    row per event.
    """
    check_format(fmt)
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    camp = result.campaign
    text = render(
        "validation.j2", fmt, title=camp.name, camp=camp, preset=result.preset.name,
        overrides=json.dumps(result.overrides) if result.overrides else "none",
        settings=result.settings, version=_version, command=command,
        timestamp=_dt.datetime.now().isoformat(timespec="seconds"),
        findings=findings(result), summary=_summary(result), events=_event_sections(result),
        **_figures(result, out),
    )
    (out / "events.csv").write_text(result.events_table().to_csv())
    return write(out, "report", fmt, text)


def _figures(result: ValidationResult, out: Path) -> dict[str, str | None]:
    """Save the peaks-vs-flow figure and (if any feature was compared) the heat map."""
    plots.validation_peaks(result).savefig(out / "peaks_vs_flow.png", dpi=_DPI)
    heat = plots.validation_mismatch(result)
    if heat is not None:
        heat.savefig(out / "mismatch_heatmap.png", dpi=_DPI)
    return {"peaks": "peaks_vs_flow.png",
            "heat": "mismatch_heatmap.png" if heat is not None else None}


def _summary(result: ValidationResult) -> pd.DataFrame:
    """Per feature: mean and RMS of the standardised residuals, events beyond 2 spreads."""
    res = result.residuals.dropna(axis=1, how="all")
    res_full = result.residuals_full.dropna(axis=1, how="all")
    summary = pd.DataFrame({
        "mean z (sensor chain)": res.mean(),
        "RMS z (sensor chain)": np.sqrt((res ** 2).mean()),
        "events |z|>2": (res.abs() > 2).sum(),
        "mean z (full resolution)": res_full.reindex(columns=res.columns).mean(),
    })
    summary.index.name = "feature"
    return summary


def _event_sections(result: ValidationResult) -> list[dict[str, Any]]:
    """Heading and feature table (None if no feature) of each event."""
    sections = []
    for ev in result.campaign.events:
        sim = result.simulations[ev.id]
        rows = [{"feature": key, "recorded": f.value, "spread": f.spread,
                 "model (sensor chain)": s.value if (s := sim.sensor.get(key)) else math.nan,
                 "model (full resolution)": fu.value if (fu := sim.full.get(key)) else math.nan,
                 "z": result.residuals.loc[ev.id].get(key, math.nan)}
                for key, f in result.recorded[ev.id].items()]
        sections.append({
            "heading": f"{ev.id}: {ev.flow_gpm:g} gal/min ({sim.f_exc_hz:.1f} Hz), "
                       f"{ev.wob_klbf:g} klbf; model scenario {sim.scenario}, "
                       f"Z spring {sim.z['spring']:.2f}, Z impact {sim.z['impact']:.2f}",
            "table": pd.DataFrame(rows).set_index("feature") if rows else None,
        })
    return sections
