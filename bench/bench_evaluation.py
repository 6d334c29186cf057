"""Time one evaluation of a 10-event campaign: every event's run and its measurement.

The campaign is ``bench_diagnose.py``'s (7in tool, 200-650 gal/min, 8 s events, 0.3 g noise;
here the tool saw 1.1 x the stated WOB). Each repeat evaluates a new model change (a WOB
scale), so nothing is cached; one worker thread (``--workers``: more threads of one evaluator, as a
diagnosis' sequential stages use it: their measurement shares one interpreter lock).
Compares the model folding only the periods its recordings folded at (what a diagnosis
does) with folding every period 1-4.

    python bench/bench_evaluation.py [--repeats N] [--workers N]
"""

from __future__ import annotations

import argparse
import statistics
import time

from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.model.change import ModelChange
from vadsim.model.settings import RunSettings

FLOWS = (200.0, 250.0, 300.0, 350.0, 400.0, 450.0, 500.0, 550.0, 600.0, 650.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--workers", type=int, default=1, help="evaluator threads (default 1)")
    args = ap.parse_args()
    camp = synthetic_campaign("7in-cde", FLOWS, change=ModelChange(scales={"wob": 1.1}),
                              cycles=300, analyse_cycles=200, duration_s=8.0, noise_g=0.3,
                              seed=7, name="bench-eval")
    settings = RunSettings("7in-cde", cycles=300, analyse_cycles=200)
    times: dict[str, list[float]] = {"the recordings' periods": [], "every period": []}
    for rep in range(args.repeats):
        for name, got in times.items():
            with CampaignEvaluator(camp, settings, phases=4, workers=args.workers,
                                   cache=False) as ev:
                if name == "every period":
                    ev.fold_periods = {}
                ev.base()
                change = ModelChange(scales={"wob": 1.0 + 0.01 * (rep + 1)})
                t0 = time.perf_counter()
                ev.evaluate([(f"wob-{rep}", change)])
                got.append(time.perf_counter() - t0)
    for name, got in times.items():
        per = statistics.median(got) / len(FLOWS) * 1000
        print(f"folding {name}: median {per:.0f} ms per event evaluation "
              f"({len(got)} evaluations of {len(FLOWS)} events, {args.workers} thread(s))")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
