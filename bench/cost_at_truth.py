"""A blind campaign's training cost at its truth, against the fits its diagnosis reached.

A post-mortem for a missed campaign: does the model at the true values explain it (then the
search failed), or not (then the candidates or the thresholds did)? Reads the truth from
``DIR/campaigns/truth.json`` -- only after the diagnosis, never for it -- and evaluates, with
the diagnosis' evaluator and default nuisance constants, the training RSS (sum of squared
standardised residuals over every event) at the truth (WOB as recorded, theta0 at rest)
and at every fit of ``DIR/results/NAME.json`` over the same candidates, plus any
``--point`` given, and the truth at other excitation phases at rest (``--theta0``): near a
regime boundary one event's response can flip between phases a fraction of a milliradian
apart. Each line gives the worst event's share.

    python bench/cost_at_truth.py DIR NAME [--point v1,v2,...] [--theta0 a,b,...]
                                          [--steady auto|full]

``--steady full`` evaluates with literal runs, to tell the steady-state engine's part in a
fit from the search's. First used on blind-12 (bench/results/2026-11-diagnosis-log.md,
"Stop 24").
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from vadsim.blind.truth_regret import truth_point
from vadsim.campaigns import campaign_preset, load_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.hypothesis import HypothesisCosts
from vadsim.fit.nuisance import DEFAULT_NUISANCE, resolve_nuisance
from vadsim.model.settings import RunSettings


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="the folder of `vadsim blind --out`")
    ap.add_argument("name", help="campaign name, e.g. blind-12")
    ap.add_argument("--point", action="append", default=[],
                    help="more points, comma-separated, in the truth's coordinate order")
    ap.add_argument("--theta0", default="",
                    help="comma-separated phases at rest (rad) to evaluate the truth at")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--steady", choices=("auto", "full"), default="auto",
                    help="the runs' steady-state engine (default auto, as a diagnosis)")
    args = ap.parse_args()
    truth = json.loads((args.folder / "campaigns" / "truth.json").read_text())[args.name]
    camp = load_campaign(args.folder / "campaigns" / args.name)
    settings = RunSettings(campaign_preset(camp), cycles=300, analyse_cycles=200,
                           steady=args.steady)
    nuis = resolve_nuisance(tuple(DEFAULT_NUISANCE), settings)
    hyp, at_truth = truth_point(truth, nuis)
    values = list(at_truth[:hyp.n_physics])
    wob = at_truth[hyp.n_physics]
    points = {"truth": at_truth}
    order = [(t, p.name) for t in truth["truths"] for p in CANDIDATES[t["key"]].params]
    names = [f"{t['key']}.{p}" for t, p in order]
    result = args.folder / "results" / f"{args.name}.json"
    if result.exists():
        for step in json.loads(result.read_text())["steps"]:
            for row in step["ranking"]:
                by_id = row["parameters"]
                if set(row["ids"]) != {t["id"] for t in truth["truths"]} or row["probe_only"]:
                    continue
                vals = [by_id[t["id"]][p] for t, p in order]
                nv = [row["nuisance"][s.name] for s in nuis]
                points[f"step {step['step']}: {row['candidate']}"] = hyp.round([*vals, *nv])
    for th in filter(None, args.theta0.split(",")):
        points[f"truth at theta0 {float(th):g}"] = hyp.round([*values, wob, float(th)])
    for i, p in enumerate(args.point):
        points[f"--point {i + 1}"] = hyp.round([float(v) for v in p.split(",")])
    eids = [e.id for e in camp.events]
    with CampaignEvaluator(camp, settings, phases=4, workers=args.workers) as ev:
        ev.base(eids)
        costs = HypothesisCosts(ev, hyp, eids)
        n = sum(len(ev.keys[e]) for e in eids)
        print(f"{args.name}: {', '.join(names)}, wob_scale, theta0; {n} residuals")
        labels = list(points)
        per_event = costs.event_rss([points[k] for k in labels])
        for label, row in zip(labels, per_event, strict=True):
            rss, worst = float(row.sum()), int(row.argmax())
            print(f"  {label:45s} RSS {rss:9.1f}  RMS z {(rss / n) ** 0.5:5.2f}  worst "
                  f"{eids[worst]} ({camp.events[worst].flow_gpm:g} gal/min) {row[worst]:8.1f}"
                  f"  at {points[label]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
