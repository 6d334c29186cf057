"""Time a full diagnosis of a 10-event campaign (target: at most 10 minutes on 2 cores).

Writes a 10-event 7in campaign (200-650 gal/min, 8 s per event, 0.3 g noise) with a
concealed hydraulic force on the anvil (c = 4e-4 N/kg per (gal/min)^2), loads it back from
disk and runs ``vadsim.diagnose.diagnose`` with every candidate and the default settings.

    python bench/bench_diagnose.py [--effect none]
"""

from __future__ import annotations

import argparse
import tempfile
import time

from vadsim.candidates import CANDIDATES
from vadsim.diagnose import diagnose
from vadsim.recordings import load_campaign, save_campaign
from vadsim.synthetic import synthetic_campaign

FLOWS = (200.0, 250.0, 300.0, 350.0, 400.0, 450.0, 500.0, 550.0, 600.0, 650.0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--effect", default="hydraulic", choices=["hydraulic", "none"])
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args()
    extras = []
    if args.effect == "hydraulic":
        extras = CANDIDATES["hydraulic_force[anvil]"].change({"c": 4.0e-4}).extras
    camp = synthetic_campaign("7in-cde", FLOWS, extras=extras, cycles=300, analyse_cycles=200,
                              duration_s=8.0, noise_g=0.3, seed=7, name="bench-10")
    with tempfile.TemporaryDirectory() as tmp:
        camp = load_campaign(save_campaign(camp, tmp + "/camp"))
        t0 = time.perf_counter()
        d = diagnose(camp, workers=args.workers, progress=lambda m: print(" ", m, flush=True))
        dt = time.perf_counter() - t0
    print(d.summary())
    print(f"diagnosis of {len(camp.events)} events: {dt:.0f} s "
          f"({'within' if dt <= 600 else 'OVER'} the 10-minute target)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
