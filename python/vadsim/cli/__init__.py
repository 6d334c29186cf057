"""The ``vadsim`` command line.

Why this module exists: drilling engineers run the model by tool name and flow rate without
writing Python. Every sub-command prints a table a person can read and, with ``--json``, one
JSON object a script can parse. Dependencies point one way: cli -> analysis -> core.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from vadsim.model.presets import PRESETS, get_preset, param_table
from vadsim.model.simulate import SURFACES, SimulationResult, SolverError, simulate
from vadsim.signals.labels import regime_name

__all__ = ["main"]


def _parse_pairs(items: Sequence[str] | None, flag: str, example: str = "") -> dict[str, str]:
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep:
            hint = f", e.g. {flag} {example}" if example else ""
            raise ValueError(f"{flag} {item!r}: expected NAME=VALUE{hint}")
        out[name.strip()] = value.strip()
    return out


def _parse_overrides(items: Sequence[str] | None) -> dict[str, float]:
    out: dict[str, float] = {}
    for name, value in _parse_pairs(items, "--set", "kS=4.7e5").items():
        try:
            out[name] = float(value)
        except ValueError as exc:
            raise ValueError(f"--set {name}={value}: {value!r} is not a number") from exc
    return out


def _row(r: SimulationResult) -> dict[str, float | int | str]:
    z = r.z
    mean1, std1 = r.peak_stats(1)
    mean5, _ = r.peak_stats(5)
    row: dict[str, float | int | str] = {
        "flow_gpm": r.flow_gpm,
        "f_exc_hz": round(r.f_exc_hz, 3),
        **{f"Z_{s}": round(z[s], 4) for s in SURFACES[:4]},
        "scenario": r.scenario,
        "regime": regime_name(r.scenario),
        "x1_peak_mean_g": round(mean1, 3),
        "x1_peak_std_g": round(std1, 3),
        "x5_peak_mean_g": round(mean5, 3),
        "J_pos_N_per_kg": round(r.impulse_pos, 3),
        "J_mean_N_per_kg": round(r.impulse_mean, 3),
        "steps": r.stats["steps"],
        "events": len(r.events),
    }
    if r.m_ref_kg:
        row["J_pos_kN"] = round(r.impulse_pos * r.m_ref_kg / 1000.0, 4)
    return row


def _cmd_run(args: argparse.Namespace) -> int:
    overrides = _parse_overrides(args.set or [])
    preset = get_preset(args.preset)
    flows = args.flow

    def one(q: float) -> SimulationResult:
        return simulate(
            preset, q, cycles=args.cycles, analyse_cycles=args.analyse, overrides=overrides,
            wob_klbf=args.wob, law=args.law, method=args.method, rtol=args.rtol,
            record="none",
        )

    t0 = time.perf_counter()
    workers = max(1, min(args.jobs, len(flows)))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        results = list(pool.map(one, flows))
    elapsed = time.perf_counter() - t0
    rows = [_row(r) for r in results]
    if args.json:
        print(json.dumps({"preset": preset.name, "overrides": overrides, "runs": rows,
                          "elapsed_s": round(elapsed, 3)}))
        return 0
    print(f"{preset.name}: {preset.tool} tool, {preset.bit} bit, "
          f"{args.wob or preset.wob_klbf:g} klbf, {args.cycles:g} cycles "
          f"(last {args.analyse:g} analysed)")
    head = (f"{'Q gpm':>7} {'f Hz':>6} {'Z1':>6} {'Z2':>6} {'Z3':>6} {'Z4':>6} {'sc':>3} "
            f"{'x1 peak g':>10} {'+-':>6} {'x5 peak g':>10} {'J* N/kg':>8} {'J* kN':>7}  regime")
    print(head)
    for r in rows:
        print(f"{r['flow_gpm']:7.1f} {r['f_exc_hz']:6.2f} {r['Z_spring']:6.3f} "
              f"{r['Z_impact']:6.3f} {r['Z_off_bottom']:6.3f} {r['Z_on_bottom']:6.3f} "
              f"{r['scenario']:3d} {r['x1_peak_mean_g']:10.2f} {r['x1_peak_std_g']:6.2f} "
              f"{r['x5_peak_mean_g']:10.2f} {r['J_pos_N_per_kg']:8.2f} "
              f"{r.get('J_pos_kN', float('nan')):7.3f}  {r['regime']}")
    print(f"{len(rows)} runs in {elapsed:.2f} s on {workers} thread(s)")
    return 0


def _cmd_presets(args: argparse.Namespace) -> int:
    if args.name:
        p = get_preset(args.name)
        print(f"{p.name}: {p.tool} tool, {p.bit} bit, WOB {p.wob_klbf:g} klbf, "
              f"m* = {p.m_ref_kg:.2f} kg, law {p.law}\n{p.note}")
        for name, unit, meaning, _ in param_table():
            print(f"  {name:>9} = {p.params[name]:<12.6g} {unit:<18} {meaning}")
        return 0
    for p in PRESETS.values():
        print(f"{p.name:<10} {p.tool:>6} {p.bit:<4} WOB {p.wob_klbf:g} klbf  "
              f"l0 {p.params['l0']:g} m  wob {p.params['wob']:g} N/kg")
    return 0


def _flows(args: argparse.Namespace) -> list[float]:
    from vadsim.studies.sweep import flows_from_hz

    if args.hz:
        lo, hi, step = args.hz
        return [float(q) for q in flows_from_hz(args.preset, _arange(lo, hi, step, "--hz"))]
    lo, hi, step = args.flows
    return [float(q) for q in _arange(lo, hi, step, "--flows")]


def _arange(lo: float, hi: float, step: float, flag: str) -> list[float]:
    if not (step > 0) or hi < lo:
        raise ValueError(f"{flag} {lo:g} {hi:g} {step:g}: need FROM <= TO and STEP > 0")
    n = int(round((hi - lo) / step)) + 1
    return [lo + i * step for i in range(n) if lo + i * step <= hi + 1e-9 * max(1.0, abs(hi))]


def _sweep_options(args: argparse.Namespace) -> dict:
    return dict(
        overrides=_parse_overrides(args.set or []), law=args.law, wob_klbf=args.wob,
        cycles=args.cycles, analyse_cycles=args.analyse, mode=args.mode, gap_via=args.gap_via,
        workers=args.workers, scheduler=args.scheduler, store=args.store,
        progress=not args.quiet, detail=args.detail,
    )


def _finish_dataset(ds, args: argparse.Namespace) -> None:
    from vadsim.studies.sweep import save_dataset

    if args.out:
        save_dataset(ds, args.out)
        print(f"saved {args.out}")


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
    with _pd_display():
        print(df.round(3).to_string())
    print(f"{ds.sizes['flow_gpm']} runs in {elapsed:.1f} s ({ds.attrs['mode']} mode)")
    print("\nregimes along flow:")
    print(thesis.regime_intervals(ds).to_string(index=False))
    if args.plot:
        from vadsim import plots

        for kind, fn in (("peaks", plots.peaks_vs_flow), ("z", plots.z_vs_flow),
                         ("j", plots.j_vs_flow)):
            path = args.plot.replace(".png", f"-{kind}.png")
            fn(ds, path=path)
            print(f"figure {path}")
    return 0


def _cmd_map(args: argparse.Namespace) -> int:
    from vadsim.studies.sweep import sweep

    axes = {args.param: _arange(*args.values, flag="--values") if args.steps is None
            else list(np.linspace(args.values[0], args.values[1], args.steps))}
    if args.param2:
        axes[args.param2] = list(np.linspace(args.values2[0], args.values2[1], args.steps2))
    t0 = time.perf_counter()
    ds = sweep(args.preset, _flows(args), axes, **_sweep_options(args))
    elapsed = time.perf_counter() - t0
    _finish_dataset(ds, args)
    n = int(np.prod([ds.sizes[d] for d in ds.scenario.dims]))
    print(f"{n} runs in {elapsed:.1f} s ({n / elapsed:.1f} runs/s)")
    counts = {int(k): int(v) for k, v in zip(*np.unique(ds.scenario.values,
                                                         return_counts=True), strict=True)}
    print("scenario counts:", ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
    k = np.unravel_index(int(np.nanargmax(ds.j_pos.values)), ds.j_pos.shape)
    best = {d: float(ds[d].values[i]) for d, i in zip(ds.j_pos.dims, k, strict=True)}
    print(f"max J* {float(ds.j_pos.values[k]):.2f} N/kg at {best}")
    if args.plot and not args.param2:
        from vadsim import plots

        plots.regime_map(ds, path=args.plot.replace(".png", "-regimes.png"))
        plots.j_map(ds, path=args.plot.replace(".png", "-j.png"))
        print(f"figures {args.plot.replace('.png', '-regimes.png')}, "
              f"{args.plot.replace('.png', '-j.png')}")
    return 0


def _cmd_design(args: argparse.Namespace) -> int:
    from vadsim.studies import design

    common = dict(workers=args.workers, scheduler=args.scheduler, progress=not args.quiet,
                  cycles=args.cycles, analyse_cycles=args.analyse, detail="map")
    if args.study in design.STUDIES:
        ds = design.one_at_a_time(args.study, args.preset, steps=args.steps,
                                  gap_via=args.gap_via, store=args.store, **common)
        _finish_dataset(ds, args)
        table = design.study_table(ds)
        with _pd_display():
            print(table.round(3).to_string())
        j0 = table["j_max"].iloc[int(np.argmin(np.abs(table.index - _base_value(args))))]
        print(f"max J* over the study: {table['j_max'].max():.2f} N/kg "
              f"({table['j_max'].max() / j0 - 1:+.0%} vs the preset's value)")
        if args.plot:
            from vadsim import plots

            plots.regime_map(ds, path=args.plot.replace(".png", "-regimes.png"))
            plots.j_map(ds, path=args.plot.replace(".png", "-j.png"))
        return 0
    if args.study == "recommended":
        res = design.compare_designs(design.RECOMMENDED, args.preset, gap_via=args.gap_via,
                                     **common)
        _print_design(res)
        if args.plot:
            from vadsim import plots

            plots.design_comparison(res.original, res.changed, path=args.plot)
        return 0
    # optimise
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

            plots.design_comparison(opt.verified.original, opt.verified.changed,
                                    labels=("original", "optimised"), path=args.plot)
    if args.plot:
        # The optimum's map: flow x gap ratio over the published range, kS and Fo optimal.
        from vadsim import plots

        fixed = {k: v for k, v in opt.best.items() if k != "gap_ratio"}
        gap_map = design.sweep(args.preset, design.thesis_flows(args.preset, 1.0),
                               {"gap_ratio": np.linspace(*design.STUDIES["gap"].values(2), 14)},
                               overrides=fixed, gap_via=args.gap_via, detail="map",
                               workers=args.workers, progress=not args.quiet)
        for kind, fn in (("regimes", plots.regime_map), ("j", plots.j_map)):
            path = args.plot.replace(".png", f"-map-{kind}.png")
            fn(gap_map, path=path)
            print(f"figure {path}")
    if args.out:
        opt.history.to_csv(args.out, index=False)
        print(f"saved every evaluated design to {args.out}")
    return 0


def _base_value(args: argparse.Namespace) -> float:
    from vadsim.studies import design

    s = design.STUDIES[args.study]
    return 1.0 if s.parameter == "gap_ratio" else get_preset(args.preset).params[s.parameter]


def _print_design(res) -> None:
    m0, m1 = res.metrics_original, res.metrics_changed
    print(f"design {res.design} (gap via {res.gap_via})")
    for name, m in (("original", m0), ("changed", m1)):
        print(f"  {name:9s} max J* {m['j_max']:7.2f} N/kg ({m['j_max_kN']:.3f} kN) at "
              f"{m['flow_at_max_gpm']:.0f} gal/min; operating range {m['range_from_gpm']:.0f}-"
              f"{m['range_to_gpm']:.0f} gal/min; regime 1 up to {m['regime1_edge_gpm']:.0f}")
    print(f"  max J* {res.j_ratio:+.0%}, operating range {res.range_ratio:+.0%}")


def _cmd_thesis(args: argparse.Namespace) -> int:
    from vadsim.studies import thesis
    from vadsim.studies.sweep import sweep

    ds = sweep("7in-cde", _arange(200, 650, 10, "--flows"), cycles=args.cycles,
               analyse_cycles=args.analyse, mode=args.mode, workers=args.workers,
               progress=not args.quiet)
    with _pd_display():
        print("Impact regimes of the 7in CDE flow sweep vs dissertation section 4.1:")
        print(thesis.compare_regimes(ds).to_string(index=False))
        print("\nMean x1 peaks (full resolution) vs the dissertation's simulated peaks:")
        print(thesis.compare_peaks(ds).round(3).to_string(index=False))
    k = int(np.nanargmax(ds.j_pos.values))
    print(f"\nmax J* {float(ds.j_pos[k]):.2f} N/kg at {float(ds.flow_gpm[k]):.0f} gal/min, "
          f"scenario {int(ds.scenario[k])}")
    _finish_dataset(ds, args)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from vadsim import plots
    from vadsim.studies.sweep import load_dataset

    if args.kind == "traces":
        preset = args.inputs[0] if args.inputs else "7in-cde"
        r = simulate(preset, args.flow, cycles=args.cycles, analyse_cycles=args.analyse,
                     record="window")
        plots.time_traces(r, cycles=args.show_cycles, path=args.out)
    else:
        if not args.inputs:
            raise ValueError(f"plot {args.kind} needs a NetCDF file from sweep, map or design")
        ds = [load_dataset(p) for p in args.inputs]
        if args.kind == "compare":
            if len(ds) != 2:
                raise ValueError("plot compare needs two files: original and changed design")
            plots.design_comparison(ds[0], ds[1], path=args.out)
        else:
            fn = {"peaks": plots.peaks_vs_flow, "z": plots.z_vs_flow, "j": plots.j_vs_flow,
                  "regime-map": plots.regime_map, "j-map": plots.j_map}[args.kind]
            kwargs = {"reference": args.reference} if args.kind == "peaks" and args.reference \
                else {}
            fn(ds[0], path=args.out, **kwargs)
    print(f"figure {args.out}")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    from vadsim.fit.validate import validate, write_report

    t0 = time.perf_counter()
    res = validate(args.campaign, overrides=_parse_overrides(args.set or []),
                   cycles=args.cycles, analyse_cycles=args.analyse, workers=args.workers)
    cmd = "vadsim validate " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else None
    path = write_report(res, args.out, fmt=args.format, command=cmd)
    z = res.residuals
    with _pd_display():
        print(f"{res.campaign.name}: {len(res.campaign.events)} events simulated in "
              f"{time.perf_counter() - t0:.1f} s with preset {res.preset.name}")
        print("standardised residuals (model through the sensor chain - recorded) / spread:")
        print(z.round(2).to_string())
    print(f"report: {path}")
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from vadsim.fit.calibrate import calibrate

    bounds = {}
    for name, text in _parse_pairs(args.bounds, "--bounds").items():
        lo, sep, hi = text.partition(":")
        if not sep:
            raise ValueError(f"--bounds {name}={text}: expected LO:HI")
        bounds[name] = (float(lo), float(hi))
    start = {k: float(v) for k, v in _parse_pairs(args.start, "--start").items()}

    def report(stage: str, n: int, cost: float, vals: dict) -> None:
        if not args.quiet and n % 10 == 0:
            print(f"  [{stage}] evaluation {n}: cost {cost:.4g} at "
                  + ", ".join(f"{k}={v:.5g}" for k, v in vals.items()), flush=True)

    res = calibrate(args.campaign, args.param, bounds=bounds or None, start=start or None,
                    targets=args.targets, keys=args.keys, resolution=args.resolution,
                    overrides=_parse_overrides(args.set or []),
                    global_stage={"scan": "scan", "de": "de", "none": False}[args.global_stage],
                    n_global=args.n_global, n_starts=args.starts,
                    popsize=args.popsize, maxiter=args.maxiter, seed=args.seed,
                    profile_points=args.profile, cycles=args.cycles,
                    analyse_cycles=args.analyse, workers=args.workers, callback=report)
    if args.json:
        print(json.dumps({"estimates": res.estimates, "stderr": res.stderr,
                          "start": res.start, "cost_before": res.cost_before,
                          "cost_after": res.cost_after, "evaluations": res.evaluations,
                          "seconds": round(res.seconds, 2)}))
        return 0
    print(res.summary())
    with _pd_display():
        print("standardised residuals before:")
        print(res.residuals_before.round(2).to_string())
        print("after:")
        print(res.residuals_after.round(2).to_string())
        for name, prof in res.profile.items():
            print(f"profile of the cost along {name}:")
            print(prof.round(4).to_string(index=False))
    return 0


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from vadsim.fit.diagnose import diagnose, predict, write_diagnosis_report

    def say(msg: str) -> None:
        if not args.json:
            print(f"  {msg}", flush=True)
        else:
            print(f"  {msg}", file=sys.stderr, flush=True)

    diag = diagnose(args.campaign, candidates=args.candidates,
                    overrides=_parse_overrides(args.set or []), cycles=args.cycles,
                    analyse_cycles=args.analyse, phases=args.phases,
                    min_delta=args.min_delta, min_reduction=args.min_reduction,
                    workers=args.workers, progress=None if args.quiet else say)
    if args.predict:
        predict(diag, args.predict, workers=args.workers)
    path = write_diagnosis_report(diag, args.out, fmt=args.format)
    if args.json:
        print(json.dumps(diag.as_json()))
        return 0
    print(diag.summary())
    print(f"report: {path}")
    return 0


def _cmd_blind(args: argparse.Namespace) -> int:
    from vadsim.blind import DEFAULT_SCENARIOS, blind_benchmark

    scenarios = DEFAULT_SCENARIOS
    if args.only:
        scenarios = tuple(s for s in DEFAULT_SCENARIOS if s.id in args.only or s.key in args.only)
        if not scenarios:
            raise ValueError(f"--only {' '.join(args.only)}: no scenario has that candidate")
    sc = blind_benchmark(args.out, scenarios=scenarios, duration_s=args.duration,
                         noise_g=args.noise, seed=args.seed, workers=args.workers,
                         progress=lambda m: print(f"  {m}", flush=True))
    print(Path(args.out, "scores.md").read_text())
    return 0 if sc["campaigns"] else 1


class _pd_display:
    def __enter__(self) -> None:
        import pandas as pd

        self._ctx = pd.option_context("display.width", 200, "display.max_columns", 30)
        self._ctx.__enter__()

    def __exit__(self, *exc: object) -> None:
        self._ctx.__exit__(*exc)


def _add_grid_options(p: argparse.ArgumentParser, detail: str = "full") -> None:
    p.add_argument("preset", nargs="?", default="7in-cde",
                   help="tool preset: " + ", ".join(PRESETS) + " (default 7in-cde)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--flows", type=float, nargs=3, metavar=("FROM", "TO", "STEP"),
                   default=[200.0, 650.0, 10.0],
                   help="flow axis in gal/min (default 200 650 10)")
    g.add_argument("--hz", type=float, nargs=3, metavar=("FROM", "TO", "STEP"),
                   help="flow axis given as excitation frequency in Hz, e.g. 21.3 69.3 0.5")
    p.add_argument("--mode", default="independent", choices=["independent", "continuation"],
                   help="independent: every run from rest; continuation: each flow starts "
                   "from the previous flow's final state, as in a field flow sweep")
    p.add_argument("--cycles", type=float, default=400, help="run length in cycles (400)")
    p.add_argument("--analyse", type=float, default=200, help="steady window in cycles (200)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="override a parameter for every run (repeatable)")
    p.add_argument("--law", default=None,
                   choices=["kelvin_voigt", "kelvin_voigt_no_tension", "hunt_crossley"],
                   help="contact law of the impact surfaces")
    p.add_argument("--wob", type=float, default=None, help="weight on bit (klbf)")
    p.add_argument("--gap-via", default="spring", choices=["spring", "anvil", "housing"],
                   help="which length realises a gap change (default spring)")
    p.add_argument("--detail", default=detail, choices=["full", "map"],
                   help="full: every label (peaks and J* at 20 kHz, impact frequency); map: "
                   f"regimes, J*, periodicity only, ~25 %% faster (default {detail})")
    _add_exec_options(p)
    p.add_argument("--store", default=None,
                   help="folder of finished chunks: an interrupted run resumes from it")
    p.add_argument("--out", default=None, help="save the dataset to this NetCDF file")
    p.add_argument("--plot", default=None, metavar="FILE.png", help="also draw the figures")
    p.add_argument("--json", action="store_true", help="print JSON records")


def _add_exec_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--workers", type=int, default=None,
                   help="local threads (default: all cores)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for the docs and tests)."""
    parser = argparse.ArgumentParser(
        prog="vadsim",
        description="Simulate a vibration-assisted drilling tool: impact regimes, "
        "impulse per second J*, vibration peaks.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser(
        "run", help="run the model at one or more flow rates and print the labels",
        description="Run the model from its static on-bottom state at each flow rate "
        "(in parallel threads) and print impacts per cycle Z per surface, the impact scenario "
        "(dissertation Table 4.2), 200 ms peak statistics at x1 and x5 and J*.",
    )
    run.add_argument("preset", nargs="?", default="7in-cde",
                     help="tool preset: " + ", ".join(PRESETS) + " (default 7in-cde)")
    run.add_argument("--flow", type=float, nargs="+", default=[200.0],
                     help="flow rates in gal/min (default 200)")
    run.add_argument("--cycles", type=float, default=400,
                     help="run length in excitation cycles (default 400)")
    run.add_argument("--analyse", type=float, default=200,
                     help="steady window: the last N cycles (default 200)")
    run.add_argument("--wob", type=float, default=None,
                     help="weight on bit in klbf (default: the preset's)")
    run.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="override a parameter, e.g. --set kS=4.7e5 (repeatable)")
    run.add_argument("--law", default=None,
                     choices=["kelvin_voigt", "kelvin_voigt_no_tension", "hunt_crossley"],
                     help="contact law of the impact surfaces (default kelvin_voigt)")
    run.add_argument("--method", default="adams", choices=["adams", "bdf"],
                     help="CVODE method (default adams)")
    run.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance (1e-6)")
    run.add_argument("--jobs", type=int, default=2, help="parallel threads (default 2)")
    run.add_argument("--json", action="store_true", help="print one JSON object")
    run.set_defaults(func=_cmd_run)

    sw = sub.add_parser(
        "sweep", help="flow sweep: labels at every flow, regimes along flow, NetCDF",
        description="Run the model at every flow of an axis (in parallel, resumable with "
        "--store) and print Z per surface, scenario, peaks, J*, impact frequency and "
        "periodicity per flow, then the regime intervals along flow.",
    )
    _add_grid_options(sw)
    sw.set_defaults(func=_cmd_sweep)

    mp = sub.add_parser(
        "map", help="2-D map over flow and a parameter (or two): regimes and J*",
        description="Run the model over flow x one or two parameters. Parameters are Table "
        "2.1 names (see 'vadsim presets 7in-cde') or gap_ratio / gap. Example (the "
        "dissertation's gap map): vadsim map --param gap_ratio --values 0.85 1.5 --steps 85 "
        "--hz 21.3 69.3 0.5 --out gap.nc --store gap.parts",
    )
    _add_grid_options(mp, detail="map")
    mp.add_argument("--param", required=True, help="design parameter of the map")
    mp.add_argument("--values", type=float, nargs="+", required=True,
                    metavar="V", help="FROM TO (with --steps) or FROM TO STEP")
    mp.add_argument("--steps", type=int, default=None, help="number of parameter values")
    mp.add_argument("--param2", default=None, help="optional second parameter")
    mp.add_argument("--values2", type=float, nargs=2, metavar=("FROM", "TO"))
    mp.add_argument("--steps2", type=int, default=5)
    mp.set_defaults(func=_cmd_map)

    de = sub.add_parser(
        "design", help="the dissertation's design studies, its recommended design, or an "
        "optimisation of kS, gap and Fo together",
        description="spring / gap / force: one-at-a-time map over the published range "
        "(parametric.csv) with J* maximum and operating range per value. recommended: the "
        "dissertation's recommended design vs the original (Fig. 5.7). optimise: "
        "differential evolution over kS, gap ratio and Fo within the published ranges, "
        "maximising J* and the operating range (J* within 10 %% of its maximum).",
    )
    de.add_argument("study", choices=["spring", "gap", "force", "recommended", "optimise"])
    de.add_argument("preset", nargs="?", default="7in-cde")
    de.add_argument("--steps", type=int, default=21, help="parameter values of a study (21)")
    de.add_argument("--gap-via", default="spring", choices=["spring", "anvil", "housing"],
                    help="which length realises a gap change (default spring)")
    de.add_argument("--cycles", type=float, default=400)
    de.add_argument("--analyse", type=float, default=200)
    de.add_argument("--popsize", type=int, default=6, help="optimise: population factor (6)")
    de.add_argument("--maxiter", type=int, default=8, help="optimise: generations (8)")
    de.add_argument("--seed", type=int, default=1, help="optimise: random seed (1)")
    de.add_argument("--store", default=None, help="study: resumable chunk folder")
    de.add_argument("--out", default=None, help="save the map (NetCDF) or the designs (CSV)")
    de.add_argument("--plot", default=None, metavar="FILE.png", help="also draw the figures")
    _add_exec_options(de)
    de.set_defaults(func=_cmd_design)

    th = sub.add_parser(
        "thesis", help="compare the 7in CDE flow sweep with the dissertation's regimes and peaks",
    )
    th.add_argument("--mode", default="independent", choices=["independent", "continuation"])
    th.add_argument("--cycles", type=float, default=400)
    th.add_argument("--analyse", type=float, default=200)
    th.add_argument("--out", default=None, help="save the sweep (NetCDF)")
    _add_exec_options(th)
    th.set_defaults(func=_cmd_thesis)

    pl = sub.add_parser(
        "plot", help="draw a figure from a saved sweep/map, or time traces of a run",
        description="peaks / z / j: a flow sweep's peaks (Figs 3.42, 4.27b), Z* (4.27a) or "
        "J* by regime (4.28); regime-map / j-map: a map over flow and a parameter (5.1-5.6); "
        "compare: two flow sweeps, original and changed design (5.7); traces: forces, "
        "indentations and x1 acceleration over the last cycles of a run (4.2-4.6). "
        "Example: vadsim sweep --out s.nc && vadsim plot peaks s.nc --reference "
        "thesis-7in-cde --out peaks.png",
    )
    pl.add_argument("kind", choices=["peaks", "z", "j", "regime-map", "j-map", "compare",
                                     "traces"])
    pl.add_argument("inputs", nargs="*",
                    help="NetCDF file(s) from sweep/map/design; for traces: a preset")
    pl.add_argument("--out", default="figure.png", help="output file (.png, .pdf, .svg)")
    pl.add_argument("--reference", default=None,
                    help="peaks: overlay the dissertation's points, e.g. thesis-7in-cde")
    pl.add_argument("--flow", type=float, default=200.0, help="traces: flow (gal/min)")
    pl.add_argument("--cycles", type=float, default=400, help="traces: run length (400)")
    pl.add_argument("--analyse", type=float, default=200, help="traces: window (200)")
    pl.add_argument("--show-cycles", type=float, default=3, help="traces: cycles shown (3)")
    pl.set_defaults(func=_cmd_plot)

    va = sub.add_parser(
        "validate", help="simulate a campaign's events and compare features with the recordings",
        description="Simulate every event of CAMPAIGN (a folder with campaign.toml, the toml "
        "file, or a shipped campaign: thesis:7in-cde, thesis:7in-rc, thesis:9.5in-pdc) at its "
        "flow and WOB, pass each sensor's simulated acceleration through its chain, compute "
        "the same features on both sides and write a report (tables, peaks vs flow, "
        "standardised mismatch heat map).",
    )
    va.add_argument("campaign")
    va.add_argument("--out", default="validation", help="report folder (default validation)")
    va.add_argument("--format", default="md", choices=["md", "html"], help="report format")
    va.add_argument("--set", action="append", metavar="NAME=VALUE",
                    help="override a model parameter (repeatable)")
    va.add_argument("--cycles", type=float, default=400)
    va.add_argument("--analyse", type=float, default=200)
    _add_exec_options(va)
    va.set_defaults(func=_cmd_validate)

    ca = sub.add_parser(
        "calibrate", help="fit parameters to a campaign (robust least squares, global stage)",
        description="Fit --param parameters to CAMPAIGN's features by robust least squares "
        "on standardised residuals: differential evolution within the bounds, then a local "
        "soft-L1 polish; prints estimates with standard errors and the fit before and after. "
        "Example (the 9.5in withheld constants against the dissertation's simulations): "
        "vadsim calibrate thesis:9.5in-pdc --param l0 --param wob --targets thesis-sim "
        "--resolution full",
    )
    ca.add_argument("campaign")
    ca.add_argument("--param", action="append", required=True,
                    help="parameter to fit (repeatable), e.g. --param l0 --param wob")
    ca.add_argument("--bounds", action="append", metavar="NAME=LO:HI",
                    help="search range (defaults: l0 0.4:1.4 m, wob 200:2500 N/kg, "
                    "else 0.5x-2x the start)")
    ca.add_argument("--start", action="append", metavar="NAME=VALUE",
                    help="starting value (default: the preset's)")
    ca.add_argument("--targets", default="recorded", choices=["recorded", "thesis-sim"],
                    help="fit the recordings, or the dissertation's own simulated results")
    ca.add_argument("--keys", nargs="+", default=None,
                    help="feature keys to fit (default: all that both sides have)")
    ca.add_argument("--resolution", default="sensor", choices=["sensor", "full"],
                    help="simulated features through the sensor chain or at full resolution")
    ca.add_argument("--global", dest="global_stage", default="scan",
                    choices=["scan", "de", "none"],
                    help="global stage: dense Sobol scan (default), differential evolution, "
                    "or none (local polish from --start only)")
    ca.add_argument("--n-global", type=int, default=512, help="scan: points (512)")
    ca.add_argument("--starts", type=int, default=3, help="scan: local polishes (3)")
    ca.add_argument("--popsize", type=int, default=8, help="de: population factor (8)")
    ca.add_argument("--maxiter", type=int, default=10, help="de: generations (10)")
    ca.add_argument("--seed", type=int, default=1)
    ca.add_argument("--profile", type=int, default=0, metavar="N",
                    help="profile the cost along each parameter at N points")
    ca.add_argument("--set", action="append", metavar="NAME=VALUE",
                    help="fixed parameter overrides (repeatable)")
    ca.add_argument("--cycles", type=float, default=400)
    ca.add_argument("--analyse", type=float, default=200)
    ca.add_argument("--json", action="store_true")
    _add_exec_options(ca)
    ca.set_defaults(func=_cmd_calibrate)

    dg = sub.add_parser(
        "diagnose", help="locate a mismatch, fit candidate physics, select on held-out events",
        description="Compare the base model with CAMPAIGN feature by feature, say where they "
        "disagree, fit every candidate physics (hydraulic_force, contact_law, anvil_friction, "
        "string_radiation, axial_lateral, sensor_chain), rank them on held-out events "
        "(leave-one-flow-out and a high-flow block, AICc) and name the missing physics or "
        "'none'. Writes a report (diagnosis.md/.html, diagnosis.json, figures). Example: "
        "vadsim diagnose thesis:7in-cde --predict thesis:7in-rc --json",
    )
    dg.add_argument("campaign")
    dg.add_argument("--out", default="diagnosis", help="report folder (default diagnosis)")
    dg.add_argument("--format", default="md", choices=["md", "html"], help="report format")
    dg.add_argument("--json", action="store_true",
                    help="print one JSON object (missing_physics, parameters, located, "
                    "heldout_error_before/after, ranking); progress goes to stderr")
    dg.add_argument("--candidates", nargs="+", default=None,
                    help="candidate ids to try (default: all)")
    dg.add_argument("--predict", metavar="CAMPAIGN",
                    help="predict another campaign with the chosen physics (nothing refitted)")
    dg.add_argument("--set", action="append", metavar="NAME=VALUE",
                    help="override a base-model parameter (repeatable)")
    dg.add_argument("--cycles", type=float, default=300, help="run length, cycles (300)")
    dg.add_argument("--analyse", type=float, default=200, help="analysed cycles (200)")
    dg.add_argument("--phases", type=int, default=4,
                    help="sampling phases the simulated features average over (4)")
    dg.add_argument("--min-delta", type=float, default=10.0,
                    help="held-out AICc margin a candidate needs over 'none' (10)")
    dg.add_argument("--min-reduction", type=float, default=0.3,
                    help="held-out RMS reduction a candidate needs, fraction (0.3)")
    dg.add_argument("--quiet", action="store_true", help="no progress lines")
    dg.add_argument("--workers", type=int, default=None,
                    help="worker processes for the candidates (default: all cores)")
    dg.set_defaults(func=_cmd_diagnose)

    bl = sub.add_parser(
        "blind", help="blind benchmark of diagnose on campaigns with concealed physics",
        description="Write campaigns (RECORDINGS.md format) from the 7in model plus one "
        "concealed effect (each candidate at two magnitudes, and five with none), through the "
        "sensor chain with noise; diagnose each from disk without the truth; score "
        "identification, false alarms, parameter error and held-out improvement (scores.md, "
        "scores.json). Resumes from finished results in OUT/results.",
    )
    bl.add_argument("--out", default="blind-benchmark", help="folder (default blind-benchmark)")
    bl.add_argument("--only", nargs="+", help="only these candidate ids (and 'none')")
    bl.add_argument("--duration", type=float, default=8.0, help="seconds per event (8)")
    bl.add_argument("--noise", type=float, default=0.3, help="sensor noise, g (0.3)")
    bl.add_argument("--seed", type=int, default=2026)
    bl.add_argument("--workers", type=int, default=None,
                    help="worker processes per diagnosis (default: all cores)")
    bl.set_defaults(func=_cmd_blind)

    pr = sub.add_parser("presets", help="list the presets, or show one's parameters")
    pr.add_argument("name", nargs="?", help="preset to show")
    pr.set_defaults(func=_cmd_presets)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vadsim`` command."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, SolverError, OSError) as exc:
        print(f"vadsim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
