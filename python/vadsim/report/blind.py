"""The blind benchmark's score sheet (``scores.md``).

This module turns the scores of :func:`vadsim.blind.score` into tables: the acceptance
criteria, a summary per class, identification per candidate, then one table per class with a
row per campaign. The text and the layout are the template ``templates/blind.j2``, rendered
by :func:`vadsim.report.rendering.render`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

import pandas as pd

from vadsim.report.rendering import render

__all__ = ["blind_markdown"]


def blind_markdown(sc: dict[str, Any], settings: dict[str, Any],
                   descriptions: Mapping[str, str] | None = None) -> str:
    """The score sheet in Markdown: PASS/FAIL per criterion, a summary per class, then a
    table per class. ``descriptions`` says what each class tests (a heading's text)."""
    descriptions = descriptions or {}
    by_class = [{"name": c, "what": descriptions.get(c, ""),
                 "table": _campaigns([r for r in sc["campaigns"] if r["class"] == c])}
                for c in sc["classes"]]
    by_candidate = _percent(sc["identification_by_candidate"], "candidate", "found", ".0f")
    return render("blind.j2", "md", title="Blind benchmark", sc=sc,
                  settings=json.dumps(settings), criteria=sc["criteria"],
                  summary=_summary(sc), by_candidate=by_candidate,
                  parameter_errors=_parameter_errors(sc), by_class=by_class)


def _percent(shares: dict[str, float], name: str, column: str, spec: str) -> pd.DataFrame:
    """A one-column table of shares as percentages, indexed by ``name``."""
    return pd.DataFrame({column: [f"{100 * v:{spec}} %" for v in shares.values()]},
                        index=pd.Index(list(shares), name=name))


def _pct(v: float | None, spec: str = ".0f") -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{100 * v:{spec}} %"


def _num(v: float | None, spec: str = ".3g") -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:{spec}}"


def _summary(sc: dict[str, Any]) -> pd.DataFrame:
    """One row per class and one for all: identification, variants, false alarms, held-out
    gain, median parameter error, nuisance recovery, interval coverage, regret, time."""
    rows = []
    for name, s in [*sc["classes"].items(), ("all", sc["overall"])]:
        perr = list(s["parameter_error_median"].values())
        rows.append({
            "class": name,
            "correct": f"{s['correct']}/{s['campaigns']}",
            "identification": _pct(s["identification_rate"]),
            "variant correct": _pct(s["variant_rate"]),
            "false alarms": (f"{s['false_alarms']}/{s['null_campaigns']}"
                             if s["null_campaigns"] else "-"),
            "held-out gain median / min": (f"{_pct(s['heldout_improvement_median'])} / "
                                           f"{_pct(s['heldout_improvement_min'])}"),
            "parameter error (median of medians)": _pct(
                float(pd.Series(perr).median()) if perr else None, ".1f"),
            "abs wob_scale error (median)": _num(s["wob_scale_error_median"], ".3f"),
            "truths in 95 % interval": (f"{s['intervals_covering']}/{s['intervals_scored']}"
                                        if s.get("intervals_scored") else "-"),
            "regret within noise": (f"{s['regret_scored'] - s['search_failures']}/"
                                    f"{s['regret_scored']}" if s.get("regret_scored") else "-"),
            "time (s)": f"{s['elapsed_s']:.0f}",
        })
    return pd.DataFrame(rows).set_index("class")


def _parameter_errors(sc: dict[str, Any]) -> pd.DataFrame:
    """Median relative error per class and ``id.param`` (found true effects only)."""
    rows = [{"class": c, "parameter": k, "median relative error": _pct(v, ".1f")}
            for c, s in sc["classes"].items() for k, v in s["parameter_error_median"].items()]
    return pd.DataFrame(rows).set_index(["class", "parameter"]) if rows else pd.DataFrame()


def _nuisance_text(r: dict[str, Any]) -> str:
    """The fitted nuisance constants, with the error where the truth is known."""
    err = {"wob_scale": r["wob_scale_error"], "theta0": r["theta0_error"]}
    return ", ".join(f"{k}={v:.3g}" + (f" (err {err[k]:.3f})" if err.get(k) is not None else "")
                     for k, v in r["nuisance"].items()) or "-"


def _values(values: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                     for k, v in values.items())


def _truth_text(r: dict[str, Any]) -> str:
    text = " + ".join(f"{k} ({_values(r['truth_values'].get(k.partition('[')[0], {}))})"
                      for k in r["truth_keys"]) or "none"
    if r["nuisance_truth"]:
        text += f" [nuisance {_values(r['nuisance_truth'])}]"
    return text


def _found_text(r: dict[str, Any]) -> str:
    names = r["found_keys"] if r["found_keys"] else r["found"]
    text = " + ".join(names or ["none"])
    if r["verdict"] == "unexplained":
        text += " (unexplained)"
    return text + ("" if r["correct"] else " **(wrong)**")


def _regret_text(r: dict[str, Any]) -> str:
    if r.get("regret") is None:
        return "n/a" if r.get("regret_na") else "-"
    flag = " **(search failure)**" if r["search_failure"] else ""
    return f"{r['regret']:.0f} ({r['regret_noise']:.0f}){flag}"


def _campaigns(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per campaign: truth, what was found, parameter errors, held-out RMS, time."""
    out = []
    for r in rows:
        variant = " (variant wrong)" if r["correct"] and r["variant_correct"] is False else ""
        out.append({
            "campaign": r["campaign"],
            "truth": _truth_text(r),
            "found": _found_text(r),
            "correct": ("yes" if r["correct"] else "no") + variant,
            "parameter errors": ", ".join(f"{k} {100 * v:.1f} %"
                                          for k, v in r["parameter_error"].items()) or "-",
            "nuisance found": _nuisance_text(r),
            "held-out RMS before -> after": f"{_num(r['heldout_before'], '.2f')} -> "
                                            f"{_num(r['heldout_after'], '.2f')}",
            "regret (noise)": _regret_text(r),
            "time (s)": f"{r['elapsed_s'] or 0:.0f}",
        })
    return pd.DataFrame(out).set_index("campaign")
