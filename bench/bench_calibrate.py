"""Calibration recovers the withheld constants from recordings the model wrote itself.

Writes a synthetic campaign with l0 = 0.7 m, wob = 1000 N/kg (the 7in preset) through the
field sensor chain (1024 Hz, 250 g, 0.3 g noise), then calibrates l0 and wob from l0 = 1.0,
wob = 500 over the default bounds (l0 0.4-1.4, wob 200-2500), without being told the truth,
and prints the estimates, their errors, the costs (at the start, at the estimate and, for
comparison only, at the truth) and the time taken.

The campaign is designed as a field test would be to make both constants visible:

* several WOB levels, down to 0.5 klbf: ``wob`` only preloads the rock and the on-bottom
  shoulder, which never open at 4 klbf; at 0.5-1 klbf (the excitation Fo = 300 N/kg against
  a preload of 125-250 N/kg) the bit lifts and the response changes with ``wob``;
* flows over the whole range (150-550 gal/min), through the regime changes, whose positions
  move with the gaps (proportional to ``l0``);
* 8 s per event, as the field tests recorded: a long recording sweeps its sampling phase over
  the impacts, so its features match the model's average over sampling phases.

At a single WOB of 4 klbf, or with the former 6 events at 1-4 klbf, an alias of l0 with a
compensating wob fits as well as the truth (see docs/CALIBRATION.md).

    python bench/bench_calibrate.py            # about 15 minutes on 2 cores
    python bench/bench_calibrate.py --check    # only the costs at the truth and aliases
"""

from __future__ import annotations

import argparse
import math
import time

from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.calibrate import calibrate
from vadsim.fit.calibration_targets import calibration_cost
from vadsim.model.presets import get_preset

TRUTH = {"l0": 0.7, "wob": 1000.0}
START = {"l0": 1.0, "wob": 500.0}
FLOWS = tuple(q for q in (150.0, 250.0, 350.0, 450.0, 550.0) for _ in range(3))
WOBS = (0.5, 1.0, 2.0) * 5


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=float, default=200, help="model run length (cycles)")
    ap.add_argument("--analyse", type=float, default=100, help="model steady window (cycles)")
    ap.add_argument("--duration", type=float, default=8.0, help="recording per event (s)")
    ap.add_argument("--noise", type=float, default=0.3, help="sensor noise (g)")
    ap.add_argument("--n-global", type=int, default=256)
    ap.add_argument("--seed", type=int, default=3, help="noise and sampling-phase seed")
    ap.add_argument("--check", action="store_true",
                    help="only print the cost at the truth and at phase aliases")
    args = ap.parse_args()
    camp = synthetic_campaign("7in-cde", FLOWS, wob_klbf=WOBS, cycles=args.cycles,
                              analyse_cycles=args.analyse, duration_s=args.duration,
                              noise_g=args.noise, seed=args.seed)
    p = get_preset("7in-cde").params
    half = math.pi / (p["beta"] * (p["L3"] - p["LI"] - p["LOn"]))

    def cost(values: dict[str, float]) -> float:
        return calibration_cost(camp, values, cycles=args.cycles,
                                analyse_cycles=args.analyse)[0]

    print(f"{len(FLOWS)} events (flows {sorted(set(FLOWS))} gal/min x WOB "
          f"{sorted(set(WOBS))} klbf), {args.duration:g} s each, noise {args.noise:g} g")
    if args.check:
        print(f"cost at the truth {cost(TRUTH):.2f}")
        for k in (-2, -1, 0, 1, 2):
            for wob in (900.0, 950.0, 1000.0, 1050.0, 1100.0):
                if k == 0 and wob == TRUTH["wob"]:
                    continue
                v = {"l0": TRUTH["l0"] + k * half, "wob": wob}
                print(f"cost at l0 {v['l0']:.4f} ({k:+d} half-periods), wob {wob:g}: "
                      f"{cost(v):.2f}")
        return 0
    t0 = time.perf_counter()
    res = calibrate(camp, ("l0", "wob"), start=START, cycles=args.cycles,
                    analyse_cycles=args.analyse, n_global=args.n_global)
    seconds = time.perf_counter() - t0
    print(res.summary())
    err = {n: res.estimates[n] / TRUTH[n] - 1 for n in TRUTH}
    print(f"errors: l0 {err['l0']:+.2%}, wob {err['wob']:+.2%} "
          f"({'within' if max(map(abs, err.values())) <= 0.05 else 'NOT within'} 5 %); "
          f"{seconds:.0f} s")
    print(f"cost: start {res.cost_before:.2f}, estimate {res.cost_after:.2f}, "
          f"truth {cost(TRUTH):.2f} (for comparison only)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
