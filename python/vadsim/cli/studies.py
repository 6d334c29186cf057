"""Commands over many runs: ``sweep`` (flow axis), ``map`` (flow x parameters), ``design``
(the dissertation's design studies and an optimiser), ``thesis`` (every published number
against vadsim's, REPRODUCTION.md) and ``constants`` (the scan of theta0 and the gap).

Why this module exists: these commands share the flow axis, the resumable store, the NetCDF
output and the figures; the study code itself lives in ``vadsim.studies``. The heavy modules
(xarray, dask, matplotlib) are imported inside the handlers so ``vadsim run`` stays quick.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from vadsim.cli.common import (
    DEFAULT_PRESET,
    Parents,
    Subparsers,
    arange,
    figure_file,
    figure_path,
    pandas_display,
    parse_overrides,
)
from vadsim.model.presets import PRESETS, get_preset

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["add_parsers"]

_GAP_VIA = ["spring", "anvil", "housing"]
_MODES = ["independent", "continuation"]


def add_parsers(sub: Subparsers, parents: Parents) -> None:
    """Add ``sweep``, ``map``, ``design``, ``thesis`` and ``constants`` to the ``vadsim``
    sub-commands."""
    sw = sub.add_parser(
        "sweep", help="flow sweep: labels at every flow, regimes along flow, NetCDF",
        description="Run the model at every flow of an axis (in parallel, resumable with "
        "--store) and print Z per surface, scenario, peaks, J*, impact frequency and "
        "periodicity per flow, then the regime intervals along flow.",
        parents=_grid_parents(parents),
    )
    _add_grid_options(sw)
    sw.set_defaults(func=_cmd_sweep)
    _add_map(sub, parents)
    _add_design(sub, parents)
    th = sub.add_parser(
        "thesis", help="every number the dissertation publishes, vadsim's value, and why a "
        "miss is a miss (REPRODUCTION.md)",
        description="Run what the dissertation's published numbers need (the 7in CDE and RC "
        "flow sweeps, the 9.5in events, the design studies) for the reference preset and "
        "the thesis preset, and list each published number once with vadsim's values, the "
        "tolerance, a status and, for each miss, its measured reason (from a constants scan, "
        "--scan).",
        epilog="example: vadsim constants --out scan/ && vadsim thesis --scan scan/ --out "
        "repro/ (the report alone: about 2 min on 2 cores)",
        parents=[parents.length, *parents.execution],
    )
    th.add_argument("--reference", default="7in-cde",
                    help="the reference 7in CDE preset (default 7in-cde)")
    th.add_argument("--thesis-preset", default="7in-cde-thesis",
                    help="the preset with the scan's constants (default 7in-cde-thesis; "
                    "'none' to leave it out)")
    th.add_argument("--scan", default=None, metavar="DIR",
                    help="a vadsim constants output folder: the reasons of the misses are "
                    "measured on its scores, its maps go into the report")
    th.add_argument("--out", default=None, metavar="DIR",
                    help="write REPRODUCTION.md, reproduction.csv and the figures there")
    th.add_argument("--maps", default=None, metavar="DIR",
                    help="run (or read) chapter 5's gap and spring maps per preset in DIR and "
                    "measure the dissertation's regime counts on them (about 17,500 runs a "
                    "preset, resumable; a second call reads them)")
    th.add_argument("--spring-steps", type=int, default=None, metavar="N",
                    help="kS values of the spring map (default 96; the published step "
                    "gives 948)")
    th.set_defaults(func=_cmd_thesis)
    _add_constants(sub, parents)


def _add_constants(sub: Subparsers, parents: Parents) -> None:
    co = sub.add_parser(
        "constants", help="scan theta0 and the gap against every published target (maps)",
        description="The excitation phase at rest theta0 and the anvil-spring gap are not "
        "fixed by the published lengths (MODEL.md). Sweep flow over a grid of both, score the "
        "regime bands, the CDE and RC peaks and the design studies' J* ratios at each point, "
        "and write the maps, the scores and the best point (the *-thesis presets' constants).",
        epilog="example: vadsim constants --out scan/ (22 min on 2 cores); then around its "
        "best point: vadsim constants --theta0 2.30 2.65 0.025 --gap 0.8 1.1 0.05 "
        "--no-designs --out fine/ (7 min)",
        parents=[parents.length, *parents.execution],
    )
    co.add_argument("preset", nargs="?", default=DEFAULT_PRESET,
                    help=f"the CDE preset whose constants are scanned (default {DEFAULT_PRESET})")
    th = co.add_mutually_exclusive_group()
    th.add_argument("--theta0-steps", type=int, default=24,
                    help="phases at rest over [0, pi) (default 24: 0.13 rad apart)")
    th.add_argument("--theta0", type=float, nargs=3, metavar=("FROM", "TO", "STEP"),
                    help="phases at rest from-to-step instead (rad), to refine a region")
    co.add_argument("--gap", type=float, nargs=3, metavar=("FROM", "TO", "STEP"),
                    default=[0.6, 1.4, 0.1], help="gap ratios (default 0.6 1.4 0.1)")
    co.add_argument("--design-every", type=int, default=2,
                    help="design sweeps on every n-th theta0 and gap (default 2)")
    co.add_argument("--no-designs", action="store_true", help="skip the J* ratio targets")
    co.add_argument("--out", required=True, help="folder for scan.nc, scores.csv, "
                    "summary.csv, best.json, constants-maps.png, target-maps.png")
    co.set_defaults(func=_cmd_constants)


def _grid_parents(parents: Parents) -> list[argparse.ArgumentParser]:
    return [parents.length, parents.overrides, parents.load, *parents.execution]


def _add_grid_options(p: argparse.ArgumentParser, detail: str = "full") -> None:
    p.add_argument("preset", nargs="?", default=DEFAULT_PRESET,
                   help="tool preset: " + ", ".join(PRESETS) + f" (default {DEFAULT_PRESET})")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--flows", type=float, nargs=3, metavar=("FROM", "TO", "STEP"),
                   default=[200.0, 650.0, 10.0],
                   help="flow axis in gal/min (default 200 650 10)")
    g.add_argument("--hz", type=float, nargs=3, metavar=("FROM", "TO", "STEP"),
                   help="flow axis given as excitation frequency in Hz, e.g. 21.3 69.3 0.5")
    p.add_argument("--mode", default="independent", choices=_MODES,
                   help="independent: every run from rest; continuation: each flow starts "
                   "from the previous flow's final state, as in a field flow sweep")
    _add_gap_via(p)
    p.add_argument("--detail", default=detail, choices=["full", "map"],
                   help="full: every label (peaks and J* at 20 kHz, impact frequency); map: "
                   f"regimes, J*, periodicity only, ~25 %% faster (default {detail})")
    p.add_argument("--store", default=None,
                   help="folder of finished chunks: an interrupted run resumes from it")
    p.add_argument("--out", default=None, help="save the dataset to this NetCDF file")
    _add_plot_option(p)
    p.add_argument("--json", action="store_true", help="print JSON records")


def _add_gap_via(p: argparse.ArgumentParser) -> None:
    p.add_argument("--gap-via", default="spring", choices=_GAP_VIA,
                   help="which length realises a gap change (default spring)")


def _add_plot_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--plot", default=None, metavar="FILE", type=figure_file,
                   help="also draw the figures: FILE.png (or .pdf, .svg) names them, "
                   "e.g. FILE-peaks.png, FILE-j.png")


def _add_map(sub: Subparsers, parents: Parents) -> None:
    mp = sub.add_parser(
        "map", help="2-D map over flow and a parameter (or two): regimes and J*",
        description="Run the model over flow x one or two parameters. Parameters are Table "
        "2.1 names (see 'vadsim presets 7in-cde') or gap_ratio / gap. Example (the "
        "dissertation's gap map): vadsim map --param gap_ratio --values 0.85 1.5 --steps 85 "
        "--hz 21.3 69.3 0.5 --out gap.nc --store gap.parts",
        parents=_grid_parents(parents),
    )
    _add_grid_options(mp, detail="map")
    mp.add_argument("--param", required=True, help="design parameter of the map")
    mp.add_argument("--values", type=float, nargs="+", required=True,
                    metavar="V", help="FROM TO (with --steps) or FROM TO STEP")
    mp.add_argument("--steps", type=int, default=None, help="number of parameter values")
    mp.add_argument("--param2", default=None, help="optional second parameter")
    mp.add_argument("--values2", type=float, nargs=2, metavar=("FROM", "TO"))
    mp.add_argument("--steps2", type=int, default=5)
    mp.add_argument("--adaptive", action="store_true",
                    help="run a coarse lattice, then refine only where regimes (or the "
                    "operating range's edge, or J*: see below) change between neighbours; the rest "
                    "is filled from the agreeing cell around it (variable 'simulated')")
    mp.add_argument("--coarse", type=int, default=16,
                    help="adaptive: stride of the first lattice, a power of two (16)")
    mp.add_argument("--range-edge", action="store_true",
                    help="adaptive: also refine where the operating range (J* within 10 %% of "
                    "its row's best) begins or ends")
    mp.add_argument("--j-tol", type=float, default=None,
                    help="adaptive: also refine where J* differs by more than this fraction "
                    "of the map's max between neighbours (default: off)")
    mp.set_defaults(func=_cmd_map)


def _add_design(sub: Subparsers, parents: Parents) -> None:
    de = sub.add_parser(
        "design", help="the dissertation's design studies, its recommended design, or an "
        "optimisation of kS, gap and Fo together",
        description="spring / gap / force: one-at-a-time map over the published range "
        "(parametric.csv) with J* maximum and operating range per value. recommended: the "
        "dissertation's recommended design vs the original (Fig. 5.7). optimise: "
        "differential evolution over kS, gap ratio and Fo within the published ranges, "
        "maximising J* and the operating range (J* within 10 %% of its maximum). robust: the "
        "original, the dissertation's recommendation and a robust optimum (the mean score "
        "over a sample of the plausible theta0 and gap) compared by the mean and worst case "
        "of max J* and operating range over that sample.",
        parents=[parents.length, *parents.execution],
    )
    de.add_argument("study", choices=["spring", "gap", "force", "recommended", "optimise",
                                      "robust"])
    de.add_argument("preset", nargs="?", default=DEFAULT_PRESET)
    de.add_argument("--steps", type=int, default=21, help="parameter values of a study (21)")
    _add_gap_via(de)
    de.add_argument("--popsize", type=int, default=6, help="optimise: population factor (6)")
    de.add_argument("--maxiter", type=int, default=8, help="optimise: generations (8)")
    de.add_argument("--seed", type=int, default=1, help="optimise: random seed (1)")
    de.add_argument("--sample", type=int, default=None, choices=[1, 5, 9],
                    help="judge every design over this many points of the plausible "
                    "(theta0, gap) region: mean and worst case; 'optimise --sample N' "
                    "maximises the robust objective, as 'robust' does (default: robust 5, "
                    "the others at the preset's constants only)")
    de.add_argument("--store", default=None, help="study: resumable chunk folder")
    de.add_argument("--out", default=None, help="save the map (NetCDF) or the designs (CSV)")
    _add_plot_option(de)
    de.set_defaults(func=_cmd_design)


def _flows(args: argparse.Namespace) -> list[float]:
    from vadsim.studies.sweep import flows_from_hz

    if args.hz:
        lo, hi, step = args.hz
        return [float(q) for q in flows_from_hz(args.preset, arange(lo, hi, step, flag="--hz"))]
    lo, hi, step = args.flows
    return [float(q) for q in arange(lo, hi, step, flag="--flows")]


def _sweep_options(args: argparse.Namespace) -> dict[str, Any]:
    return dict(
        overrides=parse_overrides(args.set), law=args.law, wob_klbf=args.wob_klbf,
        cycles=args.cycles, analyse_cycles=args.analyse, mode=args.mode, gap_via=args.gap_via,
        workers=args.workers, scheduler=args.scheduler, store=args.store,
        progress=not args.quiet, detail=args.detail,
    )


def _finish_dataset(ds: Any, args: argparse.Namespace) -> None:
    from vadsim.studies.sweep import save_dataset

    if args.out:
        save_dataset(ds, args.out)
        print(f"saved {args.out}")


def _draw(ds: Any, base: str, figures: dict[str, Callable[..., Figure]]) -> list[str]:
    """Draw each figure of ``ds`` to ``figure_path(base, kind)``; the files written."""
    paths = []
    for kind, fn in figures.items():
        path = figure_path(base, kind)
        fn(ds, path=path)
        paths.append(path)
    return paths


def _cmd_sweep(args: argparse.Namespace) -> int:
    from vadsim.studies import thesis
    from vadsim.studies.sweep import sweep

    t0 = time.perf_counter()
    ds = sweep(args.preset, _flows(args), **_sweep_options(args))
    elapsed = time.perf_counter() - t0
    _finish_dataset(ds, args)
    df = ds[["f_exc_hz", "z_spring", "z_impact", "z_off_bottom", "z_on_bottom", "scenario",
             "x1_peak_mean_g", "x1_peak_std_g", "x5_peak_mean_g", "j_pos", "j_pos_kN",
             "x1_impact_hz", "periodicity"]].to_dataframe()
    if args.json:
        print(df.reset_index().to_json(orient="records"))
        return 0
    with pandas_display():
        print(df.round(3).to_string())
    print(f"{ds.sizes['flow_gpm']} runs in {elapsed:.1f} s ({ds.attrs['mode']} mode)")
    print("\nregimes along flow:")
    print(thesis.regime_intervals(ds).to_string(index=False))
    if args.plot:
        from vadsim import plots

        figures: dict[str, Callable[..., Figure]] = {
            "peaks": plots.peaks_vs_flow, "z": plots.z_vs_flow, "j": plots.j_vs_flow}
        for path in _draw(ds, args.plot, figures):
            print(f"figure {path}")
    return 0


def _cmd_map(args: argparse.Namespace) -> int:
    from vadsim.studies.sweep import sweep

    need = 3 if args.steps is None else 2
    if len(args.values) != need:
        raise ValueError(f"--values {' '.join(f'{v:g}' for v in args.values)}: expected "
                         + ("FROM TO STEP (or FROM TO with --steps)" if need == 3
                            else "FROM TO with --steps"))
    axes = {args.param: arange(*args.values, flag="--values") if args.steps is None
            else list(np.linspace(args.values[0], args.values[1], args.steps))}
    if args.param2:
        axes[args.param2] = list(np.linspace(args.values2[0], args.values2[1], args.steps2))
    refine = None
    if args.adaptive:
        from vadsim.studies.refine import Refinement

        refine = Refinement(coarse=args.coarse, j_tol=args.j_tol, range_edge=args.range_edge)
    t0 = time.perf_counter()
    ds = sweep(args.preset, _flows(args), axes, refine=refine, **_sweep_options(args))
    elapsed = time.perf_counter() - t0
    _finish_dataset(ds, args)
    if args.json:  # one record per point, as 'sweep --json' gives
        names = ["z_spring", "z_impact", "z_off_bottom", "z_on_bottom", "scenario", "j_pos",
                 "j_pos_kN", "x1_peak_mean_g", "periodicity"]
        names += ["simulated"] if "simulated" in ds else []
        df = ds[names].to_dataframe()
        print(df.reset_index().to_json(orient="records"))
        return 0
    n = int(np.prod([ds.sizes[d] for d in ds.scenario.dims]))
    if refine is not None:
        ran = int(ds["simulated"].sum())
        print(f"{ran} of {n} points run ({ran / n:.1%}), the rest filled, in {elapsed:.1f} s")
    else:
        print(f"{n} runs in {elapsed:.1f} s ({n / elapsed:.1f} runs/s)")
    counts = {int(k): int(v) for k, v in zip(*np.unique(ds.scenario.values,
                                                         return_counts=True), strict=True)}
    print("scenario counts:", ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
    k = np.unravel_index(int(np.nanargmax(ds.j_pos.values)), ds.j_pos.shape)
    best = {d: float(ds[d].values[i]) for d, i in zip(ds.j_pos.dims, k, strict=True)}
    print(f"max J* {float(ds.j_pos.values[k]):.2f} N/kg at {best}")
    if args.plot and not args.param2:
        from vadsim import plots

        paths = _draw(ds, args.plot, {"regimes": plots.regime_map, "j": plots.j_map})
        print("figures " + ", ".join(paths))
    return 0


def _cmd_design(args: argparse.Namespace) -> int:
    from vadsim.studies import design

    if args.study == "robust" or (args.study == "optimise" and args.sample is not None):
        return _design_robust(args)  # an optimisation over the sample is the robust one
    if args.sample is not None and args.study != "optimise":
        return _design_over_sample(args)
    if args.study in design.STUDIES:
        return _design_study(args)
    if args.study == "recommended":
        res = design.compare_designs(
            design.RECOMMENDED, args.preset, gap_via=args.gap_via, workers=args.workers,
            scheduler=args.scheduler, progress=not args.quiet, cycles=args.cycles,
            analyse_cycles=args.analyse, detail="map")
        _print_design(res)
        if args.plot:
            from vadsim import plots

            plots.design_comparison(res.original, res.changed, path=args.plot)
            print(f"figure {args.plot}")
        return 0
    return _design_optimise(args)


def _design_over_sample(args: argparse.Namespace) -> int:
    """A study or the recommended design, judged over the constants' sample."""
    from vadsim.studies.design import RECOMMENDED
    from vadsim.studies.robust import constants_sample, robust_compare, robust_study

    sample = constants_sample(args.preset, args.sample)
    kw = dict(cycles=args.cycles, analyse_cycles=args.analyse, workers=args.workers,
              detail="map")
    if args.study == "recommended":
        table = robust_compare({"recommended": RECOMMENDED}, args.preset, sample, **kw).table
    else:
        table = robust_study(args.study, args.preset, args.steps, sample, **kw)
    print(f"over {len(sample)} points of the plausible (theta0, gap) region of {args.preset}; "
          "J* in N/kg (kN with the m* shown)")
    with pandas_display():
        print(table.round(3).to_string())
    if args.out:
        table.to_csv(args.out)
        print(f"wrote {args.out}")
    return 0


