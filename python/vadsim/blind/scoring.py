"""Scores of the blind benchmark: diagnoses against the concealed truth, per class.

Why this module exists: a benchmark is only as good as its rules of correctness, and they
must be the same for a hand-written test and for an hour of diagnoses. This module holds
them, works on plain dictionaries (``results/<name>.json`` and ``truth.json`` as loaded), and
runs no model.

The diagnosis JSON scored (``Diagnosis.as_json()``): ``verdict`` ("none", "explained" or
"unexplained"), ``missing_physics`` (candidate ids, ``["none"]`` when none),
``missing_physics_keys`` (the same with variants), ``parameters`` (``{id: {param: value,
fixed choices}}``), ``nuisance`` (``{name: {"value": v, "interval": [lo, hi]}}``),
``heldout_error_before``, ``heldout_error_after`` and ``elapsed_s``. The earlier format (one
id as a string, flat parameters, no verdict, no nuisance) is normalised by
:func:`normalise_result`, so results written before still score.

Rules
-----
* correct: the set of ids found equals the set of true ids (order-insensitive), and the
  verdict is not "unexplained". On a null campaign: ``["none"]`` and the verdict "none";
  anything else (another id, or "unexplained") is a false alarm.
* variant-correct: the same with keys (``hydraulic_force[anvil]``), reported separately;
  unknown (None) for results without keys.
* parameter error, for every true id also found: ``|found / true - 1|`` per ``id.param``
  (the absolute error when the true value is 0).
* held-out improvement ``1 - after / before`` on every campaign with an effect.
* nuisance recovery: ``|wob_scale found - true|`` (true 1 unless set) where the result has
  it; ``theta0`` as the distance modulo pi where the truth sets it.
* interval coverage: of the true values the diagnosis reports an interval for (every true
  id's parameters when the id is found, and ``wob_scale``, true 1 unless set), how many lie
  inside their 95 % interval; a calibrated uncertainty covers about 95 % of them.
* false alarms over every null-like campaign: the null and nuisance_null classes and the
  nulls of the other classes.
* regret (:mod:`vadsim.blind.truth_regret`, where the result carries one): the chosen model's
  training cost minus the true model's; a regret beyond the noise is a search failure,
  whatever the verdict. Scored as the share of campaigns within the noise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["CRITERIA", "normalise_result", "normalise_truth", "score"]

CRITERIA: dict[str, str] = {
    "size": "at least 40 campaigns, at least 12 of them from the independent generator",
    "identification": "identification >= 90 % in every class",
    "false_alarms": "false alarms in at most 1 of 10 null-like campaigns",
    "regret": "regret within the noise in >= 95 % of the campaigns it is scored on",
    "heldout": "held-out error down >= 50 % in every campaign with an effect",
    "coverage": "95 % intervals hold 90-98 % of the true values",
}
"""The acceptance criteria of the benchmark, checked by :func:`score`."""

_MIN_CAMPAIGNS, _MIN_INDEPENDENT = 40, 12
_MIN_IDENTIFICATION = 0.9
_MAX_FALSE_ALARM_RATE = 0.1
_MIN_REGRET_WITHIN = 0.95
_MIN_HELDOUT_GAIN = 0.5
_COVERAGE_RANGE = (0.90, 0.98)


def _value(v: Any) -> float:
    return float(v["value"]) if isinstance(v, Mapping) else float(v)


def normalise_result(r: Mapping[str, Any]) -> dict[str, Any]:
    """One diagnosis JSON in the current form; the earlier one (``missing_physics`` a
    string, parameters flat, no verdict) converted. Ids and keys come without "none"."""
    mp = r.get("missing_physics", "none")
    old = isinstance(mp, str)
    ids = [i for i in ([mp] if old else list(mp)) if i != "none"]
    keys = r.get("missing_physics_keys")
    params = dict(r.get("parameters") or {})
    if old:
        params = {ids[0]: params} if ids else {}
    return {
        "verdict": r.get("verdict") or ("explained" if ids else "none"),
        "ids": ids,
        "keys": None if keys is None else [k for k in keys if k != "none"],
        "parameters": {i: dict(v) for i, v in params.items() if isinstance(v, Mapping)},
        "nuisance": {k: _value(v) for k, v in (r.get("nuisance") or {}).items()},
        "intervals": {i: {k: (float(v[0]), float(v[1])) for k, v in d.items()}
                      for i, d in (r.get("intervals") or {}).items()},
        "nuisance_intervals": {k: (float(v["interval"][0]), float(v["interval"][1]))
                               for k, v in (r.get("nuisance") or {}).items()
                               if isinstance(v, Mapping) and v.get("interval")},
        "heldout_before": float(r.get("heldout_error_before", math.nan)),
        "heldout_after": float(r.get("heldout_error_after", math.nan)),
        "elapsed_s": r.get("elapsed_s"),
        "concealment": r.get("concealment"),
        "regret": r.get("regret"),
    }


def normalise_truth(t: Mapping[str, Any]) -> dict[str, Any]:
    """One ``truth.json`` entry in the current form; an earlier one (a single ``id``,
    ``key`` and ``values``) becomes class "default"."""
    if "truths" in t:
        return {"class": t.get("class", "default"), "truths": list(t["truths"]),
                "nuisance": dict(t.get("nuisance") or {}),
                "library_point": bool(t.get("library_point", True)),
                "generator": str(t.get("generator", "vadsim"))}
    truths = [] if t["id"] == "none" else [{"key": t.get("key", t["id"]), "id": t["id"],
                                            "values": dict(t.get("values") or {})}]
    return {"class": "default", "truths": truths, "nuisance": {}, "library_point": True,
            "generator": "vadsim"}


def _parameter_errors(truths: Sequence[Mapping[str, Any]], found: set[str],
                      params: Mapping[str, Mapping[str, Any]]) -> dict[str, float]:
    errs: dict[str, float] = {}
    for t in truths:
        if t["id"] not in found:
            continue
        got_all = params.get(t["id"], {})
        for k, v in t["values"].items():
            got = got_all.get(k)
            if isinstance(got, int | float) and not isinstance(got, bool):
                errs[f"{t['id']}.{k}"] = (abs(float(got) / v - 1.0) if v != 0
                                          else abs(float(got)))
    return errs


def _coverage(truths: Sequence[Mapping[str, Any]], found: set[str],
              r: Mapping[str, Any], nuisance_truth: Mapping[str, float]
              ) -> dict[str, bool]:
    """``{"id.param" or nuisance name: true value inside its reported interval}`` over the
    true values the result gives an interval for."""
    out: dict[str, bool] = {}
    for t in truths:
        ivs = r["intervals"].get(t["id"], {}) if t["id"] in found else {}
        for k, v in t["values"].items():
            if k in ivs:
                lo, hi = ivs[k]
                out[f"{t['id']}.{k}"] = bool(lo <= v <= hi)
    if "wob_scale" in r["nuisance_intervals"]:
        lo, hi = r["nuisance_intervals"]["wob_scale"]
        out["wob_scale"] = bool(lo <= nuisance_truth.get("wob_scale", 1.0) <= hi)
    return out


def _nuisance_errors(truth: Mapping[str, float], found: Mapping[str, float]
                     ) -> dict[str, float | None]:
    wob = (abs(found["wob_scale"] - truth.get("wob_scale", 1.0))
           if "wob_scale" in found else None)
    th = None
    if "theta0" in truth and "theta0" in found:
        th = abs((found["theta0"] - truth["theta0"] + math.pi / 2) % math.pi - math.pi / 2)
    return {"wob_scale": wob, "theta0": th}


def _row(name: str, r: dict[str, Any], t: dict[str, Any]) -> dict[str, Any]:
    """One campaign scored by the rules of the module docstring."""
    tids = [x["id"] for x in t["truths"]]
    tkeys = [x["key"] for x in t["truths"]]
    found = set(r["ids"])
    null = not tids
    if null:
        correct = not found and r["verdict"] == "none"
    else:
        correct = found == set(tids) and r["verdict"] != "unexplained"
    variant = (None if r["keys"] is None or null
               else correct and set(r["keys"]) == set(tkeys))
    b, a = r["heldout_before"], r["heldout_after"]
    gain = (1.0 - a / b if b > 0 else math.nan) if not null else None
    nerr = _nuisance_errors(t["nuisance"], r["nuisance"])
    return {
        "campaign": name, "class": t["class"], "truth": tids, "truth_keys": tkeys,
        "truth_values": {x["id"]: dict(x["values"]) for x in t["truths"]},
        "nuisance_truth": t["nuisance"], "null": null,
        "found": r["ids"] or ["none"], "found_keys": r["keys"], "verdict": r["verdict"],
        "parameters": r["parameters"], "nuisance": r["nuisance"],
        "correct": bool(correct), "variant_correct": variant,
        "false_alarm": (not correct) if null else None,
        "parameter_error": _parameter_errors(t["truths"], found, r["parameters"]),
        "heldout_before": b, "heldout_after": a, "heldout_improvement": gain,
        "wob_scale_error": nerr["wob_scale"], "theta0_error": nerr["theta0"],
        "interval_covers": _coverage(t["truths"], found, r, t["nuisance"]),
        "concealment": r["concealment"], "elapsed_s": r["elapsed_s"],
        "regret": None if r["regret"] is None else float(r["regret"]["regret"]),
        "regret_noise": None if r["regret"] is None else float(r["regret"]["noise"]),
        "search_failure": None if r["regret"] is None else bool(r["regret"]["search_failure"]),
        "regret_na": not t["library_point"], "generator": t["generator"],
    }


def _median(values: Sequence[float | None]) -> float:
    v = [x for x in values if x is not None and not math.isnan(x)]
    return float(np.median(v)) if v else math.nan


def _min(values: Sequence[float | None]) -> float:
    v = [x for x in values if x is not None and not math.isnan(x)]
    return float(np.min(v)) if v else math.nan


def _rate(flags: Sequence[bool | None]) -> float:
    v = [bool(x) for x in flags if x is not None]
    return float(np.mean(v)) if v else math.nan


def _summary(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Rates, medians and extremes of a set of scored campaigns (a class, or all)."""
    effect = [r for r in rows if not r["null"]]
    null = [r for r in rows if r["null"]]
    perr: dict[str, list[float]] = {}
    for r in effect:
        for k, v in r["parameter_error"].items():
            perr.setdefault(k, []).append(v)
    return {
        "campaigns": len(rows), "correct": sum(r["correct"] for r in rows),
        "identification_rate": _rate([r["correct"] for r in rows]),
        "effect_campaigns": len(effect), "null_campaigns": len(null),
        "effects_identified": _rate([r["correct"] for r in effect]),
        "variant_rate": _rate([r["variant_correct"] for r in effect]),
        "false_alarms": sum(bool(r["false_alarm"]) for r in null),
        "parameter_error_median": {k: _median(v) for k, v in sorted(perr.items())},
        "heldout_improvement_median": _median([r["heldout_improvement"] for r in effect]),
        "heldout_improvement_min": _min([r["heldout_improvement"] for r in effect]),
        "wob_scale_error_median": _median([r["wob_scale_error"] for r in rows]),
        "theta0_error_median": _median([r["theta0_error"] for r in rows]),
        "intervals_covering": sum(sum(r["interval_covers"].values()) for r in rows),
        "intervals_scored": sum(len(r["interval_covers"]) for r in rows),
        "regret_scored": sum(r["search_failure"] is not None for r in rows),
        "search_failures": sum(bool(r["search_failure"]) for r in rows),
        "regret_within_noise": _rate([None if r["search_failure"] is None
                                      else not r["search_failure"] for r in rows]),
        "elapsed_s": float(sum(r["elapsed_s"] or 0.0 for r in rows)),
    }


