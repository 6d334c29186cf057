"""The dissertation's published numbers, shipped with the package: the one reader of them.

Why this module exists: every number the dissertation publishes lives in ``data/thesis/*.csv``
(Table 2.1, the field and simulated events, the regime boundaries of the 7in flow sweep, the
parametric study's ranges and results). Presets, the reproduction report, calibration targets
and figures all read them; they read them here, so a corrected table is corrected everywhere.
This module sits below every other layer: it imports nothing from vadsim.
"""

from __future__ import annotations

import csv
from importlib import resources
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pandas is imported on first use: presets need only the csv rows
    import pandas as pd

__all__ = ["field_events", "parametric_rows", "published_regimes", "table_2_1", "thesis_csv",
           "thesis_rows"]


def thesis_rows(name: str) -> list[dict[str, str]]:
    """Rows of ``data/thesis/<name>`` as dicts of strings (no pandas)."""
    text = resources.files("vadsim").joinpath(f"data/thesis/{name}").read_text()
    return list(csv.DictReader(text.splitlines()))


def thesis_csv(name: str) -> pd.DataFrame:
    """``data/thesis/<name>`` as a DataFrame."""
    import pandas as pd

    with resources.files("vadsim").joinpath(f"data/thesis/{name}").open() as fh:
        return pd.read_csv(fh)


def table_2_1() -> dict[str, dict[str, float]]:
    """Table 2.1 by tool: ``{"7in": {...}, "9.5in": {...}}`` (the 7in RC bit mass as
    ``m1_RC``)."""
    tools: dict[str, dict[str, float]] = {"7in": {}, "9.5in": {}}
    for row in thesis_rows("parameters.csv"):
        for tool in tools:
            value = row[f"tool_{tool}"].strip()
            if value:
                tools[tool][row["name"]] = float(value)
    return tools


def published_regimes() -> pd.DataFrame:
    """The five regimes of the 7in flow sweep (dissertation section 4.1)."""
    return thesis_csv("regimes_7in.csv")


def field_events(tool: str | None = None, bit: str | None = None) -> pd.DataFrame:
    """Every validation event: field and simulated peaks, impact frequency, behaviour."""
    df = thesis_csv("field_events.csv")
    if tool is not None:
        df = df[df["tool"] == tool]
    if bit is not None:
        df = df[df["bit"] == bit]
    return df.reset_index(drop=True)


def parametric_rows() -> dict[str, dict[str, str]]:
    """The parametric study's rows (``parametric.csv``) by parameter name."""
    return {row["study"]: row for row in thesis_rows("parametric.csv")}
