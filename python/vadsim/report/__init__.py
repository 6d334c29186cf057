"""Reports: Markdown and HTML documents of validations, diagnoses and the blind benchmark.

Why this package exists: every report is a table, some findings and some figures, rendered
to Markdown or HTML; the rendering lives here, once (:mod:`vadsim.report.rendering`: Jinja2
templates under ``templates/``, tables by pandas), and the analysis modules only compute.

* :mod:`~vadsim.report.validation`: :func:`write_validation_report` (``report.md``/``.html``);
* :mod:`~vadsim.report.diagnosis`: :func:`write_diagnosis_report` (``diagnosis.md``/``.html``,
  ``diagnosis.json``);
* :mod:`~vadsim.report.blind`: :func:`blind_markdown` (``scores.md``).

The three are imported from their modules (``from vadsim.report.validation import
write_validation_report``), not from here: they import the analysis modules (``vadsim.fit``),
and :mod:`vadsim.blind` imports :mod:`vadsim.report.blind` at its top.
"""

from __future__ import annotations

from vadsim.report.rendering import FORMATS, fmt_value, render

__all__ = ["FORMATS", "fmt_value", "render"]
