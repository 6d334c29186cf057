"""Commands on single runs: ``run`` (labels at some flow rates), ``presets``, ``plot``.

Why this module exists: these commands need the model and the labels only, not the study
machinery (xarray, dask), so a single run starts quickly.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any

from vadsim._interrupt import result, stop_on_interrupt
from vadsim.cli.common import (
    DEFAULT_PRESET,
    Parents,
    Subparsers,
    parse_overrides,
    workers_parent,
)
from vadsim.model.presets import PRESETS, get_preset, param_table
from vadsim.model.result import SURFACES, SimulationResult
from vadsim.model.simulation import simulate
from vadsim.signals.labels import regime_name

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["PRESETS_FOOTER", "PRESET_ROLES", "RUN_TABLE_LEGEND", "FlowsThenPreset",
           "add_parsers"]


class FlowsThenPreset(argparse.Action):
    """``--flow Q [Q ...] [PRESET]``: flow rates, then optionally the preset.

    ``--flow`` takes one or more numbers, so argparse hands it every word up to the next
    option, including a preset written after it (``vadsim run --flow 200 7in-rc``). The
    numbers are the flows; one trailing word is kept as ``flow_preset`` and ``_cmd_run``
    uses it as the preset, so the preset may stand before or after ``--flow``.
    """

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
        words = [str(v) for v in (values or [])]
        flows: list[float] = []
        for i, word in enumerate(words):
            try:
                flows.append(float(word))
            except ValueError:
                rest = words[i:]
                if not flows or len(rest) > 1:
                    raise argparse.ArgumentError(
                        self, f"expected flow rates in gal/min (numbers), then at most one "
                        f"preset; got {' '.join(words)}") from None
                namespace.flow_preset = rest[0]
                break
        setattr(namespace, self.dest, flows)


def add_parsers(sub: Subparsers, parents: Parents) -> None:
    """Add ``run``, ``presets`` and ``plot`` to the ``vadsim`` sub-commands."""
    _add_run(sub, parents)
    pr = sub.add_parser("presets", help="list the presets, or show one's parameters")
    pr.add_argument("name", nargs="?", help="preset to show")
    pr.set_defaults(func=_cmd_presets)
    _add_plot(sub, parents)


def _add_run(sub: Subparsers, parents: Parents) -> None:
    run = sub.add_parser(
        "run", help="run the model at one or more flow rates and print the labels",
        description="Run the model from its static on-bottom state at each flow rate "
        "(in parallel threads) and print impacts per cycle Z per surface, the impact scenario "
        "(dissertation Table 4.2), 200 ms peak statistics at x1 and x5 and J*.",
        parents=[parents.length, parents.load, parents.overrides,
                 workers_parent(default=2, what="parallel threads")],
    )
    # default None so that a preset given after --flow (flow_preset) can be told apart
    run.add_argument("preset", nargs="?", default=None,
                     help="tool preset: " + ", ".join(PRESETS) + f" (default {DEFAULT_PRESET})")
    run.add_argument("--flow", nargs="+", default=[200.0], action=FlowsThenPreset,
                     metavar="GPM", help="flow rates in gal/min (default 200); a preset may "
                     "follow them")
    run.add_argument("--method", default="adams", choices=["adams", "bdf"],
                     help="CVODE method (default adams)")
    run.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance (1e-6)")
    run.add_argument("--jobs", dest="workers", type=int, default=argparse.SUPPRESS,
                     help=argparse.SUPPRESS)  # the old name of --workers
    run.add_argument("--json", action="store_true", help="print one JSON object")
    run.set_defaults(func=_cmd_run, flow_preset=None)


def _add_plot(sub: Subparsers, parents: Parents) -> None:
    pl = sub.add_parser(
        "plot", help="draw a figure from a saved sweep/map, or time traces of a run",
        description="peaks / z / j: a flow sweep's peaks (Figs 3.42, 4.27b), Z* (4.27a) or "
        "J* by regime (4.28); regime-map / j-map: a map over flow and a parameter (5.1-5.6); "
        "compare: two flow sweeps, original and changed design (5.7); traces: forces, "
        "indentations and x1 acceleration over the last cycles of a run (4.2-4.6); "
        "--cycles and --analyse apply to traces. "
        "Example: vadsim sweep --out s.nc && vadsim plot peaks s.nc --reference "
        "thesis-7in-cde --out peaks.png",
        parents=[parents.length],
    )
    pl.add_argument("kind", choices=["peaks", "z", "j", "regime-map", "j-map", "compare",
                                     "traces"])
    pl.add_argument("inputs", nargs="*",
                    help="NetCDF file(s) from sweep/map/design; for traces: a preset")
    pl.add_argument("--out", default="figure.png", help="output file (.png, .pdf, .svg)")
    pl.add_argument("--reference", default=None,
                    help="peaks: overlay the dissertation's points, e.g. thesis-7in-cde")
    pl.add_argument("--flow", type=float, default=200.0, help="traces: flow (gal/min)")
    pl.add_argument("--show-cycles", type=float, default=3, help="traces: cycles shown (3)")
    pl.set_defaults(func=_cmd_plot)


def _preset_name(args: argparse.Namespace) -> str:
    if args.preset and args.flow_preset:
        raise ValueError(f"two presets: {args.preset!r} and {args.flow_preset!r} "
                         "(after --flow); give one")
    return args.preset or args.flow_preset or DEFAULT_PRESET


def _row(r: SimulationResult) -> dict[str, float | int | str]:
    z = r.z
    mean1, std1 = r.peak_stats(1)
    mean5, _ = r.peak_stats(5)
    row: dict[str, float | int | str] = {
        "flow_gpm": r.flow_gpm,
        "f_exc_hz": round(r.f_exc_hz, 3),
        **{f"z_{s}": round(z[s], 4) for s in SURFACES[:4]},
        "scenario": r.scenario,
        "regime": regime_name(r.scenario),
        "x1_peak_mean_g": round(mean1, 3),
        "x1_peak_std_g": round(std1, 3),
        "x5_peak_mean_g": round(mean5, 3),
        "j_pos": round(r.impulse_pos, 3),
        "j_mean": round(r.impulse_mean, 3),
        "steps": r.stats["steps"],
        "events": len(r.events),
    }
    if r.m_ref_kg:
        row["j_pos_kN"] = round(r.impulse_pos_kn, 4)
    return row


def _cmd_run(args: argparse.Namespace) -> int:
    overrides = parse_overrides(args.set)
    preset = get_preset(_preset_name(args))
    flows = args.flow

    def one(q: float) -> SimulationResult:
        return simulate(
            preset, q, cycles=args.cycles, analyse_cycles=args.analyse, overrides=overrides,
            wob_klbf=args.wob_klbf, law=args.law, method=args.method, rtol=args.rtol,
            record="none",
        )

    t0 = time.perf_counter()
    workers = max(1, min(args.workers, len(flows)))
    with ThreadPoolExecutor(max_workers=workers) as pool, stop_on_interrupt(pool):
        results = [result(f) for f in [pool.submit(one, q) for q in flows]]
    elapsed = time.perf_counter() - t0
    rows = [_row(r) for r in results]
    if args.json:
        print(json.dumps({"preset": preset.name, "overrides": overrides, "runs": rows,
                          "elapsed_s": round(elapsed, 3)}))
        return 0
    print(f"{preset.name}: {preset.tool} tool, {preset.bit} bit, "
          f"{args.wob_klbf or preset.wob_klbf:g} klbf, {args.cycles:g} cycles "
          f"(last {args.analyse:g} analysed)")
    _print_rows(rows)
    print(f"{len(rows)} runs in {elapsed:.2f} s on {workers} thread(s)")
    print(RUN_TABLE_LEGEND)
    return 0


RUN_TABLE_LEGEND = """\
Q: flow rate; f: excitation frequency (alpha Q / 2 pi). Z1-Z4: impacts per excitation cycle at
the recoil spring (1), the impact face (2), the off-bottom (3) and on-bottom (4) shoulders;
sc: the impact scenario they make (dissertation Table 4.2, named under regime). x1 / x5 peak:
mean of the largest |acceleration| in each 200 ms window at the bit sub (x1) and above the
motor (x5), g, full resolution; +-: the std of the x1 peaks. J*: impulse per second, the
mean of max(F_I, 0) at the impact face, per kg of the reference mass m* (N/kg); x m* = kN."""
"""What each column of ``vadsim run``'s table means, printed under it."""


