"""Agreement of ``steady="auto"`` with the literal run over the whole thesis map.

The steady-state engine stops a run at its confirmed periodic orbit and builds the analysed
window from it. This benchmark runs the thesis-resolution map (gap ratio 85-150 % in 85 steps
x excitation 21.3-69.3 Hz in 0.5 Hz steps: 8,245 points, 400 cycles, 200 analysed) both ways
and reports:

- the points whose impact scenario differs, split by whether the literal run's own window is
  periodic (its Poincare section, ``period`` > 0): the goal is none where it is;
- where the scenario differs, whether two literal runs at rtol 1e-6 and 1e-7 differ there too
  (the point is then sensitive to the integration itself, not to the engine);
- J* and the bit's mean 200 ms peak: median and largest relative difference, over the points
  built from an orbit and over all points;
- how many runs stopped at an orbit, and both maps' wall times.

    python bench/bench_steady.py                              # the whole map, both ways
    python bench/bench_steady.py --gap-steps 5 --hz-step 4    # a smoke test
    python bench/bench_steady.py --full full.nc --auto auto.nc  # reuse saved maps

Maps given with ``--full``/``--auto`` are read if the file exists, else computed and saved
there.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from vadsim.model.regimes import scenario
from vadsim.model.settings import RunSettings
from vadsim.studies.sweep import (
    design_overrides,
    flows_from_hz,
    load_dataset,
    save_dataset,
    sweep,
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="7in-cde")
    ap.add_argument("--gap-steps", type=int, default=85)
    ap.add_argument("--hz-step", type=float, default=0.5)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--full", type=Path, default=None, help="the literal map (read or saved)")
    ap.add_argument("--auto", type=Path, default=None, help="the steady=auto map (read or saved)")
    ap.add_argument("--no-recheck", action="store_true",
                    help="skip the rtol 1e-7 reruns where the scenarios differ")
    return ap.parse_args(argv)


def _map(args: argparse.Namespace, steady: str, path: Path | None) -> tuple[xr.Dataset, float]:
    if path is not None and path.exists():
        return load_dataset(path), float("nan")
    hz = np.arange(21.3, 69.3 + 1e-9, args.hz_step)
    flows = flows_from_hz(args.preset, hz)
    gaps = np.linspace(0.85, 1.50, args.gap_steps)
    settings = RunSettings(args.preset, cycles=400, analyse_cycles=200, steady=steady)
    t0 = time.perf_counter()
    ds = sweep(None, flows, {"gap_ratio": gaps}, settings=settings, detail="map",
               workers=args.workers, progress=True)
    wall = time.perf_counter() - t0
    if path is not None:
        save_dataset(ds, path)
    return ds, wall


def _rel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(a - b) / np.abs(b)


def _stats(name: str, rel: np.ndarray) -> str:
    rel = rel[np.isfinite(rel)]
    if not rel.size:
        return f"{name}: no points"
    return (f"{name}: median {np.median(rel):.1e}, 99th percentile {np.percentile(rel, 99):.1e}, "
            f"max {rel.max():.1e} over {rel.size} points")


def _recheck(args: argparse.Namespace, full: xr.Dataset, cells: list[tuple[int, int]]
             ) -> list[dict[str, Any]]:
    """The literal run at rtol 1e-7 at each differing point: its scenario against the
    literal run's at 1e-6."""
    out = []
    base = RunSettings(args.preset, cycles=400, analyse_cycles=200, steady="full", rtol=1e-7)
    params = dict(base.preset.params)
    for i, j in cells:
        gap = float(full["gap_ratio"][i])
        flow = float(full["flow_gpm"][j])
        s = base.with_changes(overrides=design_overrides(params, {"gap_ratio": gap}, "spring"))
        r = s.run(flow, record="none", summary_rate_hz=5000.0, atol=1e-9)
        z = r.z
        out.append({"gap": gap, "flow": flow, "scenario_1e-7": scenario(z["spring"], z["impact"]),
                    "scenario_1e-6": int(full["scenario"][i, j])})
    return out


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    full, t_full = _map(args, "full", args.full)
    auto, t_auto = _map(args, "auto", args.auto)
    n = full["scenario"].size
    print(f"\n{n} points; wall time literal {t_full:.1f} s, steady=auto {t_auto:.1f} s")
    stopped = auto["steady_period"].to_numpy() > 0
    print(f"runs built from an orbit: {int(stopped.sum())} ({stopped.mean():.0%})")
    diff = full["scenario"].to_numpy() != auto["scenario"].to_numpy()
    periodic = full["period"].to_numpy() > 0
    print(f"scenario differs at {int(diff.sum())} points: {int((diff & periodic).sum())} where "
          f"the literal window is periodic ({int(periodic.sum())} such points), "
          f"{int((diff & ~periodic).sum())} where it is not")
    cells = [tuple(int(v) for v in c) for c in np.argwhere(diff)]
    if cells and not args.no_recheck:
        checks = _recheck(args, full, cells)
        sensitive = sum(c["scenario_1e-7"] != c["scenario_1e-6"] for c in checks)
        print(f"  of those, the literal runs at rtol 1e-6 and 1e-7 differ at {sensitive} of "
              f"{len(checks)}")
        for c in checks:
            print(f"    gap {c['gap']:.3f} flow {c['flow']:.1f}: literal 1e-6 scenario "
                  f"{c['scenario_1e-6']}, 1e-7 {c['scenario_1e-7']}")
    for name in ("j_pos", "x1_peak_mean_g", "x5_peak_mean_g"):
        rel = _rel(auto[name].to_numpy(), full[name].to_numpy())
        print(_stats(f"{name} (orbit points)", rel[stopped]))
        print(_stats(f"{name} (all points)", rel))
    return 0


if __name__ == "__main__":
    sys.exit(main())
