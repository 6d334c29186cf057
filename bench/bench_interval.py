"""Do calibration intervals hold the truth? The README's Fo example over several seeds.

Each seed writes the README's campaign (three flows, 200/450/600 gal/min, recorded with
Fo = 380 N/kg through the field sensor chain, 0.3 g noise) with its own sampling phases and
noise, calibrates Fo over 200-600 N/kg (``n_global=32``) and prints the estimate, the cost-rise
threshold, the 95 % interval, whether it holds 380, and the time.

    python bench/bench_interval.py                       # seeds 0 1 2, bootstrap intervals
    python bench/bench_interval.py --seeds 0 --method profile
"""

from __future__ import annotations

import argparse
import time

from vadsim.campaigns import synthetic
from vadsim.fit import calibrate

TRUE_FO = 380.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--method", choices=["auto", "bootstrap", "profile"], default="auto")
    args = ap.parse_args()
    held = 0
    for seed in args.seeds:
        t0 = time.perf_counter()
        camp = synthetic.synthetic_campaign("7in-cde", (200, 450, 600),
                                            overrides={"Fo": TRUE_FO}, seed=seed)
        fit = calibrate.calibrate(camp, ["Fo"], bounds={"Fo": (200, 600)}, n_global=32,
                                  progress=False, interval_method=args.method)
        lo, hi = fit.interval["Fo"]
        ok = lo <= TRUE_FO <= hi
        held += ok
        print(f"seed {seed}: {fit.interval_method}, Fo = {fit.estimates['Fo']:.2f}, threshold "
              f"{fit.threshold['Fo']:.2f}, 95 % interval [{lo:.1f}, {hi:.1f}], holds "
              f"{TRUE_FO:g}: {'yes' if ok else 'NO'}, {time.perf_counter() - t0:.0f} s",
              flush=True)
    print(f"{held} of {len(args.seeds)} intervals hold the truth")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
