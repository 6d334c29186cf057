"""The reproduction report: REPRODUCTION.md and its figures from a
:class:`~vadsim.studies.reproduction.Reproduction`.

Why this module exists: ``vadsim thesis --out DIR`` and docs/REPRODUCTION.md are the same
document; the tables come from :mod:`vadsim.studies.reproduction`, the scan's maps from
:mod:`vadsim.plots.constants`, the flow figures from :mod:`vadsim.plots.flow`.
"""

from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import pandas as pd

from vadsim.model.presets import get_preset
from vadsim.plots import peaks_vs_flow, regime_map
from vadsim.report.rendering import render, write
from vadsim.studies.design import STUDIES
from vadsim.studies.reproduction import Reproduction

__all__ = ["write_reproduction_report"]

_SECTIONS = (
    ("Regime bands (section 4.1)", "regimes_7in.csv", None,
     "The 7in CDE flow sweep, 200-650 gal/min in 10 gal/min steps, independent runs."),
    ("7in CDE events (chapter 4)", "field_events.csv", "7in-CDE", ""),
    ("7in RC events (chapter 4)", "field_events.csv", "7in-RC", ""),
    ("9.5in PDC events (chapter 4)", "field_events.csv", "9.5in-PDC",
     "The 9.5in preset, calibrated on these simulated events (docs/CALIBRATION.md)."),
    ("Design studies (chapter 5)", "parametric.csv", None, ""),
    ("Table 2.1", "parameters.csv", None, "Inputs: each preset uses them as published."),
)


def _section_table(rep: Reproduction, source: str, key: str | None) -> pd.DataFrame:
    t = rep.table[rep.table.source == source]
    if key is not None:
        t = t[t.id.str.contains(f":{key}-", regex=False)]
    cols = ["quantity", "published", "unit"]
    for lab in rep.presets:
        cols += [lab, f"status_{lab}"]
    cols += ["tolerance", "reason"]
    return t[cols].rename(columns={f"status_{lab}": f"{lab} status" for lab in rep.presets})


def write_reproduction_report(rep: Reproduction, folder: str | os.PathLike[str],
                              scan_dir: str | os.PathLike[str] | None = None,
                              best: dict[str, Any] | None = None,
                              command: str = "vadsim thesis --out DIR",
                              fmt: str = "md") -> Path:
    """Write ``REPRODUCTION.md`` (or ``.html``), and beside it ``reproduction/`` with
    ``reproduction.csv`` and the figures.

    Parameters
    ----------
    rep
        :func:`vadsim.studies.reproduction.reproduce`'s result.
    folder
        Output folder (created).
    scan_dir
        A ``vadsim constants`` output folder: its maps are copied in and shown.
    best
        The scan's best constants (``best.json``), quoted in the text.
    """
    out = Path(folder)
    files = out / "reproduction"  # figures and the CSV beside the page, not among its siblings
    files.mkdir(parents=True, exist_ok=True)
    rep.table.to_csv(files / "reproduction.csv", index=False)
    figures: dict[str, str | None] = {}
    for lab, sweeps in rep.sweeps.items():
        name = f"peaks-{lab}.png"
        with warnings.catch_warnings():  # the thesis preset is not 7in-cde: on purpose
            warnings.simplefilter("ignore", UserWarning)
            peaks_vs_flow(sweeps["cde"], reference="thesis-7in-cde", path=files / name)
        figures[f"x1 peaks along flow, {rep.presets[lab]}, with the dissertation's"] = (
            f"reproduction/{name}")
    for lab, maps in rep.maps.items():
        for study, ds in maps.items():
            name = f"{study}-map-{lab}.png"
            plt.close(regime_map(ds, path=files / name))
            figures[f"{study} map (chapter 5), {rep.presets[lab]}: regimes over excitation "
                    f"frequency and {STUDIES[study].parameter}"] = f"reproduction/{name}"
    if scan_dir is not None:
        for png in ("constants-maps.png", "target-maps.png"):
            src = Path(scan_dir) / png
            if src.is_file():
                shutil.copyfile(src, files / png)
                figures[f"scan: {png[:-4]}"] = f"reproduction/{png}"
    sections = [dict(title=title, what=what, table=_section_table(rep, source, key))
                for title, source, key, what in _SECTIONS]
    thesis_note = get_preset(rep.presets["thesis"]).note if "thesis" in rep.presets else ""
    text = render("reproduction.j2", fmt, "Reproduction", presets=rep.presets,
                  counts=rep.counts(), command=command, seconds=rep.seconds, best=best,
                  figures=figures, sections=sections, thesis_note=thesis_note)
    return write(out, "REPRODUCTION", fmt, text)