def _status(ok: bool | None) -> str:
    return "n/a" if ok is None else ("PASS" if ok else "FAIL")


def _criterion(key: str, ok: bool | None, detail: str) -> dict[str, Any]:
    return {"criterion": CRITERIA[key], "status": _status(ok), "detail": detail}


def _criteria(classes: Mapping[str, dict[str, Any]], rows: Sequence[dict[str, Any]]
              ) -> list[dict[str, Any]]:
    """PASS, FAIL or n/a (nothing to judge) per acceptance criterion, with the numbers."""
    independent = sum(r["generator"] == "independent" for r in rows)
    worst = min(classes.items(), key=lambda kv: kv[1]["identification_rate"], default=None)
    low = [c for c, s in classes.items() if s["identification_rate"] < _MIN_IDENTIFICATION]
    null = [r for r in rows if r["null"]]
    alarms = sum(bool(r["false_alarm"]) for r in null)
    regrets = [not r["search_failure"] for r in rows if r["search_failure"] is not None]
    gains = [r["heldout_improvement"] for r in rows if not r["null"]]
    short = [g for g in gains if not (g is not None and g >= _MIN_HELDOUT_GAIN)]
    covers = [c for r in rows for c in r["interval_covers"].values()]
    coverage = float(np.mean(covers)) if covers else math.nan
    return [
        _criterion("size", len(rows) >= _MIN_CAMPAIGNS and independent >= _MIN_INDEPENDENT,
                   f"{len(rows)} campaigns, {independent} from the independent generator"),
        _criterion("identification", not low if worst else None,
                   (f"lowest {worst[0]} {100 * worst[1]['identification_rate']:.0f} %"
                    + (f"; below: {', '.join(low)}" if low else "")) if worst else "no class"),
        _criterion("false_alarms", alarms <= _MAX_FALSE_ALARM_RATE * len(null) if null else None,
                   f"{alarms} of {len(null)} null-like campaigns"),
        _criterion("regret", (sum(regrets) >= _MIN_REGRET_WITHIN * len(regrets)
                              if regrets else None),
                   f"{sum(regrets)} of {len(regrets)} campaigns" if regrets
                   else "no campaign with a regret"),
        _criterion("heldout", not short if gains else None,
                   (f"{len(gains) - len(short)} of {len(gains)} campaigns; smallest "
                    f"{100 * _min(gains):.0f} %") if gains else "no campaign with an effect"),
        _criterion("coverage", (_COVERAGE_RANGE[0] <= coverage <= _COVERAGE_RANGE[1]
                                if covers else None),
                   f"{sum(covers)} of {len(covers)} true values ({100 * coverage:.0f} %)"
                   if covers else "no interval to score"),
    ]


