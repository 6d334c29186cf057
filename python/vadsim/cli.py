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

from vadsim.labels import regime_name
from vadsim.presets import PRESETS, get_preset, param_table
from vadsim.simulate import SURFACES, SimulationResult, SolverError, simulate

__all__ = ["main"]


def _parse_overrides(items: Sequence[str]) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"--set {item!r}: expected NAME=VALUE, e.g. --set kS=4.7e5")
        try:
            out[name.strip()] = float(value)
        except ValueError as exc:
            raise ValueError(f"--set {item!r}: {value!r} is not a number") from exc
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

    pr = sub.add_parser("presets", help="list the presets, or show one's parameters")
    pr.add_argument("name", nargs="?", help="preset to show")
    pr.set_defaults(func=_cmd_presets)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vadsim`` command."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, SolverError) as exc:
        print(f"vadsim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
