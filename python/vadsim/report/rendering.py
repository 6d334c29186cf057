"""The one place where reports become Markdown or HTML: Jinja2 templates, pandas tables.

Why this module exists: the validation report, the diagnosis and the blind benchmark's score
sheet are each one template under ``templates/`` (package data, shipped in the wheel), written
once for both formats. A template imports the building blocks of its format
(``blocks.md.j2`` or ``blocks.html.j2``: headings, paragraphs, lists, tables, figures, inline
code) and calls them; tables are pandas DataFrames rendered by ``DataFrame.to_markdown`` or
``DataFrame.to_html``. HTML is escaped by Jinja2's autoescaping and wrapped in
``page.html.j2``.
"""

from __future__ import annotations

import functools
import math
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from jinja2 import Environment, PackageLoader, StrictUndefined
from markupsafe import Markup

__all__ = ["FORMATS", "TABLE_DIGITS", "check_format", "fmt_value", "render", "write"]

FORMATS: tuple[str, ...] = ("md", "html")
"""The formats of a report: Markdown and HTML."""

_SUFFIX = {"md": ".md", "html": ".html"}


def check_format(fmt: str) -> str:
    """``fmt`` if it is one of :data:`FORMATS`, else ValueError."""
    if fmt not in FORMATS:
        raise ValueError(f"fmt = {fmt!r} must be 'md' or 'html'")
    return fmt


TABLE_DIGITS = 3
"""Significant digits of a number in a report's table (a parameter value in text has 4)."""


def fmt_value(v: Any, digits: int = 4) -> str:
    """A number for text: floats with ``digits`` significant digits (NaN empty), anything
    else as text. The one formatter of reports and summaries; tables use
    :data:`TABLE_DIGITS`."""
    if isinstance(v, (float, np.floating)):
        return "" if math.isnan(v) else f"{float(v):.{digits}g}"
    return str(v)


def _cells(df: pd.DataFrame) -> pd.DataFrame:
    """The table as text cells, its index (if named or meaningful) as the first column."""
    named = df.index.name is not None or not isinstance(df.index, pd.RangeIndex)
    flat = df.reset_index() if named else df
    if named and df.index.name is None:
        flat = flat.rename(columns={"index": ""})
    return flat.map(lambda v: fmt_value(v, TABLE_DIGITS))


_NUMBER = re.compile(r"^([-+]?(\d+\.?\d*|\.\d+)(e[-+]?\d+)?( %)?|nan|)$")


def _markdown_table(df: pd.DataFrame) -> str:
    """A pipe table; columns of numbers (or percentages) right-aligned, the rest left."""
    cells = _cells(df)
    align = ["right" if cells[c].str.fullmatch(_NUMBER).all() else "left" for c in cells]
    # a "|" in a header or cell (e.g. "events |z|>2") would split the row: escape it
    cells = cells.map(lambda v: v.replace("|", "\\|"))
    cells.columns = [str(c).replace("|", "\\|") for c in cells.columns]
    return cells.to_markdown(index=False, disable_numparse=True, colalign=align)


def _html_table(df: pd.DataFrame) -> Markup:
    return Markup(_cells(df).to_html(index=False, border=0, escape=True))


def _num(value: Any, spec: str = "g") -> str:
    """``{{ x|num(".3f") }}``: ``format(x, spec)``."""
    return format(value, spec)


def _oneline(text: str) -> str:
    """Collapse the line breaks of a template paragraph (keeps Markup safe)."""
    flat = re.sub(r"\s*\n\s*", " ", str(text).strip())
    return Markup(flat) if isinstance(text, Markup) else flat


@functools.cache
def _environment(fmt: str) -> Environment:
    env = Environment(
        loader=PackageLoader("vadsim.report", "templates"),
        autoescape=fmt == "html",
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        undefined=StrictUndefined,
    )
    env.filters.update(num=_num, oneline=_oneline,
                       table=_html_table if fmt == "html" else _markdown_table)
    return env


def render(template: str, fmt: str, title: str, **context: Any) -> str:
    """Render ``templates/<template>`` as Markdown or a whole HTML page titled ``title``.

    The template sees ``context`` and ``fmt``; Markdown comes out with single blank lines
    between blocks and one final newline.
    """
    env = _environment(check_format(fmt))
    body = env.get_template(template).render(fmt=fmt, **context)
    if fmt == "md":
        lines = [line.rstrip() for line in body.splitlines()]
        return re.sub(r"\n{3,}", "\n\n", "\n".join(lines)).strip("\n") + "\n"
    return env.get_template("page.html.j2").render(title=title, body=Markup(body))


def write(folder: str | os.PathLike[str], stem: str, fmt: str, text: str) -> Path:
    """Write ``text`` to ``folder/<stem>.md`` (or ``.html``) and return the path."""
    path = Path(folder) / f"{stem}{_SUFFIX[check_format(fmt)]}"
    path.write_text(text)
    return path
