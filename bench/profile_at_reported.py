"""A blind campaign's reported intervals followed along the profile across islands.

Re-scores the intervals of a finished diagnosis without re-running it: reads the chosen model,
its point and its reported 95 % intervals from ``DIR/results/NAME.json``, runs
:func:`vadsim.fit.interval_profile.profile_intervals` from them with the diagnosis' evaluator
(recording cycles, diagnosis phases), and says per scored value (each candidate parameter the
truth shares, and the WOB factor, as ``vadsim blind`` scores them) whether the truth lies
inside before and after. The truth is read from ``DIR/campaigns/truth.json`` only for the
scoring, after the profile. One JSON file a campaign goes to ``--out``.

    python bench/profile_at_reported.py DIR NAME [NAME ...] [--out FOLDER] [--workers 2]

First used on the ten campaigns of the 44-campaign benchmark whose intervals missed a truth
(bench/results/2026-11-diagnosis-log.md, section 21).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from vadsim.blind.truth_regret import chosen_point
from vadsim.campaigns import campaign_preset, load_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.hypothesis import HypothesisCosts
from vadsim.fit.interval_profile import profile_intervals
from vadsim.fit.nuisance import DEFAULT_NUISANCE, resolve_nuisance
from vadsim.model.defaults import DEFAULTS
from vadsim.model.settings import RunSettings


def profile_one(folder: Path, name: str, workers: int) -> dict[str, Any]:
    """The profile at one campaign's reported point, with the truth's coverage."""
    result = json.loads((folder / "results" / f"{name}.json").read_text())
    camp = load_campaign(folder / "campaigns" / name)
    settings = RunSettings(campaign_preset(camp), cycles=DEFAULTS.recording_cycles,
                           analyse_cycles=DEFAULTS.analyse_cycles)
    nuisance = resolve_nuisance(DEFAULT_NUISANCE, settings)
    hyp, point = chosen_point(result, nuisance)
    names = [f"{CANDIDATES[k].id}.{p.name}" for k in hyp.keys for p in CANDIDATES[k].params]
    before = [tuple(result["intervals"][CANDIDATES[k].id][p.name]) for k in hyp.keys
              for p in CANDIDATES[k].params]
    before += [tuple(result["nuisance"][s.name]["interval"]) for s in nuisance]
    names += [s.name for s in nuisance]
    eids = [e.id for e in camp.events]
    t0 = time.perf_counter()
    with CampaignEvaluator(camp, settings, phases=DEFAULTS.diagnosis_phases,
                           workers=workers) as ev:
        ev.base(eids)
        costs = HypothesisCosts(ev, hyp, eids)
        rss = costs.rss(point)
        n0 = ev.n_evals
        after = profile_intervals(costs, point, before, rss, len(eids))
        points = (ev.n_evals - n0) // len(eids)
    seconds = time.perf_counter() - t0
    truth = json.loads((folder / "campaigns" / "truth.json").read_text())[name]
    true_values = {f"{t['id']}.{k}": float(v) for t in truth["truths"]
                   for k, v in t["values"].items()}
    true_values["wob_scale"] = float(truth.get("nuisance", {}).get("wob_scale", 1.0))
    rows = []
    for j, label in enumerate(names):
        true = true_values.get(label)
        rows.append({"value": label, "reported": point[j], "truth": true,
                     "before": list(before[j]), "after": list(after[j]),
                     "covers_before": _covers(before[j], true),
                     "covers_after": _covers(after[j], true)})
    return {"campaign": name, "model": list(hyp.keys), "training_cost": rss,
            "profile_points": points, "seconds": round(seconds, 1), "rows": rows}


def _covers(interval: tuple[float, ...], true: float | None) -> bool | None:
    return None if true is None else bool(interval[0] <= true <= interval[1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="the folder of `vadsim blind --out`")
    ap.add_argument("names", nargs="+", help="campaign names, e.g. blind-11")
    ap.add_argument("--out", type=Path, default=Path("."), help="folder for NAME.profile.json")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.names:
        one = profile_one(args.folder, name, args.workers)
        (args.out / f"{name}.profile.json").write_text(json.dumps(one, indent=1) + "\n")
        for r in one["rows"]:
            if r["truth"] is not None:
                print(f"{name} {r['value']:36s} truth {r['truth']:<10.5g} "
                      f"before {r['before'][0]:.5g}..{r['before'][1]:.5g} "
                      f"after {r['after'][0]:.5g}..{r['after'][1]:.5g} "
                      f"covers {r['covers_before']} -> {r['covers_after']}")
        print(f"{name}: {one['profile_points']} points, {one['seconds']} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
