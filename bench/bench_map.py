"""Time the thesis-resolution regime map (gap ratio x flow) on the local cores.

Why this benchmark: the issue asks for the dissertation's chapter 5 map at its resolution --
gap ratio 85-150 % in 85 steps x excitation 21.3-69.3 Hz in 0.5 Hz steps, 97 x 85 = 8,245
runs of 400 cycles -- in at most 5 minutes on a 2-core machine. This script runs exactly
that map through :func:`vadsim.studies.sweep.sweep` (threads, a fresh resumable store, progress bar)
and prints the wall time, the throughput and the median time of one run, so the number quoted
in the note can be re-measured. Smaller grids (``--gap-steps 3 --hz-step 4``) smoke-test it.

Per-run times are measured by wrapping the ``simulate`` that ``RunSettings.run`` calls (the one
way the sweep starts a run; in-process, thread-safe), so they are real single-run times, not
chunk averages.

    python bench/bench_map.py                        # the full 8,245-run map
    python bench/bench_map.py --steady full          # every cycle of every run integrated
    python bench/bench_map.py --mode continuation    # each flow from the previous one's state
    python bench/bench_map.py --gap-steps 3 --hz-step 4 --out /tmp/map.nc

Runs stop at their periodic orbit (``--steady auto``, the default) unless ``--steady full``;
the summary line says how many did.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import vadsim.model.settings as vsettings
from vadsim.model.settings import RunSettings
from vadsim.studies.sweep import GAP_REALISATIONS, flows_from_hz, save_dataset, sweep

TARGETS_S = {"independent": 100.0, "continuation": 60.0}
"""The budgets for the full thesis-resolution map: every point from rest, and in
continuation mode."""


def _timed(fn: Callable[..., Any], times: list[float], lock: threading.Lock
           ) -> Callable[..., Any]:
    """Wrap ``fn`` so that every call's wall time is appended to ``times`` (except sweep's
    one-cycle validation probe, which is not a map point)."""

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            dt = time.perf_counter() - t0
            if kwargs.get("cycles") != 1:
                with lock:
                    times.append(dt)

    return wrapper


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="7in-cde")
    ap.add_argument("--gap-steps", type=int, default=85,
                    help="gap-ratio values in [gap-min, gap-max] (thesis: 85)")
    ap.add_argument("--gap-min", type=float, default=0.85)
    ap.add_argument("--gap-max", type=float, default=1.50)
    ap.add_argument("--hz-min", type=float, default=21.3)
    ap.add_argument("--hz-max", type=float, default=69.3)
    ap.add_argument("--hz-step", type=float, default=0.5,
                    help="excitation-frequency step in Hz (thesis: 0.5)")
    ap.add_argument("--cycles", type=float, default=400, help="run length (thesis: 400)")
    ap.add_argument("--analyse-cycles", type=float, default=None,
                    help="steady window (default: half of --cycles, as in the thesis)")
    ap.add_argument("--workers", type=int, default=None, help="threads (default: all cores)")
    ap.add_argument("--gap-via", choices=GAP_REALISATIONS, default="spring")
    ap.add_argument("--detail", choices=("map", "full"), default="map",
                    help="labels per run: 'map' (regimes, J*; the map's needs) or 'full'")
    ap.add_argument("--mode", choices=("independent", "continuation"), default="independent")
    ap.add_argument("--steady", choices=("auto", "full"), default="auto",
                    help="stop each run at its periodic orbit (auto) or integrate every cycle")
    ap.add_argument("--settle", type=float, default=None,
                    help="continuation mode: cycles a continued point settles before its "
                         "window (default: the sweep's CONTINUATION_SETTLE_CYCLES)")
    ap.add_argument("--store", type=Path, default=None,
                    help="keep chunks here (resumable; only missing points are timed). "
                         "Default: a fresh temporary folder, deleted afterwards")
    ap.add_argument("--out", type=Path, default=None, help="save the dataset (NetCDF)")
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    if args.gap_steps < 1 or args.hz_step <= 0 or args.cycles <= 0:
        ap.error("--gap-steps must be >= 1, --hz-step and --cycles > 0")
    if args.workers is not None and args.workers < 1:
        ap.error("--workers must be >= 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    analyse = args.analyse_cycles if args.analyse_cycles is not None else args.cycles / 2
    hz = np.arange(args.hz_min, args.hz_max + 1e-9, args.hz_step)
    flows = flows_from_hz(args.preset, hz)
    gaps = np.linspace(args.gap_min, args.gap_max, args.gap_steps)
    n_runs = flows.size * gaps.size
    workers = args.workers or os.cpu_count() or 1
    print(f"{args.preset}: {gaps.size} gap ratios {gaps[0]:.2f}-{gaps[-1]:.2f} "
          f"(via {args.gap_via}) x {flows.size} flows {hz[0]:.1f}-{hz[-1]:.1f} Hz "
          f"({flows[0]:.1f}-{flows[-1]:.1f} gal/min) = {n_runs} runs of {args.cycles:g} "
          f"cycles ({analyse:g} analysed), {args.mode}, steady={args.steady}, {workers} "
          f"threads on {os.cpu_count()} cores", flush=True)

    times: list[float] = []
    lock = threading.Lock()
    real_simulate = vsettings.simulate
    vsettings.simulate = _timed(real_simulate, times, lock)
    tmp = None
    store = args.store
    if store is None:
        tmp = tempfile.mkdtemp(prefix="vadsim-bench-map-")
        store = Path(tmp)
    try:
        t0 = time.perf_counter()
        settings = RunSettings(args.preset, cycles=args.cycles, analyse_cycles=analyse,
                               steady=args.steady)
        ds = sweep(None, flows, {"gap_ratio": gaps}, settings=settings,
                   gap_via=args.gap_via, mode=args.mode, workers=args.workers, store=store,
                   progress=not args.no_progress, detail=args.detail,
                   settle_cycles=args.settle if args.mode == "continuation" else None)
        wall = time.perf_counter() - t0
    finally:
        vsettings.simulate = real_simulate
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)

    computed = len(times)
    print(f"wall time        {wall:9.2f} s for {computed} computed runs "
          f"({n_runs - computed} from the store)")
    if computed:
        t = np.asarray(times)
        print(f"throughput       {computed / wall:9.2f} runs/s")
        print(f"per run          median {np.median(t) * 1e3:.1f} ms, "
              f"p10 {np.percentile(t, 10) * 1e3:.1f} ms, p90 {np.percentile(t, 90) * 1e3:.1f} ms,"
              f" sum {t.sum():.1f} s (parallel efficiency {t.sum() / wall / workers:.0%})")
        full = 8245 * wall / computed
        target = TARGETS_S[args.mode]
        print(f"8,245-run map at this rate {full:7.1f} s "
              f"({'within' if full <= target else 'OVER'} the {target:.0f} s budget of "
              f"{args.mode} mode)")
    failed = int((ds["error"] != "").sum())
    counts = {int(s): int((ds["scenario"] == s).sum()) for s in np.unique(ds["scenario"])}
    print(f"failed runs      {failed}")
    print(f"scenarios        {counts}")
    print(f"CVODE steps      {int(ds['steps'].sum())} total")
    stopped = int((ds["steady_period"] > 0).sum())
    print(f"stopped at orbit {stopped} of {ds['steady_period'].size} runs "
          f"({stopped / ds['steady_period'].size:.0%})")
    if args.out is not None:
        print(f"saved            {save_dataset(ds, args.out)}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
