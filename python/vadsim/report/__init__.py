"""Reports: Markdown and HTML documents of validations, diagnoses and the blind benchmark.

Why this package exists: every report is a table, some findings and some figures, rendered
to Markdown or HTML; the rendering lives here, once, and the analysis modules only compute.
"""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

__all__ = ["fmt_value", "markdown_table", "md_to_html"]


def fmt_value(v: Any) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.3g}"
    return str(v)


def markdown_table(df: pd.DataFrame) -> str:
    cols = [df.index.name or ""] + [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for idx, row in df.iterrows():
        lines.append("| " + " | ".join([str(idx)] + [fmt_value(v) for v in row.to_numpy()]) + " |")
    return "\n".join(lines)


def md_to_html(md: str, title: str) -> str:
    """A small Markdown-to-HTML rendering of the report (headings, lists, tables, images)."""
    import html

    out = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
           "</title><style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
           "table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ccc;"
           "padding:2px 6px;text-align:right}img{max-width:100%}</style></head><body>"]
    table: list[str] = []

    def flush() -> None:
        if table:
            rows = [r.strip("|").split("|") for r in table if not set(r) <= set("|-")]
            out.append("<table>" + "".join(
                "<tr>" + "".join((f"<th>{html.escape(c.strip())}</th>" if i == 0 else
                                  f"<td>{html.escape(c.strip())}</td>") for c in r) + "</tr>"
                for i, r in enumerate(rows)) + "</table>")
            table.clear()

    for line in md.splitlines():
        if line.startswith("|"):
            table.append(line)
            continue
        flush()
        if line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            out.append(f"<h{level}>{html.escape(line.lstrip('#').strip())}</h{level}>")
        elif line.startswith("!["):
            src = line[line.index("(") + 1:line.rindex(")")]
            out.append(f"<img src='{html.escape(src)}'>")
        elif line.startswith("- "):
            out.append(f"<li>{html.escape(line[2:])}</li>")
        elif line.strip():
            out.append(f"<p>{html.escape(line)}</p>")
    flush()
    out.append("</body></html>")
    return "\n".join(out)