def _design_robust(args: argparse.Namespace) -> int:
    from vadsim.studies.design import RECOMMENDED
    from vadsim.studies.robust import (
        GAP_SPREAD,
        THETA0_SPREAD,
        constants_sample,
        robust_compare,
        robust_optimise,
    )

    t0 = time.perf_counter()

    def report(n: int, score: float, d: dict) -> None:
        if not args.quiet and n % 10 == 0:
            print(f"  {n} designs, last score {score:.3f}", flush=True)

    n_sample = args.sample or 5
    best, history = robust_optimise(args.preset, n_sample, popsize=args.popsize,
                                    maxiter=args.maxiter, seed=args.seed, workers=args.workers,
                                    callback=report)
    res = robust_compare({"recommended": RECOMMENDED, "robust optimum": best}, args.preset,
                         constants_sample(args.preset, n_sample), cycles=args.cycles,
                         analyse_cycles=args.analyse, workers=args.workers, detail="map")
    print(f"{len(res.sample)} constants: theta0 +-{THETA0_SPREAD} rad, gap x(1 +-{GAP_SPREAD}) "
          f"around {args.preset}'s; robust objective: mean over them of J*max/J*max0 + "
          "(width + dq)/(width0 + dq) (dq the flow step), each against the original at the "
          "same constants")
    with pandas_display():
        print(res.table.T.round(3).to_string())
    print(f"({len(history)} designs searched; {time.perf_counter() - t0:.0f} s)")
    if args.out:
        res.table.to_csv(args.out)
        print(f"wrote {args.out}")
    return 0