def _class_order(rows: Sequence[dict[str, Any]], order: Sequence[str]) -> list[str]:
    seen = list(dict.fromkeys(r["class"] for r in rows))
    return [c for c in order if c in seen] + [c for c in seen if c not in order]


def score(results: Mapping[str, Mapping[str, Any]], truth: Mapping[str, Mapping[str, Any]],
          class_order: Sequence[str] = ()) -> dict[str, Any]:
    """Scores of diagnoses (``as_json`` outputs by campaign name, either format) against the
    truth (``truth.json``): per class, overall, the acceptance criteria, one row per
    campaign. Classes come in ``class_order``, then in order of appearance."""
    rows = [_row(n, normalise_result(results[n]), normalise_truth(truth[n]))
            for n in sorted(results)]
    classes = {c: _summary([r for r in rows if r["class"] == c])
               for c in _class_order(rows, class_order)}
    overall = _summary(rows)
    per: dict[str, list[bool]] = {}
    for r in rows:
        for i in r["truth"]:
            per.setdefault(i, []).append(i in r["found"] and r["verdict"] != "unexplained")
    return {
        "classes": classes, "overall": overall, "criteria": _criteria(classes, rows),
        "identification_rate": overall["effects_identified"],
        "identification_by_candidate": {k: float(np.mean(v)) for k, v in sorted(per.items())},
        "false_alarms": overall["false_alarms"], "null_campaigns": overall["null_campaigns"],
        "effect_campaigns": overall["effect_campaigns"],
        "parameter_error_median": overall["parameter_error_median"],
        "heldout_improvement_min": overall["heldout_improvement_min"],
        "heldout_improvement_median": overall["heldout_improvement_median"],
        "campaigns": rows,
    }
