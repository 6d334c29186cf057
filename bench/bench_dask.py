"""Measure the speed-up of a regime map from 1 to 2 Dask workers on a local cluster.

Why this benchmark: the issue asks that a map given a Dask scheduler address runs on that
cluster unchanged, and for a measured speed-up from 1 to 2 workers. This script starts a
``LocalCluster`` of worker processes (one thread each, so a worker is one core), runs the same
small map through :func:`vadsim.studies.sweep.sweep` with ``scheduler=`` its address, then
repeats with 2 workers, and prints both wall times, the speed-up and whether both datasets are
identical (they must be: where a point runs cannot change its numbers).

Workers import vadsim before the clock starts, so the times are the map's, not start-up's.

    python bench/bench_dask.py                          # 4 gap values x 24 flows, 400 cycles
    python bench/bench_dask.py --workers 1 2 4          # also 4 workers on the 2 cores
    python bench/bench_dask.py --gap-steps 2 --flows 6  # smoke test
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence

import numpy as np
import xarray as xr
from vadsim.studies.sweep import sweep


def _warm_up() -> str:
    """Import the model on a worker (run through ``Client.run``) so it is not timed."""
    import vadsim.studies.sweep

    return vadsim.studies.sweep.__name__


def _rss_mb() -> float:
    """A worker's resident memory (MB), read from /proc (run through ``Client.run``)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def time_map(n_workers: int, flows: np.ndarray, gaps: np.ndarray, cycles: float,
             analyse_cycles: float, preset: str, progress: bool
             ) -> tuple[float, xr.Dataset, float]:
    """Wall time of the map on a fresh local cluster of ``n_workers`` single-thread processes,
    the dataset, and the largest worker's resident memory (MB) after it."""
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.wait_for_workers(n_workers)
        client.run(_warm_up)
        t0 = time.perf_counter()
        ds = sweep(preset, flows, {"gap_ratio": gaps}, cycles=cycles,
                   analyse_cycles=analyse_cycles, scheduler=cluster.scheduler_address,
                   progress=progress, detail="map")
        wall = time.perf_counter() - t0
        rss = max(client.run(_rss_mb).values())
        return wall, ds, rss


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="7in-cde")
    ap.add_argument("--gap-steps", type=int, default=4, help="gap-ratio values in 0.85-1.50")
    ap.add_argument("--flows", type=int, default=24, help="flow rates in 200-600 gal/min")
    ap.add_argument("--flow-min", type=float, default=200.0)
    ap.add_argument("--flow-max", type=float, default=600.0)
    ap.add_argument("--cycles", type=float, default=400)
    ap.add_argument("--analyse-cycles", type=float, default=None,
                    help="steady window (default: half of --cycles)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2],
                    help="cluster sizes to time, in order (default: 1 2)")
    ap.add_argument("--progress", action="store_true", help="show the sweep's progress bar")
    args = ap.parse_args(argv)
    if args.gap_steps < 1 or args.flows < 1 or args.cycles <= 0:
        ap.error("--gap-steps and --flows must be >= 1, --cycles > 0")
    if any(n < 1 for n in args.workers):
        ap.error("--workers must be >= 1")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    analyse = args.analyse_cycles if args.analyse_cycles is not None else args.cycles / 2
    flows = np.linspace(args.flow_min, args.flow_max, args.flows)
    gaps = np.linspace(0.85, 1.50, args.gap_steps)
    n_runs = flows.size * gaps.size
    print(f"{args.preset}: {gaps.size} gap ratios x {flows.size} flows "
          f"({flows[0]:g}-{flows[-1]:g} gal/min) = {n_runs} runs of {args.cycles:g} cycles, "
          f"Dask LocalCluster (processes, 1 thread each) on {os.cpu_count()} cores", flush=True)
    results: list[tuple[int, float, xr.Dataset]] = []
    cores = os.cpu_count() or 1
    for n in args.workers:
        wall, ds, rss = time_map(n, flows, gaps, args.cycles, analyse, args.preset,
                                 args.progress)
        results.append((n, wall, ds))
        # workers beyond the cores share them: a worker's own rate is per busy core
        per_worker = n_runs / wall / min(n, cores)
        print(f"{n} worker{'s' if n > 1 else ' '}  {wall:8.2f} s  {n_runs / wall:7.2f} runs/s  "
              f"{per_worker:6.2f} runs/s per busy core  worker memory {rss:5.0f} MB",
              flush=True)
    best = max(n_runs / wall / min(n, cores) for n, wall, _ in results)
    print(f"a 100-worker cluster at this per-core rate: {100 * best:.0f} runs/s, the 8,245-run "
          f"thesis map in {8245 / (100 * best):.1f} s (chunks of 8 runs: "
          f"{100 * best / 8:.0f} tasks/s for the scheduler)")
    n0, t0, ds0 = results[0]
    same = True
    for n, wall, ds in results[1:]:
        identical = ds.identical(ds0)
        same &= identical
        print(f"speed-up {n0} -> {n} workers: {t0 / wall:.2f}x "
              f"(ideal {n / n0:g}x; datasets identical: {identical})")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