def _design_study(args: argparse.Namespace) -> int:
    from vadsim.studies import design

    ds = design.one_at_a_time(args.study, args.preset, steps=args.steps, gap_via=args.gap_via,
                              store=args.store, workers=args.workers, scheduler=args.scheduler,
                              progress=not args.quiet, cycles=args.cycles,
                              analyse_cycles=args.analyse, detail="map")
    _finish_dataset(ds, args)
    table = design.study_table(ds)
    with pandas_display():
        print(table.round(3).to_string())
    j0 = table["j_max"].iloc[int(np.argmin(np.abs(table.index - _base_value(args))))]
    print(f"max J* over the study: {table['j_max'].max():.2f} N/kg "
          f"({table['j_max'].max() / j0 - 1:+.0%} vs the preset's value)")
    if args.plot:
        from vadsim import plots

        for path in _draw(ds, args.plot, {"regimes": plots.regime_map, "j": plots.j_map}):
            print(f"figure {path}")
    return 0


def _design_optimise(args: argparse.Namespace) -> int:
    from vadsim.studies import design
    from vadsim.studies.sweep import sweep

    def report(gen: int, score: float, best: dict) -> None:
        print(f"  generation {gen}: score {score:.3f} at "
              + ", ".join(f"{k}={v:.4g}" for k, v in best.items()), flush=True)

    opt = design.optimise(args.preset, gap_via=args.gap_via, popsize=args.popsize,
                          maxiter=args.maxiter, seed=args.seed, workers=args.workers,
                          callback=report)
    print(f"best design: {opt.best} (score {opt.score:.3f}, {len(opt.history)} designs, "
          f"{opt.seconds:.0f} s)")
    if opt.verified is not None:
        _print_design(opt.verified)
    if args.plot:
        from vadsim import plots

        if opt.verified is not None:
            plots.design_comparison(opt.verified.original, opt.verified.changed,
                                    labels=("original", "optimised"), path=args.plot)
            print(f"figure {args.plot}")
        # The optimum's map: flow x gap ratio over the published range, kS and Fo optimal.
        fixed = {k: v for k, v in opt.best.items() if k != "gap_ratio"}
        gap_lo, gap_hi = design.STUDIES["gap"].values(2)
        gap_map = sweep(args.preset, design.thesis_flows(args.preset, 1.0),
                        {"gap_ratio": np.linspace(gap_lo, gap_hi, 14)},
                        overrides=fixed, gap_via=args.gap_via, detail="map",
                        workers=args.workers, progress=not args.quiet)
        figures: dict[str, Callable[..., Figure]] = {"map-regimes": plots.regime_map,
                                                     "map-j": plots.j_map}
        for path in _draw(gap_map, args.plot, figures):
            print(f"figure {path}")
    if args.out:
        opt.history.to_csv(args.out, index=False)
        print(f"saved every evaluated design to {args.out}")
    return 0


