"""The words of results: a diagnosis' terminal summary, verdict sentence and notebook table.

The results are data (:class:`~vadsim.fit.diagnosis.Diagnosis`); their ``summary()``,
``verdict_text()`` and ``_repr_html_()`` ask :mod:`vadsim._render` for the functions
registered here when this module is imported.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from typing import Any

from vadsim._html import grid_table, key_value_table
from vadsim._render import register
from vadsim.fit.diagnosis import Diagnosis
from vadsim.fit.diagnosis.operating_point import operating_point_text
from vadsim.fit.diagnosis.search import PAIR_SCREEN_REPORT
from vadsim.fit.hypothesis_fit import HypothesisFit
from vadsim.report.rendering import fmt_value

__all__ = ["SUMMARY_LEGEND", "diagnosis_html", "diagnosis_summary", "edges_text",
           "params_text", "verdict_text"]


SUMMARY_LEGEND = """\
How to read it: a residual is (model - recorded) / the recording's own spread. Held-out RMS is
their root mean square on events left out of the fit: LOFO leaves one flow out at a time,
block the highest flows; near 1 or below, the model predicts within the recordings' scatter.
wob_scale (a factor on the reported WOB) and theta0 (the excitation phase at rest, rad) are
the base model's uncertain constants, refitted with every candidate. k: constants fitted
(the candidate's and those); score: held-out AICc, lower is better: an effect must beat
'none' by {min_delta:g} and cut the held-out RMS by {min_reduction:.0%} (docs/DIAGNOSIS.md)."""
"""Printed under :meth:`Diagnosis.summary`: the terms it uses (``settings`` fill it in)."""


def diagnosis_summary(diag: Diagnosis) -> str:
    """A few lines for a terminal: what was found, step by step, the verdict and a legend of
    the terms (:meth:`Diagnosis.summary`)."""
    lines = [f"{diag.campaign.name}: {len(diag.campaign.events)} events; the model was "
             f"evaluated {diag.n_evals} times in {diag.elapsed_s:.0f} s",
             "  (an evaluation: one event simulated and measured, for one candidate at one "
             "parameter point)"]
    if diag.located:
        lines.append("located: " + "; ".join(m.describe() for m in diag.located[:4]))
    else:
        lines += textwrap.wrap(
            "located: no single feature is offset or trends with flow beyond the threshold "
            "(1.5 spreads, significant)"
            + (": the effect below was chosen on the held-out fit of all the features "
               "together, where small shifts of many add up" if diag.chosen else ""),
            96, subsequent_indent="  ")
    if (op := operating_point_text(diag.operating_point)) is not None:
        lines += textwrap.wrap(op, 96, subsequent_indent="  ")
    nuis = ", ".join(f"{k} = {fmt_value(v)}" for k, v in diag.baseline.nuisance.items())
    which = "nominal" if diag.none_fit is diag.uncalibrated else "calibrated"
    lines.append(f"base model: held-out RMS {diag.uncalibrated.heldout_rms:.3f} nominal, "
                 f"{diag.baseline.heldout_rms:.3f} calibrated ({nuis or 'no nuisance'}); "
                 f"'none' is the {which} one")
    for w in diag.widened_nuisance:
        lines.append(f"nuisance {w['name']} ended at its {w['bound']} bound "
                     f"({fmt_value(w['value'])}): the recordings ask for more than "
                     f"{fmt_value(w['from'][0])}-{fmt_value(w['from'][1])}; widened to "
                     f"{fmt_value(w['to'][0])}-{fmt_value(w['to'][1])} and refitted")
    for w in diag.widened_chosen:
        lines.append(f"chosen model: {w['of']} {w['name']} ended at its {w['bound']} bound "
                     f"({fmt_value(w['value'])}) of {fmt_value(w['from'][0])}-"
                     f"{fmt_value(w['from'][1])}; widened to {fmt_value(w['to'][0])}-"
                     f"{fmt_value(w['to'][1])} and refitted"
                     + (f" -- the model refused a point there ({w['refused']}); the fit "
                        "over the earlier range is kept" if w.get("refused") else ""))
    for i, step in enumerate(diag.steps):
        lines.append(f"step {i + 1}: {'candidate':34s} {'k':>2s} "
                     f"{'held-out RMS (LOFO/block)':>26s} {'score':>9s}")
        for f in step[:8]:  # a probe's RMS is on a subset of events: no score
            lines.append(f"        {f.key:34s} {f.k:2d} {f.heldout_rms:6.3f} "
                         f"({f.heldout_rms_lofo:.2f}/{f.heldout_rms_block:.2f}) "
                         + (f"{'probe':>9s}" if f.probe else f"{f.score:9.1f}")
                         + f"  {params_text(f)}")
    for screen, what in ((False, "pair step (joint probes, RSS on the probe events; "
                                 "best single"),
                         (True, "pair screen (every model-side pair, best "
                                f"{PAIR_SCREEN_REPORT}; RSS on the worst events; base")):
        rows = [q for q in diag.pairs if bool(q.get("screen")) == screen]
        if rows:
            lines.append(f"{what} {rows[0]['single_rss']:.1f}): "
                         + ", ".join(f"{q['pair']} {q['probe_rss']:.1f}"
                                     + (" (fitted)" if q["fitted"] else "")
                                     for q in rows))
    for r in diag.review:
        what = (f"{r['from']} as {r['to']}" if r["action"] == "swap" else
                f"without {r['from']}")
        lines.append(f"review: {what} -> {r['model']}: held-out RMS {r['heldout_rms']:.3f}, "
                     f"score {r['score']:.1f} against {r['against']:.1f}"
                     + (" (accepted)" if r["accepted"] else "")
                     + (f": {r['why']}" if r.get("why") else ""))
    lines.append(verdict_text(diag))
    if diag.prediction:
        p = diag.prediction
        lines.append(f"prediction of {p['campaign']}: RMS {p['error_before']:.2f} -> "
                     f"{p['error_after']:.2f}")
    legend = SUMMARY_LEGEND.format(min_delta=diag.settings.get("min_delta", 10.0),
                                   min_reduction=diag.settings.get("min_reduction", 0.3))
    return "\n".join([*lines, legend])


def verdict_text(diag: Diagnosis) -> str:
    """One sentence: what is missing, or that nothing is, or what is left unexplained; and
    where the records ran off their stated flows, that it holds at the flows stated."""
    return _verdict_sentence(diag) + _operating_point_caveat(diag)


def _operating_point_caveat(diag: Diagnosis) -> str:
    off = sorted(r["off"] for r in diag.operating_point if r["beyond"])
    if not off:
        return ""
    return (f"; but {len(off)} of {len(diag.operating_point)} records ran off their stated "
            f"flows, by {100 * off[len(off) // 2]:+.1f} % (median): the model ran at the "
            f"flows stated, not at those run (operating point)")


def _verdict_sentence(diag: Diagnosis) -> str:
    b, f = diag.none_fit.heldout_rms, diag.final.heldout_rms
    which = "nominal" if diag.none_fit is diag.uncalibrated else "calibrated"
    noise = diag.noise
    if diag.verdict == "none":
        within = (f"; RMS z {noise['rms']:.2f}, within the noise: at most {_band(noise)}"
                  if noise else "")
        return (f"missing physics: none (the {which} base model explains the campaign: "
                f"held-out RMS {b:.2f} <= {diag.settings['max_rms']:g}{within})")
    what = (f"{' + '.join(diag.chosen.ids)} ({params_text(diag.chosen)}); held-out RMS "
            f"{b:.2f} -> {f:.2f}" if diag.chosen else
            "no candidate" + (" nor pair" if diag.pairs else "") + " passes the thresholds")
    if diag.chosen:
        what += edges_text(diag.chosen)
    where = "; ".join(f"{u['flow_gpm']:g} gal/min ({', '.join(u['worst'])})"
                      for u in diag.unexplained[:4])
    if diag.verdict == "explained":
        if noise is None or noise["within"]:
            return f"missing physics: {what}"
        return (f"missing physics: {what}; a remainder beyond the noise: RMS z "
                f"{noise['rms']:.2f} on the campaign, above {_band(noise, 'the final model')}"
                + (f"; worst at {where}" if where else ""))
    if diag.chosen is None and noise is not None and not noise["within"]:
        located = "; ".join(m.describe() for m in diag.located[:3])
        return (f"a mismatch beyond the noise that no candidate explains: the {which} base "
                f"model's RMS z {noise['rms']:.2f} on the campaign, above {_band(noise)} "
                f"(median {noise['median']:.2f}); held-out RMS "
                f"{b:.2f}" + (f"; worst at {where}" if where else "")
                + (f"; located: {located}" if located else ""))
    return (f"unexplained mismatch at {where or 'several events'}: {what}; held-out RMS "
            f"{f:.2f} > {diag.settings['max_rms']:g}")


def _band(noise: Mapping[str, Any], writer: str = "it") -> str:
    """The noise band as the verdict reads it: its edge and what it is the quantile of."""
    return (f"{noise['band']:.2f}, the {100 * noise['quantile']:g} % quantile of "
            f"{noise['draws']} campaigns {writer} writes itself")


def diagnosis_html(diag: Diagnosis) -> str:
    """The notebook table of a diagnosis (:meth:`Diagnosis._repr_html_`)."""
    head = key_value_table(f"Diagnosis: {diag.campaign.name}", [
        ("verdict", verdict_text(diag)),
        ("held-out RMS z", f"{diag.none_fit.heldout_rms:.3f} (none) -> "
                           f"{diag.final.heldout_rms:.3f} (final)"),
        ("nuisance", ", ".join(f"{k} = {fmt_value(v)}"
                               for k, v in diag.baseline.nuisance.items()) or "none"),
        ("work", f"{len(diag.campaign.events)} events, {diag.n_evals} evaluations, "
                 f"{diag.elapsed_s:.0f} s"),
    ])
    rows = [(f.key, f.k, "probe" if f.probe else f"{f.heldout_rms:.3f}",
             "-" if f.probe else f"{f.score:.1f}", params_text(f))
            for f in diag.ranking[:8]]
    return head + grid_table(("first step: candidate", "k", "held-out RMS", "score",
                              "values"), rows)



def edges_text(fit: HypothesisFit) -> str:
    """The verdict's caveat for candidate parameters ``fit`` left at an end of their search
    range (:attr:`~vadsim.fit.hypothesis_fit.HypothesisFit.at_bounds`), or ``""``."""
    edges = [e for e in fit.at_bounds if e["of"] != "nuisance"]
    if not edges:
        return ""
    return ("; at the edge of its search range: "
            + ", ".join(f"{e['of']} {e['param']} = {fmt_value(e['value'])} ({e['bound']} bound)"
                        for e in edges)
            + " -- a bound, not an estimate: read the effect as a proxy for what moves the "
              "features")


def params_text(fit: HypothesisFit) -> str:
    """A fit's values as ``name=value`` pairs."""
    return ", ".join(f"{k}={fmt_value(v)}" for k, v in fit.values.items())


register(Diagnosis, "text", diagnosis_summary)
register(Diagnosis, "verdict", verdict_text)
register(Diagnosis, "html", diagnosis_html)
