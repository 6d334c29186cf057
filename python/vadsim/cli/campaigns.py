"""Commands on recorded campaigns: ``validate``, ``calibrate``, ``diagnose`` and ``blind``.

Why this module exists: these commands compare the model with recordings (RECORDINGS.md) and
write reports; the comparison, fitting and report code lives in ``vadsim.fit`` and
``vadsim.report``, imported inside the handlers.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from vadsim.cli.common import (
    Parents,
    Subparsers,
    length_parent,
    pandas_display,
    parse_overrides,
    parse_pairs,
    workers_parent,
)
from vadsim.model.defaults import DEFAULTS

__all__ = ["add_parsers", "parse_bounds"]


def add_parsers(sub: Subparsers, parents: Parents) -> None:
    """Add ``validate``, ``calibrate``, ``diagnose`` and ``blind`` to the sub-commands."""
    va = sub.add_parser(
        "validate", help="simulate a campaign's events and compare features with the recordings",
        description="Simulate every event of CAMPAIGN (a folder with campaign.toml, the toml "
        "file, or a shipped campaign: thesis:7in-cde, thesis:7in-rc, thesis:9.5in-pdc) at its "
        "flow and WOB, pass each sensor's simulated acceleration through its chain, compute "
        "the same features on both sides and write a report (tables, peaks vs flow, "
        "standardised mismatch heat map).",
        parents=[parents.overrides, parents.length, *parents.execution],
    )
    _add_campaign_argument(va)
    _add_report_options(va, "validation")
    _add_cache_option(va)
    va.set_defaults(func=_cmd_validate)
    _add_calibrate(sub, parents)
    _add_diagnose(sub, parents)
    bl = sub.add_parser(
        "blind", help="blind benchmark of diagnose on classes of campaigns with concealed physics",
        description="Write campaigns (RECORDINGS.md format) in classes -- nulls, a nuisance "
        "(WOB reading, excitation phase at rest) only, an effect under a nuisance, pairs of "
        "effects, generic effects, one-sensor effects, the RC bit, five events, 1 g noise, "
        "and indep_* classes written by an independent simulator and sensor chain "
        "(--list) -- through the sensor chain with noise, under neutral shuffled names; "
        "diagnose each from disk without the truth; score per class and overall "
        "(identification, variants, false alarms, parameter error, held-out improvement, "
        "nuisance recovery, interval coverage, regret against the truth, PASS/FAIL per acceptance "
        "criterion) in scores.md and scores.json. "
        "Resumes from finished results in OUT/results; more classes can be added to OUT later.",
        parents=[workers_parent(what="worker processes per diagnosis"), parents.quiet],
    )
    bl.add_argument("--out", default="blind-benchmark", help="folder (default blind-benchmark)")
    bl.add_argument("--classes", type=lambda t: [c.strip() for c in t.split(",") if c.strip()],
                    metavar="A,B", help="only these classes (default all; see --list)")
    bl.add_argument("--list", action="store_true",
                    help="print the classes, their campaign counts and what each tests; no run")
    bl.add_argument("--duration", type=float, default=None,
                    help="seconds per event for every campaign (default each scenario's, 8)")
    bl.add_argument("--seed", type=int, default=2026)
    bl.add_argument("--score-finished", action="store_true",
                    help="score the campaigns already diagnosed in OUT and run nothing (e.g. "
                    "while a long run is stopped); the scores say how many they cover")
    bl.add_argument("--no-regret", action="store_true",
                    help="skip the regret against the truth (the chosen and the true model "
                    "evaluated after each diagnosis; a few seconds a campaign)")
    bl.set_defaults(func=_cmd_blind)


def _add_cache_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cache", metavar="DIR", default=None,
                   help="keep every measured run in DIR and read the ones a previous "
                   "diagnosis, calibration or validation made (default: $VADSIM_CACHE if "
                   "set, else none); a run is reused only with the same inputs and code")


def _add_report_options(p: argparse.ArgumentParser, folder: str) -> None:
    p.add_argument("--out", default=folder, help=f"report folder (default {folder})")
    p.add_argument("--format", default="md", choices=["md", "html"], help="report format")


def _add_calibrate(sub: Subparsers, parents: Parents) -> None:
    ca = sub.add_parser(
        "calibrate", help="fit parameters to a campaign (robust least squares, global stage)",
        description="Fit --param parameters to CAMPAIGN's features by robust least squares "
        "on standardised residuals: differential evolution within the bounds, then a local "
        "soft-L1 polish; prints estimates with standard errors and the fit before and after. "
        "--set fixes other parameters. "
        "Example (the 9.5in withheld constants against the dissertation's simulations): "
        "vadsim calibrate thesis:9.5in-pdc --param l0 --param wob --targets thesis-sim "
        "--resolution full",
        parents=[parents.overrides, parents.length, *parents.execution],
    )
    _add_campaign_argument(ca)
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
    ca.add_argument("--interval", dest="interval_method", default="auto",
                    choices=["auto", "bootstrap", "profile"],
                    help="how far the cost may rise inside a 95 %% interval: measured on "
                    "campaigns the fitted model writes (bootstrap), chi2(1) s^2 (profile), "
                    "or the bootstrap where the targets are recorded time series (auto)")
    ca.add_argument("--n-boot", type=int, default=50,
                    help="bootstrap: campaigns the fitted model writes (50)")
    ca.add_argument("--noise-g", type=float, default=0.3,
                    help="bootstrap: the sensors' noise, g RMS (0.3)")
    ca.add_argument("--json", action="store_true")
    ca.set_defaults(func=_cmd_calibrate)


def _add_diagnose(sub: Subparsers, parents: Parents) -> None:
    dg = sub.add_parser(
        "diagnose", help="locate a mismatch, fit candidate physics, select on held-out events",
        description="Calibrate the base model's nuisance constants (WOB scale, excitation "
        "phase at rest), compare it with CAMPAIGN feature by feature, say where they "
        "disagree, fit every candidate physics with the nuisance constants, select effects "
        "one at a time on held-out events (leave-one-flow-out and a high-flow block, AICc), "
        "and give a verdict: the missing physics, 'none', or an unexplained mismatch. "
        "Writes a report (diagnosis.md/.html, diagnosis.json, figures). Example: "
        "vadsim diagnose thesis:7in-cde --predict thesis:7in-rc --json",
        parents=[parents.overrides, length_parent(cycles=DEFAULTS.recording_cycles), parents.quiet,
                 workers_parent(what="worker processes for the candidates"),
                 parents.scheduler],
    )
    _add_campaign_argument(dg)
    _add_report_options(dg, "diagnosis")
    dg.add_argument("--json", action="store_true",
                    help="print one JSON object (missing_physics, parameters, located, "
                    "heldout_error_before/after, ranking); progress goes to stderr")
    _add_cache_option(dg)
    dg.add_argument("--candidates", nargs="+", default=None,
                    help="candidate ids to try (default: all)")
    dg.add_argument("--predict", metavar="CAMPAIGN",
                    help="predict another campaign with the chosen physics (nothing refitted)")
    dg.add_argument("--phases", type=int, default=4,
                    help="sampling phases the simulated features average over (4)")
    dg.add_argument("--min-delta", type=float, default=10.0,
                    help="held-out AICc margin a candidate needs over 'none' (10)")
    dg.add_argument("--min-reduction", type=float, default=0.3,
                    help="held-out RMS reduction a candidate needs, fraction (0.3)")
    dg.add_argument("--nuisance", action="append", metavar="NAME=LO:HI", default=None,
                    help="a constant fitted with every hypothesis (repeatable; default: "
                    "wob_scale=0.85:1.15 and theta0=0:3.1416; NAME: wob_scale, theta0 or a "
                    "model parameter); given ones replace a default of the same name")
    dg.add_argument("--no-nuisance", action="store_true",
                    help="fit no nuisance constant (the base model's values are taken as exact)")
    dg.add_argument("--max-effects", type=int, default=3,
                    help="most effects forward selection adds (3)")
    dg.add_argument("--max-rms", type=float, default=2.0,
                    help="held-out RMS z above which the verdict is 'unexplained' (2)")
    dg.add_argument("--noise-draws", type=int, default=20, metavar="N",
                    help="campaigns the base model writes itself before 'none' is given: "
                    "'none' only up to the 97.5 %% quantile of their RMS z, the upper edge of "
                    "their 95 %% band (20; 0: on --max-rms alone)")
    dg.add_argument("--intervals", choices=("profile", "walk", "search"), default="profile",
                    help="how far the reported model's 95 %% intervals are searched with new "
                    "runs: 'profile' (default) walks out from the optimum and follows the "
                    "profile across islands of the cost, 'walk' only walks, 'search' reads the "
                    "search's own points (no new run; narrowest)")
    dg.add_argument("--no-review", action="store_true",
                    help="skip the review of the chosen model (each effect refitted as its "
                    "variants, and each one not needed on top of the others dropped)")
    dg.set_defaults(func=_cmd_diagnose)


def _campaign(args: argparse.Namespace) -> Any:
    """The campaign named on the command line, loaded (outside its folder only if allowed)."""
    from vadsim.campaigns import load_any_campaign

    return load_any_campaign(args.campaign, allow_outside=args.allow_outside)


def _add_campaign_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("campaign", help="campaign folder, its campaign.toml, or thesis:7in-cde, "
                   "thesis:7in-rc, thesis:9.5in-pdc")
    p.add_argument("--allow-outside", action="store_true",
                   help="let the campaign read files outside its folder (refused by default)")


def _cmd_validate(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    # read (and refuse) the campaign before the fitting and report modules are imported
    campaign = _campaign(args)
    from vadsim.fit.validate import validate
    from vadsim.report.validation import write_validation_report

    res = validate(campaign, overrides=parse_overrides(args.set),
                   cycles=args.cycles, analyse_cycles=args.analyse, workers=args.workers,
                   progress=not args.quiet, cache=args.cache)
    cmd = "vadsim validate " + " ".join(sys.argv[2:]) if len(sys.argv) > 2 else None
    path = write_validation_report(res, args.out, fmt=args.format, command=cmd)
    z = res.residuals
    with pandas_display():
        print(f"{res.campaign.name}: {len(res.campaign.events)} events simulated in "
              f"{time.perf_counter() - t0:.1f} s with preset {res.preset.name}")
        print("standardised residuals (model through the sensor chain - recorded) / spread:")
        print(z.round(2).to_string())
    print(f"report: {path}")
    return 0


def parse_bounds(items: list[str] | None) -> dict[str, tuple[float, float]]:
    """``--bounds NAME=LO:HI`` (repeatable) -> ``{NAME: (LO, HI)}``."""
    bounds = {}
    for name, text in parse_pairs(items, "--bounds").items():
        lo, sep, hi = text.partition(":")
        if not sep:
            raise ValueError(f"--bounds {name}={text}: expected LO:HI")
        bounds[name] = (float(lo), float(hi))
    return bounds


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from vadsim.fit.calibrate import calibrate

    bounds = parse_bounds(args.bounds)
    start = {k: float(v) for k, v in parse_pairs(args.start, "--start").items()}

    def report(stage: str, n: int, cost: float, vals: dict) -> None:
        if not args.quiet and n % 10 == 0:
            print(f"  [{stage}] evaluation {n}: cost {cost:.4g} at "
                  + ", ".join(f"{k}={v:.5g}" for k, v in vals.items()), flush=True)

    global_stages: dict[str, bool | str] = {"scan": "scan", "de": "de", "none": False}
    res = calibrate(_campaign(args), args.param, bounds=bounds or None, start=start or None,
                    targets=args.targets, keys=args.keys, resolution=args.resolution,
                    overrides=parse_overrides(args.set),
                    global_stage=global_stages[args.global_stage],
                    n_global=args.n_global, n_starts=args.starts,
                    popsize=args.popsize, maxiter=args.maxiter, seed=args.seed,
                    profile_points=args.profile, interval_method=args.interval_method,
                    n_boot=args.n_boot, noise_g=args.noise_g, cycles=args.cycles,
                    analyse_cycles=args.analyse, workers=args.workers, callback=report,
                    progress=not args.quiet)
    if args.json:
        print(json.dumps({"estimates": res.estimates, "interval": res.interval,
                          "threshold": res.threshold, "interval_method": res.interval_method,
                          "stderr": res.stderr, "start": res.start, "cost_before": res.cost_before,
                          "cost_after": res.cost_after, "evaluations": res.evaluations,
                          "seconds": round(res.seconds, 2)}))
        return 0
    print(res.summary())
    with pandas_display():
        print("standardised residuals before:")
        print(res.residuals_before.round(2).to_string())
        print("after:")
        print(res.residuals_after.round(2).to_string())
        for name, prof in res.profile.items():
            print(f"profile of the cost along {name}:")
            print(prof.round(4).to_string(index=False))
    return 0


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from vadsim.fit.diagnosis.pipeline import diagnose, predict
    from vadsim.fit.diagnosis.policy import Policy
    from vadsim.fit.nuisance import DEFAULT_NUISANCE
    from vadsim.report.diagnosis import write_diagnosis_report

    nuisance: list[Any] = [] if args.no_nuisance else [*DEFAULT_NUISANCE, *(args.nuisance or [])]
    campaign, overrides = _campaign(args), parse_overrides(args.set)
    diag = diagnose(campaign, candidates=args.candidates, nuisance=nuisance,
                    overrides=overrides, cycles=args.cycles,
                    analyse_cycles=args.analyse, phases=args.phases,
                    min_delta=args.min_delta, min_reduction=args.min_reduction,
                    max_effects=args.max_effects, max_rms=args.max_rms,
                    policy=Policy(noise_draws=args.noise_draws,
                                  interval_search=args.intervals),
                    review=not args.no_review, workers=args.workers,
                    progress=not args.quiet, cache=args.cache, scheduler=args.scheduler)
    if args.predict:
        predict(diag, args.predict, workers=args.workers, cache=args.cache)
    path = write_diagnosis_report(diag, args.out, fmt=args.format)
    if args.json:
        print(json.dumps(diag.as_json()))
        return 0
    print(diag.summary())
    print(f"report: {path}")
    return 0


def _cmd_blind(args: argparse.Namespace) -> int:
    from vadsim.blind import CLASSES, blind_benchmark, class_counts, scenarios_of

    if args.list:
        counts = class_counts()
        width = max(len(c) for c in counts)
        for name, n in counts.items():
            print(f"{name:{width}s} {n:3d}  {CLASSES.get(name, '')}")
        print(f"{'total':{width}s} {sum(counts.values()):3d}")
        return 0
    scenarios_of(args.classes)  # an unknown class: exit 2 before any work
    sc = blind_benchmark(args.out, args.classes, duration_s=args.duration, seed=args.seed,
                         workers=args.workers, finished_only=args.score_finished,
                         regrets=not args.no_regret,
                         progress=False if args.quiet else lambda m: print(f"  {m}", flush=True))
    print(Path(args.out, "scores.md").read_text())
    return 0 if sc["campaigns"] else 1