def _base_value(args: argparse.Namespace) -> float:
    from vadsim.studies import design

    s = design.STUDIES[args.study]
    return 1.0 if s.parameter == "gap_ratio" else get_preset(args.preset).params[s.parameter]


def _print_design(res: Any) -> None:
    m0, m1 = res.metrics_original, res.metrics_changed
    print(f"design {res.design} (gap via {res.gap_via})")
    for name, m in (("original", m0), ("changed", m1)):
        print(f"  {name:9s} max J* {m['j_max']:7.2f} N/kg ({m['j_max_kN']:.3f} kN) at "
              f"{m['flow_at_max_gpm']:.0f} gal/min; operating range {m['range_from_gpm']:.0f}-"
              f"{m['range_to_gpm']:.0f} gal/min; regime 1 up to {m['regime1_edge_gpm']:.0f}")
    print(f"  max J* {res.j_ratio:+.0%}, operating range {res.range_ratio:+.0%}")


def _cmd_constants(args: argparse.Namespace) -> int:
    import json
    import math
    from pathlib import Path

    from vadsim.plots.constants import constants_maps, target_maps
    from vadsim.studies.constants import best_constants, scan_constants

    if args.theta0 is not None:
        theta0 = np.round(arange(*args.theta0, flag="--theta0"), 10)
    elif args.theta0_steps < 1:
        raise ValueError(f"--theta0-steps = {args.theta0_steps} must be >= 1")
    else:
        theta0 = np.linspace(0.0, math.pi, args.theta0_steps, endpoint=False)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    scan = scan_constants(
        args.preset, theta0, np.round(arange(*args.gap, flag="--gap"), 10),
        design_every=args.design_every, designs=not args.no_designs, cycles=args.cycles,
        analyse_cycles=args.analyse, workers=args.workers, progress=not args.quiet)
    best = best_constants(scan)
    scan.to_netcdf(str(out / "scan.nc"))
    scan.scores.to_csv(out / "scores.csv", index=False)
    scan.summary().to_csv(out / "summary.csv", index=False)
    (out / "best.json").write_text(json.dumps(
        {**best, "seconds": round(time.perf_counter() - t0, 1), "settings": scan.settings},
        indent=1, default=str) + "\n")
    constants_maps(scan.scores, best, path=out / "constants-maps.png")
    target_maps(scan.scores, best, path=out / "target-maps.png")
    with pandas_display():
        print(scan.summary().head(10).round(3).to_string(index=False))
    print(f"\nbest: theta0 = {best['theta0']:.4f} rad, gap x {best['gap_ratio']:.2f}: "
          f"{best['met']} of {best['of']} targets ({', '.join(best['groups'])})")
    for m in best["missed"]:
        print(f"  missed {m['target']}: {m['value']} (published {m['published']})")
    print(f"wrote {out}/ in {time.perf_counter() - t0:.0f} s")
    return 0


