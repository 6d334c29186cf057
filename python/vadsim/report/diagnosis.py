"""The diagnosis report: where the model and the recordings disagree, the ranking of
candidate physics on held-out events, the verdict, a prediction of another campaign, figures
and ``diagnosis.json``."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnose import Diagnosis, fmt_value
from vadsim.plots.campaigns import heldout_features, mismatch_base
from vadsim.report import md_to_html

__all__ = ["write_diagnosis_report"]


def write_diagnosis_report(diag: Diagnosis, folder: str | os.PathLike[str],
                           fmt: str = "md") -> Path:
    """Write ``diagnosis.md`` (or ``.html``), ``diagnosis.json`` and figures into ``folder``."""
    if fmt not in ("md", "html"):
        raise ValueError(f"fmt = {fmt!r} must be 'md' or 'html'")
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    figs = mismatch_base(diag, out) + heldout_features(diag, out)
    js = diag.as_json()
    (out / "diagnosis.json").write_text(json.dumps(js, indent=2))
    b = diag.baseline
    lines = [f"# Diagnosis of {diag.campaign.name}", "",
             f"Base model: preset `{diag.preset.name}`"
             + (f" with {diag.settings['overrides']}" if diag.settings["overrides"] else "")
             + f"; {len(diag.campaign.events)} events; {diag.n_evals} evaluations in "
             f"{diag.elapsed_s:.0f} s.", "",
             "## Where the model and the recordings disagree", ""]
    if diag.located:
        lines += [f"- {m.describe()}" for m in diag.located]
    else:
        lines.append("- No feature is offset or trends with flow beyond the threshold "
                     "(95 % intervals and a minimum effect of 1.5 spreads).")
    for le in diag.located_events:
        worst = ", ".join(f"{k} {v:+.1f}" for k, v in le["worst"].items())
        lines.append(f"- Event {le['event']} ({le['flow_gpm']:g} gal/min): RMS z "
                     f"{le['rms_z']:.1f} ({worst})")
    lines += ["", "## Candidates, ranked on held-out events", "",
              "Held-out RMS: standardised residuals of events left out of the fit "
              "(leave-one-flow-out and a high-flow block), pooled. Score: AICc on those "
              "held-out residuals (lower is better). Thresholds: score "
              f"{diag.settings['min_delta']:g} below `none` and held-out RMS "
              f"{100 * diag.settings['min_reduction']:.0f} % "
              "below `none`.", "",
              "| candidate | k | parameters | held-out RMS (LOFO / block) | score "
              "| delta vs none |",
              "|---|---|---|---|---|---|"]
    for f in [b, *diag.ranking]:
        par = ", ".join(f"{k} = {fmt_value(v)}" for k, v in f.parameters.items()) or "-"
        lines.append(f"| {f.key} | {f.k} | {par} | {f.heldout_rms:.3f} "
                     f"({f.heldout_rms_lofo:.3f} / {f.heldout_rms_block:.3f}) | "
                     f"{f.score:.1f} | {f.score - b.score:+.1f} |")
    lines += ["", "## Verdict", ""]
    if diag.chosen is None:
        lines.append("**Missing physics: none.** No candidate improves the held-out "
                     "prediction enough to be worth its parameters.")
    else:
        c = diag.chosen
        cand = CANDIDATES[c.key]
        lines.append(f"**Missing physics: `{c.id}`** — {cand.signature}")
        lines.append("")
        for p in cand.params:
            lo, hi = c.interval.get(p.name, (math.nan, math.nan))
            lines.append(f"- {p.name} = {fmt_value(c.values[p.name])} {p.unit} "
                         f"(95 % profile interval {fmt_value(lo)} to {fmt_value(hi)})")
        for k, v in cand.fixed.items():
            lines.append(f"- {k} = {v}")
        lines.append(f"- held-out RMS {b.heldout_rms:.3f} -> {c.heldout_rms:.3f} "
                     f"({100 * (1 - c.heldout_rms / b.heldout_rms):.0f} % lower)")
    if diag.prediction:
        p = diag.prediction
        lines += ["", f"## Prediction of {p['campaign']} (nothing refitted)", "",
                  f"RMS standardised residual: base {p['error_before']:.3f}, with "
                  f"`{p['physics']}` {p['error_after']:.3f}.", "",
                  "| event | flow | RMS base | RMS with physics |", "|---|---|---|---|"]
        for e, row in p["events"].items():
            lines.append(f"| {e} | {row['flow_gpm']:g} | {row['rms_before']:.2f} | "
                         f"{row.get('rms_after', row['rms_before']):.2f} |")
        if "best_ranked" in p:
            b = p["best_ranked"]
            par = ", ".join(f"{k} = {fmt_value(v)}" for k, v in b["parameters"].items())
            lines += ["", f"The best-ranked candidate, `{b['key']}` ({par}), was not chosen; "
                      f"it would predict with RMS {b['error']:.3f} (evidence, not a verdict)."]
    lines += ["", "## Figures", ""] + [f"![{f}]({f})" for f in figs]
    lines += ["", "Machine-readable: `diagnosis.json`."]
    md = "\n".join(lines) + "\n"
    if fmt == "md":
        path = out / "diagnosis.md"
        path.write_text(md)
        return path
    path = out / "diagnosis.html"
    path.write_text(md_to_html(md, f"Diagnosis of {diag.campaign.name}"))
    return path
