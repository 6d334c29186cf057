"""Calibration recovers the withheld constants from recordings the model wrote itself.

Writes a synthetic campaign with l0 = 0.7 m, wob = 1000 N/kg (the 7in preset) through the
sensor chain with 0.3 g noise, then calibrates l0 and wob from l0 = 1.0, wob = 500 and prints
the estimates, their errors, the cost before and after and the time taken.

The campaign varies the WOB as a field test does (1, 2 and 4 klbf). At a single WOB the two
constants are not identifiable from the recordings: wob only preloads the rock and the
on-bottom shoulder, which never open at 4 klbf, and a change of l0 by one period of the
excitation phase (2 pi / (beta (L3 - LI - LOn)) = 0.0166) with a compensating wob fits
within the noise. At 1-2 klbf the shoulder opens and wob shows.

    python bench/bench_calibrate.py            # about 5-10 minutes on 2 cores
"""

from __future__ import annotations

import argparse
import time

from vadsim.calibrate import calibrate
from vadsim.synthetic import synthetic_campaign

FLOWS = (250.0, 250.0, 300.0, 450.0, 450.0, 600.0)
WOBS = (1.0, 4.0, 2.0, 1.0, 4.0, 4.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=float, default=200)
    ap.add_argument("--analyse", type=float, default=100)
    ap.add_argument("--n-global", type=int, default=512)
    ap.add_argument("--seed", type=int, default=3, help="noise and sampling-phase seed")
    args = ap.parse_args()
    camp = synthetic_campaign("7in-cde", FLOWS, wob_klbf=WOBS, cycles=args.cycles,
                              analyse_cycles=args.analyse, noise_g=0.3, seed=args.seed)
    t0 = time.perf_counter()
    res = calibrate(camp, ("l0", "wob"), start={"l0": 1.0, "wob": 500.0},
                    cycles=args.cycles, analyse_cycles=args.analyse, n_global=args.n_global)
    print(res.summary())
    err = {"l0": res.estimates["l0"] / 0.7 - 1, "wob": res.estimates["wob"] / 1000.0 - 1}
    print(f"errors: l0 {err['l0']:+.2%}, wob {err['wob']:+.2%} "
          f"({'within' if max(map(abs, err.values())) <= 0.05 else 'NOT within'} 5 %); "
          f"{time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
