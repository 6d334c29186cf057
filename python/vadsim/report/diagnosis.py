"""The diagnosis report: where the model and the recordings disagree, the ranking of
candidate physics on held-out events, the verdict, a prediction of another campaign, figures
and ``diagnosis.json``.

This module gathers what the report says (tables as DataFrames, figures as files); the text
and the layout are the template ``templates/diagnosis.j2``, rendered by
:func:`vadsim.report.rendering.render`.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import pandas as pd

from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis import Diagnosis
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.plots.campaigns import heldout_features, mismatch_base
from vadsim.report.rendering import check_format, fmt_value, render, write
from vadsim.report.text import verdict_text

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
        steps=_ranking(diag), nuisance=_nuisance(diag), verdict=_verdict(diag),
        prediction=_prediction(diag),
        figures=figures,
    )
    return write(out, "diagnosis", fmt, text)


def _parameters(values: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {fmt_value(v)}" for k, v in values.items())


def _ranking(diag: Diagnosis) -> list[dict[str, Any]]:
    """One table per forward-selection step: each hypothesis' fitted values, held-out RMS and
    score against the model it extends."""
    tables = []
    current = diag.none_fit
    for i, step in enumerate(diag.steps):
        rows = [{"hypothesis": f.key, "k": str(f.k), "values": _parameters(f.values) or "-",
                 "held-out RMS (LOFO / block)": ("probe only " if f.probe else "")
                 + f"{f.heldout_rms:.3f} ({f.heldout_rms_lofo:.3f} / "
                   f"{f.heldout_rms_block:.3f})",
                 # a probe's score is over a subset of events: not comparable
                 "score": "-" if f.probe else f"{f.score:.1f}",
                 "delta": "-" if f.probe else f"{f.score - current.score:+.1f}"}
                for f in ([current] + step if i == 0 else step)]
        tables.append({"step": i + 1, "extends": current.key,
                       "table": pd.DataFrame(rows).set_index("hypothesis")})
        chosen = diag.chosen
        if chosen is None or len(chosen.keys) <= i:
            break
        current = next((f for f in step if f.keys == chosen.keys[:i + 1]), current)
    return tables


def _nuisance(diag: Diagnosis) -> pd.DataFrame | None:
    """The nuisance constants of the calibrated base model and of the final model."""
    base, final = diag.baseline, diag.final
    if not base.nuisance:
        return None
    _, base_iv = base.intervals_by_id()
    _, final_iv = final.intervals_by_id()
    rows = []
    for spec in base.nuisance_specs:
        name = spec.name
        rows.append({"constant": name, "nominal": fmt_value(spec.null),
                     "range": f"{fmt_value(spec.lo)} to {fmt_value(spec.hi)} {spec.unit}",
                     "none (calibrated)": f"{fmt_value(base.nuisance[name])} "
                                          f"{_iv(base_iv.get(name))}{_edge(base, name)}",
                     "final model": (f"{fmt_value(final.nuisance[name])} "
                                     f"{_iv(final_iv.get(name))}{_edge(final, name)}"
                                     if name in final.nuisance
                                     else f"{fmt_value(spec.null)} (nominal)")})
    return pd.DataFrame(rows).set_index("constant")


def _edge(fit: HypothesisFit, param: str, of: str = "nuisance") -> str:
    """`` (at the lower bound)`` where ``fit`` left ``param`` at an end of its range."""
    return "".join(f" (at the {e['bound']} bound)" for e in fit.at_bounds
                   if e["of"] == of and e["param"] == param)


def _iv(iv: tuple[float, float] | None) -> str:
    return f"[{fmt_value(iv[0])}, {fmt_value(iv[1])}]" if iv else ""


def _verdict(diag: Diagnosis) -> dict[str, Any]:
    """The verdict sentence and, per chosen candidate, its parameters with intervals."""
    c = diag.chosen
    effects = []
    if c is not None:
        cand_iv, _ = c.intervals_by_id()
        for key, vals in c.hypothesis.split(c.point)[0].items():
            cand = CANDIDATES[key]
            ivs = cand_iv.get(cand.id, {})
            params = [f"{p.name} = {fmt_value(vals[p.name])} {p.unit} (95 % interval "
                      f"{fmt_value(ivs.get(p.name, (math.nan,))[0])} to "
                      f"{fmt_value(ivs.get(p.name, (math.nan, math.nan))[1])})"
                      f"{_edge(c, p.name, cand.id)}"
                      for p in cand.params]
            params += [f"{k} = {v}" for k, v in cand.fixed.items()]
            effects.append({"id": cand.id, "key": key, "signature": cand.signature,
                            "params": params})
    b = diag.none_fit.heldout_rms
    f = diag.final.heldout_rms
    return {"kind": diag.verdict, "text": verdict_text(diag), "effects": effects,
            "unexplained": [{**u, "worst": ", ".join(f"{k} {v:+.1f}"
                                                     for k, v in u["worst"].items())}
                            for u in diag.unexplained],
            "reduction": f"held-out RMS {b:.3f} -> {f:.3f} ({100 * (1 - f / b):.0f} % lower)"}


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