def _cmd_thesis(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    import pandas as pd

    from vadsim.studies.reproduction import reproduce

    scan = best = None
    if args.scan is not None:
        folder = Path(args.scan)
        if not (folder / "scores.csv").is_file():
            raise ValueError(f"--scan {folder}: no scores.csv there (write one with "
                             "vadsim constants --out DIR)")
        scan = pd.read_csv(folder / "scores.csv")
        if (folder / "best.json").is_file():
            best = json.loads((folder / "best.json").read_text())
    thesis = None if args.thesis_preset == "none" else args.thesis_preset
    maps = None
    if args.maps is not None:
        from vadsim.studies.reproduction import SPRING_MAP_STEPS, thesis_maps

        steps = SPRING_MAP_STEPS if args.spring_steps is None else args.spring_steps
        presets = {"reference": args.reference, **({"thesis": thesis} if thesis else {})}
        maps = {lab: thesis_maps(name, args.maps, spring_steps=steps, cycles=args.cycles,
                                 analyse_cycles=args.analyse, workers=args.workers,
                                 progress=not args.quiet)
                for lab, name in presets.items()}
    rep = reproduce(args.reference, thesis, scan, cycles=args.cycles,
                    analyse_cycles=args.analyse, workers=args.workers,
                    progress=not args.quiet, maps=maps)
    with pandas_display():
        print(rep.counts().to_string())
        missed = rep.table[(rep.table[[f"status_{lab}" for lab in rep.presets]] == "missed")
                           .any(axis=1)]
        cols = ["quantity", "published", *rep.presets, "reason"]
        print(f"\n{len(missed)} number(s) missed by at least one preset:")
        print(missed[cols].to_string(index=False, max_colwidth=70))
    if args.out:
        from vadsim.report.reproduction import write_reproduction_report

        path = write_reproduction_report(
            rep, args.out, args.scan, best,
            command="vadsim thesis" + (f" --scan {args.scan}" if args.scan else "")
            + (f" --maps {args.maps}" if args.maps else "") + f" --out {args.out}")
        print(f"\nwrote {path}")
    return 0
