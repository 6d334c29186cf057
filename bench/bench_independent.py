"""Time writing the blind benchmark's independent campaigns (write only, no diagnosis).

The independent generator (``vadsim.blind.independent``) integrates MODEL.md's model with
SciPy's LSODA and a Python right-hand side, so writing its campaigns costs seconds per event
where vadsim's core takes a fraction of a second. This script writes the campaigns of the
``indep_*`` classes (or ``--classes``) into a folder, exactly as ``vadsim blind`` writes them
(same names, seeds and settings), and prints the time of each campaign and the total.

    python bench/bench_independent.py --out /tmp/indep            # the 12 independent ones
    python bench/bench_independent.py --out /tmp/indep --classes indep_null --duration 2

A folder already holding some of them keeps them (their time is then not measured): use a
new folder for a timing.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="folder for the campaigns")
    ap.add_argument("--classes", default=None,
                    help="comma-separated classes (default: every indep_* class)")
    ap.add_argument("--seed", type=int, default=2026, help="benchmark seed (default 2026)")
    ap.add_argument("--duration", type=float, default=None,
                    help="seconds per event (default: each scenario's, 8 s)")
    args = ap.parse_args(argv)

    from vadsim.blind import class_counts, write_campaigns

    classes = (args.classes.split(",") if args.classes
               else [c for c in class_counts() if c.startswith("indep_")])
    stamps = [time.perf_counter()]

    def tick(message: str) -> None:
        stamps.append(time.perf_counter())
        print(f"  {message}", flush=True)

    t0 = time.perf_counter()
    paths = write_campaigns(args.out, classes=classes, seed=args.seed,
                            duration_s=args.duration, progress=tick)
    total = time.perf_counter() - t0
    stamps.append(time.perf_counter())
    per = [b - a for a, b in zip(stamps[1:-1], stamps[2:], strict=True)]
    print(f"{len(paths)} campaigns of {', '.join(classes)} in {args.out}")
    if per:
        print(f"written: {len(per)} in {total:.1f} s; per campaign: median "
              f"{sorted(per)[len(per) // 2]:.1f} s, min {min(per):.1f} s, max {max(per):.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
