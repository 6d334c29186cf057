"""The blind benchmark's score sheet (``scores.md``)."""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ["blind_markdown"]


def blind_markdown(sc: dict[str, Any], settings: dict[str, Any]) -> str:
    lines = ["# Blind benchmark of `vadsim diagnose`", "",
             f"Settings: {json.dumps(settings)}", "",
             f"- identification rate: **{100 * sc['identification_rate']:.0f} %** of "
             f"{sc['effect_campaigns']} campaigns with a concealed effect",
             f"- false alarms: **{sc['false_alarms']} of {sc['null_campaigns']}** null campaigns",
             f"- held-out improvement when the right physics is found: median "
             f"{100 * sc['heldout_improvement_median']:.0f} %, smallest "
             f"{100 * sc['heldout_improvement_min']:.0f} %", "",
             "| candidate | identification |", "|---|---|"]
    lines += [f"| {k} | {100 * v:.0f} % |" for k, v in sc["identification_by_candidate"].items()]
    lines += ["", "| parameter | median relative error |", "|---|---|"]
    lines += [f"| {k} | {100 * v:.1f} % |" for k, v in sc["parameter_error_median"].items()]
    lines += ["", "| campaign | truth | found | parameters found | held-out RMS before -> after "
              "| events untouched (RMS z < 1) | largest event RMS z | time (s) |",
              "|---|---|---|---|---|---|---|---|"]
    for r in sc["campaigns"]:
        tp = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                       for k, v in r["truth_parameters"].items())
        fp = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                       for k, v in r["parameters"].items())
        c = r["concealment"] or {}
        mark = "" if r["correct"] else " **(wrong)**"
        lines.append(f"| {r['campaign']} | {r['truth']} {tp} | {r['found']}{mark} | {fp} | "
                     f"{r['heldout_before']:.2f} -> {r['heldout_after']:.2f} | "
                     f"{c.get('events_untouched', '-')}/{c.get('events', '-')} | "
                     f"{c.get('max_event_rms', math.nan):.1f} | {r['elapsed_s'] or 0:.0f} |")
    return "\n".join(lines) + "\n"
