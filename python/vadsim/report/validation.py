"""The validation report: findings, a summary per feature, peaks vs flow, the mismatch heat
map and one table per event (Markdown or HTML, with its figures)."""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from vadsim import plots
from vadsim._version import __version__ as _version
from vadsim.fit.validate import ValidationResult, findings
from vadsim.report import markdown_table, md_to_html

__all__ = ["write_validation_report"]


def write_validation_report(result: ValidationResult, folder: str | os.PathLike[str],
                 fmt: str = "md", command: str | None = None) -> Path:
    """Write ``report.md`` (or ``report.html``) with its figures into ``folder``.

    The report has: what was compared and how; a per-feature summary of the standardised
    residuals; the peaks-vs-flow figure (recorded, model through the sensor chain, model at
    full resolution); the mismatch heat map; one table per event.
    """
    if fmt not in ("md", "html"):
        raise ValueError(f"fmt = {fmt!r} must be 'md' or 'html'")

    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    fig = plots.validation_peaks(result)
    fig.savefig(out / "peaks_vs_flow.png", dpi=110)
    res = result.residuals.dropna(axis=1, how="all")
    res_full = result.residuals_full.dropna(axis=1, how="all")
    heat = None
    if not res.empty:
        heat = "mismatch_heatmap.png"
        table = pd.concat([res, res_full.add_suffix(" [full res.]")], axis=1)
        table.index = [f"{e} ({result.campaign.event(e).flow_gpm:g} gpm)" for e in table.index]
        plots.mismatch_heatmap(table, path=out / heat,
                               title=f"{result.campaign.name}: (model - recorded) / spread")
    summary = pd.DataFrame({
        "mean z (sensor chain)": res.mean(),
        "RMS z (sensor chain)": np.sqrt((res ** 2).mean()),
        "events |z|>2": (res.abs() > 2).sum(),
        "mean z (full resolution)": res_full.reindex(columns=res.columns).mean(),
    })
    summary.index.name = "feature"
    ev_table = result.events_table()
    camp = result.campaign
    lines = [
        f"# Validation report: {camp.name}",
        "",
        f"- tool {camp.tool}, bit {camp.bit}; preset `{result.preset.name}`; "
        f"overrides {json.dumps(result.overrides) if result.overrides else 'none'}",
        f"- {len(camp.events)} events; sensors: "
        + ", ".join(f"{n} (dof {s.dof}, {s.rate_hz:g} Hz, {s.range_g:g} g"
                    + (f", low-pass {s.lowpass_hz:g} Hz" if s.lowpass_hz else "") + ")"
                    for n, s in camp.sensors.items()),
        f"- runs of {result.settings['cycles']:g} cycles, last "
        f"{result.settings['analyse_cycles']:g} analysed; vadsim {_version}; "
        f"{_dt.datetime.now().isoformat(timespec='seconds')}",
    ]
    if command:
        lines.append(f"- command: `{command}`")
    lines += [
        "",
        "Simulated accelerations pass through each sensor's chain (low-pass, sampling at the "
        "sensor rate, clipping) before their features are computed, as the recordings', "
        "averaged over 8 sampling phases (a recording's phase is unknown). Residuals are "
        "standardised by the recording's own spread (window-to-window, or a default of 10 % "
        "for summary-only events) combined with the model's spread over sampling phases. The "
        "model's features at full resolution (the solver's 20x oversampled signal, as the "
        "dissertation compared) are shown too, standardised by the recording's spread.",
        "",
        "## Findings",
        "",
        *[f"- {line}" for line in findings(result)],
        "",
        "## Summary per feature",
        "",
        markdown_table(summary),
        "",
        "## Peaks vs flow",
        "",
        "![peaks vs flow](peaks_vs_flow.png)",
        "",
    ]
    if heat:
        lines += ["## Standardised mismatch (event x feature x sensor)", "",
                  f"![mismatch heat map]({heat})", ""]
    lines += ["## Events", ""]
    for ev in camp.events:
        sim = result.simulations[ev.id]
        rec = result.recorded[ev.id]
        rows = []
        for key, f in rec.items():
            s = sim.sensor.get(key)
            fu = sim.full.get(key)
            rows.append({"feature": key, "recorded": f.value, "spread": f.spread,
                         "model (sensor chain)": s.value if s else math.nan,
                         "model (full resolution)": fu.value if fu else math.nan,
                         "z": result.residuals.loc[ev.id].get(key, math.nan)})
        lines += [
            f"### {ev.id}: {ev.flow_gpm:g} gal/min ({sim.f_exc_hz:.1f} Hz), "
            f"{ev.wob_klbf:g} klbf; model scenario {sim.scenario}, "
            f"Z spring {sim.z['spring']:.2f}, Z impact {sim.z['impact']:.2f}",
            "",
            markdown_table(pd.DataFrame(rows).set_index("feature")) if rows else "(no features)",
            "",
        ]
    md = "\n".join(lines)
    (out / "events.csv").write_text(ev_table.to_csv())
    if fmt == "md":
        path = out / "report.md"
        path.write_text(md)
        return path
    path = out / "report.html"
    path.write_text(md_to_html(md, camp.name))
    return path