def _print_rows(rows: list[dict[str, Any]]) -> None:
    print(f"{'Q gal/min':>10} {'f Hz':>6} {'Z1':>6} {'Z2':>6} {'Z3':>6} {'Z4':>6} {'sc':>3} "
          f"{'x1 peak g':>10} {'+-':>6} {'x5 peak g':>10} {'J* N/kg':>8} {'J* kN':>7}  regime")
    for r in rows:
        print(f"{r['flow_gpm']:10.1f} {r['f_exc_hz']:6.2f} {r['z_spring']:6.3f} "
              f"{r['z_impact']:6.3f} {r['z_off_bottom']:6.3f} {r['z_on_bottom']:6.3f} "
              f"{r['scenario']:3d} {r['x1_peak_mean_g']:10.2f} {r['x1_peak_std_g']:6.2f} "
              f"{r['x5_peak_mean_g']:10.2f} {r['j_pos']:8.2f} "
              f"{r.get('j_pos_kN', float('nan')):7.3f}  {r['regime']}")


PRESET_ROLES: dict[str, str] = {
    "7in-cde": "the dissertation's 7in tool, CDE bit; MODEL.md's constants",
    "7in-rc": "the same tool with the RC bit (heavier bit mass m1)",
    "9.5in-pdc": "the 9.5in tool, PDC bit; l0, wob calibrated on its simulations",
    "7in-cde-cal": "7in-cde with l0, wob fitted to the simulated CDE peaks",
    "7in-rc-cal": "7in-rc with 7in-cde-cal's l0, wob",
    "7in-cde-thesis": "7in-cde at theta0 = 2.475 rad: meets chapter 4's five regime bands",
    "7in-rc-thesis": "7in-rc at 7in-cde-thesis' theta0",
}
"""One line per preset: what it is for (``vadsim presets``)."""

