"""The blind benchmark's score sheet (``scores.md``).

This module turns the scores into tables; the text and the layout are the template
``templates/blind.j2``, rendered by :func:`vadsim.report.render.render`.
"""

from __future__ import annotations

import json
import math
from typing import Any

import pandas as pd

from vadsim.report.render import render

__all__ = ["blind_markdown"]


def blind_markdown(sc: dict[str, Any], settings: dict[str, Any]) -> str:
    """The score sheet in Markdown: rates, then identification per candidate, median
    parameter errors and one row per campaign."""
    by_candidate = _percent(sc["identification_by_candidate"], "candidate", "identification",
                            ".0f")
    errors = _percent(sc["parameter_error_median"], "parameter", "median relative error", ".1f")
    return render("blind.j2", "md", title="Blind benchmark", sc=sc, settings=json.dumps(settings),
                  by_candidate=by_candidate, parameter_errors=errors,
                  campaigns=_campaigns(sc["campaigns"]))


def _percent(shares: dict[str, float], name: str, column: str, spec: str) -> pd.DataFrame:
    """A one-column table of shares as percentages, indexed by ``name``."""
    return pd.DataFrame({column: [f"{100 * v:{spec}} %" for v in shares.values()]},
                        index=pd.Index(list(shares), name=name))


def _values(values: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                     for k, v in values.items())


def _campaigns(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per campaign: truth, what was found, held-out gain, concealment, time."""
    out = []
    for r in rows:
        c = r["concealment"] or {}
        out.append({
            "campaign": r["campaign"],
            "truth": f"{r['truth']} {_values(r['truth_parameters'])}",
            "found": f"{r['found']}" + ("" if r["correct"] else " **(wrong)**"),
            "parameters found": _values(r["parameters"]),
            "held-out RMS before -> after": f"{r['heldout_before']:.2f} -> "
                                            f"{r['heldout_after']:.2f}",
            "events untouched (RMS z < 1)": f"{c.get('events_untouched', '-')}/"
                                            f"{c.get('events', '-')}",
            "largest event RMS z": f"{c.get('max_event_rms', math.nan):.1f}",
            "time (s)": f"{r['elapsed_s'] or 0:.0f}",
        })
    return pd.DataFrame(out).set_index("campaign")
