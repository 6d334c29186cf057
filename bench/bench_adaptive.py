"""The thesis map by adaptive refinement, against the full grid: runs, time, labels that differ.

The thesis-resolution gap map (gap ratio 85-150 % in 85 steps x excitation 21.3-69.3 Hz in
0.5 Hz steps: 8,245 runs of 400 cycles, ``detail="map"``) once in full and once adaptively
(:class:`vadsim.studies.refine.Refinement`), on the local cores. Prints the fraction of runs
the adaptive map made, both wall times, the regime labels that differ (all of them, and those
more than one grid step from a boundary of the full map, which must be 0), and how far J* and
each row's operating range (J* within 10 % of its maximum) moved.

    python bench/bench_adaptive.py                          # full map, then the adaptive one
    python bench/bench_adaptive.py --full /tmp/full.nc      # reuse (or write) the full map
    python bench/bench_adaptive.py --gap-steps 17 --hz-step 2  # a small smoke run
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from vadsim.studies.refine import Refinement
from vadsim.studies.sweep import flows_from_hz, load_dataset, save_dataset, sweep

TARGET_S = 60.0
"""The issue's budget for the adaptive thesis map on 2 cores."""


def near_boundary(labels: np.ndarray) -> np.ndarray:
    """Points with a differently labelled neighbour (8-neighbourhood) in ``labels``."""
    out = np.zeros(labels.shape, dtype=bool)
    n0, n1 = labels.shape
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            shifted = np.full(labels.shape, np.nan)
            src = labels[max(0, -di):n0 - max(0, di), max(0, -dj):n1 - max(0, dj)]
            shifted[max(0, di):n0 - max(0, -di), max(0, dj):n1 - max(0, -dj)] = src
            out |= np.isfinite(shifted) & (shifted != labels)
    return out


def operating_range(j: np.ndarray, flows: np.ndarray, fraction: float = 0.9) -> np.ndarray:
    """Per row, the flow span (gal/min) where J* is within ``1 - fraction`` of its maximum."""
    out = np.zeros(j.shape[0])
    for i, row in enumerate(j):
        ok = np.flatnonzero(row >= fraction * np.nanmax(row))
        out[i] = flows[ok.max()] - flows[ok.min()] if ok.size else 0.0
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gap-steps", type=int, default=85)
    ap.add_argument("--hz-step", type=float, default=0.5)
    ap.add_argument("--cycles", type=float, default=400)
    ap.add_argument("--coarse", type=int, default=16)
    ap.add_argument("--j-tol", type=float, default=None,
                    help="refine where corner J* differ by more than this fraction of the max")
    ap.add_argument("--range-edge", action="store_true",
                    help="also refine at the operating range's edge")
    ap.add_argument("--halo", type=int, default=1)
    ap.add_argument("--full", type=Path, default=None,
                    help="the full map's NetCDF: read if it exists, else written there")
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args()
    preset = "7in-cde"
    flows = flows_from_hz(preset, np.arange(21.3, 69.3 + 1e-9, args.hz_step))
    axes = {"gap_ratio": np.linspace(0.85, 1.5, args.gap_steps)}
    kw = dict(cycles=args.cycles, analyse_cycles=args.cycles / 2, detail="map",
              workers=args.workers)
    n = flows.size * args.gap_steps
    full_s = None
    if args.full is not None and args.full.exists():
        full = load_dataset(args.full)
        print(f"full map: read {args.full}")
    else:
        t0 = time.perf_counter()
        full = sweep(preset, flows, axes, **kw)
        full_s = time.perf_counter() - t0
        print(f"full map: {n} runs in {full_s:.1f} s")
        if args.full is not None:
            save_dataset(full, args.full)
    rule = Refinement(coarse=args.coarse, j_tol=args.j_tol,
                      range_edge=args.range_edge, halo=args.halo)
    t0 = time.perf_counter()
    ad = sweep(preset, flows, axes, refine=rule, **kw)
    ad_s = time.perf_counter() - t0
    ran = int(ad["simulated"].sum())
    f, a = full["scenario"].values, ad["scenario"].values
    diff = f != a
    outside = diff & ~near_boundary(f.astype(float))
    jf, ja = full["j_pos"].values, ad["j_pos"].values
    rf, ra = operating_range(jf, flows), operating_range(ja, flows)
    print(f"adaptive map ({rule}): {ran} of {n} runs ({ran / n:.1%}) in {ad_s:.1f} s"
          + (f" ({full_s / ad_s:.1f}x faster than the full map)" if full_s else "")
          + f"; budget {TARGET_S:.0f} s on 2 cores")
    print(f"regime labels that differ: {int(diff.sum())} of {n}; more than one grid step "
          f"from a boundary: {int(outside.sum())} (must be 0)")
    print(f"J*: largest difference {np.nanmax(np.abs(ja - jf)):.1f} N/kg (map max "
          f"{np.nanmax(jf):.0f}); median {np.nanmedian(np.abs(ja - jf)):.2f} N/kg")
    print(f"operating range per gap ratio: largest difference {np.max(np.abs(ra - rf)):.1f} "
          f"gal/min, {int(np.sum(ra != rf))} of {len(rf)} rows differ")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