PRESETS_FOOTER = """\
wob is the weight on bit per kg of the reference mass m* (N/kg; m* = WOB / wob); theta0 is the
excitation phase at rest (mod pi), gap the impact-face gap as a fraction of the length unit l0.
-cal: the length unit l0 and wob calibrated against the dissertation's simulated peaks and
regime edges (docs/CALIBRATION.md). -thesis: the excitation phase at rest theta0 that the
published lengths cannot fix, chosen so that the regime bands of the dissertation's chapter 4
are met (docs/REPRODUCTION.md); the plain presets keep MODEL.md's convention, so their regime
boundaries differ from the published ones. vadsim presets NAME lists every parameter."""


def _cmd_presets(args: argparse.Namespace) -> int:
    if args.name:
        p = get_preset(args.name)
        print(f"{p.name}: {p.tool} tool, {p.bit} bit, WOB {p.wob_klbf:g} klbf, "
              f"m* = {p.m_ref_kg:.2f} kg, law {p.law}\n{p.note}")
        print(f"Values are per unit reference mass m* = {p.m_ref_kg:.2f} kg: masses in m*, "
              f"stiffnesses in N/m per kg of m*\n(N/m/kg; x m* for N/m), dampings in N s/m per "
              f"kg, forces in N/kg. Lengths in l0 = {p.params['l0']:g} m.")
        for name, unit, meaning, _ in param_table():
            value = p.params.get(name, math.nan)
            shown = "unset" if math.isnan(value) else f"{value:.6g}"
            print(f"  {name:>9} = {shown:<12} {unit:<18} {meaning}")
        print(f"  (theta0 = {p.theta0 % math.pi:.4f} rad mod pi; gap = {p.gap:.6g} l0)")
        return 0
    head = ("preset", "tool", "bit", "WOB klbf", "l0 m", "wob N/kg", "theta0 rad", "gap l0")
    rows = [(p.name, p.tool, p.bit, f"{p.wob_klbf:g}", f"{p.params['l0']:g}",
             f"{p.params['wob']:g}", f"{p.theta0 % math.pi:.3f}", f"{p.gap:.3g}")
            for p in PRESETS.values()]
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    for row in [head, *rows]:
        print("  ".join(c.ljust(w) if i < 3 else c.rjust(w)
                        for i, (c, w) in enumerate(zip(row, widths, strict=True))))
    print("what each is for:")
    for name in PRESETS:
        print(f"  {name:<{widths[0]}}  {PRESET_ROLES.get(name, '')}")
    print(PRESETS_FOOTER)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    from vadsim import plots
    from vadsim.studies.sweep import load_dataset

    if args.kind == "traces":
        preset = args.inputs[0] if args.inputs else DEFAULT_PRESET
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
            figures: dict[str, Callable[..., Figure]] = {
                "peaks": plots.peaks_vs_flow, "z": plots.z_vs_flow, "j": plots.j_vs_flow,
                "regime-map": plots.regime_map, "j-map": plots.j_map}
            fn = figures[args.kind]
            kwargs = {"reference": args.reference} if args.kind == "peaks" and args.reference \
                else {}
            fn(ds[0], path=args.out, **kwargs)
    print(f"figure {args.out}")
    return 0
