"""Small HTML tables for notebook reprs (``_repr_html_``): a title, rows of label and value,
and optionally a second table, so that a result shows what it holds instead of an address."""

from __future__ import annotations

import html
from collections.abc import Iterable, Sequence

_STYLE = ("border-collapse:collapse;font-size:90%;margin:0.2em 0",
          "text-align:left;padding:1px 8px;border-bottom:1px solid #ddd")


def key_value_table(title: str, rows: Iterable[tuple[str, object]]) -> str:
    """A two-column table under a bold title; values are escaped."""
    body = "".join(f'<tr><th style="{_STYLE[1]}">{html.escape(str(k))}</th>'
                   f'<td style="{_STYLE[1]}">{html.escape(str(v))}</td></tr>' for k, v in rows)
    return (f"<div><strong>{html.escape(title)}</strong>"
            f'<table style="{_STYLE[0]}">{body}</table></div>')


def grid_table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A table with a header row; cells are escaped."""
    head = "".join(f'<th style="{_STYLE[1]}">{html.escape(str(h))}</th>' for h in header)
    body = "".join("<tr>" + "".join(f'<td style="{_STYLE[1]}">{html.escape(str(c))}</td>'
                                    for c in row) + "</tr>" for row in rows)
    return f'<table style="{_STYLE[0]}"><tr>{head}</tr>{body}</table>'
