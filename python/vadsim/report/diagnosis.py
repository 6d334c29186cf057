"""The diagnosis report: where the model and the recordings disagree, the ranking of
candidate physics on held-out events, the verdict, a prediction of another campaign, figures
and ``diagnosis.json``.

This module gathers what the report says (tables as DataFrames, figures as files); the text
and the layout are the template ``templates/diagnosis.j2``, rendered by
:func:`vadsim.report.render.render`.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import pandas as pd

from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnose import Diagnosis, fmt_value
from vadsim.plots.campaigns import heldout_features, mismatch_base
from vadsim.report.render import check_format, render, write

__all__ = ["write_diagnosis_report"]


def write_diagnosis_report(diag: Diagnosis, folder: str | os.PathLike[str],
                           fmt: str = "md") -> Path:
    """Write ``diagnosis.md`` (or ``.html``), ``diagnosis.json`` and figures into ``folder``."""
    check_format(fmt)
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    figures = mismatch_base(diag, out) + heldout_features(diag, out)
    (out / "diagnosis.json").write_text(json.dumps(diag.as_json(), indent=2))
    text = render(
        "diagnosis.j2", fmt, title=f"Diagnosis of {diag.campaign.name}", diag=diag,
        overrides=diag.settings["overrides"] or "",
        located_events=[{**le, "worst": ", ".join(f"{k} {v:+.1f}" for k, v in le["worst"].items())}
                        for le in diag.located_events],
        ranking=_ranking(diag), verdict=_verdict(diag), prediction=_prediction(diag),
        figures=figures,
    )
    return write(out, "diagnosis", fmt, text)


def _parameters(values: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {fmt_value(v)}" for k, v in values.items())


def _ranking(diag: Diagnosis) -> pd.DataFrame:
    """The base model and every candidate: parameters, held-out RMS, score."""
    base = diag.baseline
    rows = [{"candidate": f.key, "k": str(f.k), "parameters": _parameters(f.parameters) or "-",
             "held-out RMS (LOFO / block)": f"{f.heldout_rms:.3f} ({f.heldout_rms_lofo:.3f} / "
                                            f"{f.heldout_rms_block:.3f})",
             "score": f"{f.score:.1f}", "delta vs none": f"{f.score - base.score:+.1f}"}
            for f in [base, *diag.ranking]]
    return pd.DataFrame(rows).set_index("candidate")


def _verdict(diag: Diagnosis) -> dict[str, Any] | None:
    """The chosen candidate's parameters with their intervals, None if none was chosen."""
    c = diag.chosen
    if c is None:
        return None
    cand = CANDIDATES[c.key]
    params = []
    for p in cand.params:
        lo, hi = c.interval.get(p.name, (math.nan, math.nan))
        params.append(f"{p.name} = {fmt_value(c.values[p.name])} {p.unit} "
                      f"(95 % profile interval {fmt_value(lo)} to {fmt_value(hi)})")
    params += [f"{k} = {v}" for k, v in cand.fixed.items()]
    b = diag.baseline.heldout_rms
    return {"id": c.id, "signature": cand.signature, "params": params,
            "reduction": f"held-out RMS {b:.3f} -> {c.heldout_rms:.3f} "
                         f"({100 * (1 - c.heldout_rms / b):.0f} % lower)"}


def _prediction(diag: Diagnosis) -> dict[str, Any] | None:
    """The prediction of another campaign with its per-event table, None if there is none."""
    p = diag.prediction
    if not p:
        return None
    table = pd.DataFrame([
        {"event": e, "flow": f"{row['flow_gpm']:g}", "RMS base": f"{row['rms_before']:.2f}",
         "RMS with physics": f"{row.get('rms_after', row['rms_before']):.2f}"}
        for e, row in p["events"].items()
    ]).set_index("event")
    best = p.get("best_ranked")
    return {**p, "table": table,
            "best_ranked": {**best, "parameters": _parameters(best["parameters"])}
            if best else None}
