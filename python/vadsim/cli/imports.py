"""``vadsim campaign import`` and ``vadsim campaign show``: bring a recording in, check it.

Why this module exists: a drilling engineer has a memory sub's continuous record and the
rig's surface log, not a campaign folder. ``campaign import`` turns them into one (the work
is :func:`vadsim.campaigns.import_campaign`; the figure :func:`vadsim.plots.import_figure`),
and ``campaign show`` prints what a campaign holds, so that an import is checked before a
diagnosis that takes minutes.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from typing import Any

from vadsim.cli.common import Parents, Subparsers, parse_pairs

__all__ = ["add_parsers"]

_EXAMPLE = ("vadsim campaign import record.csv --surface rig.csv --out my-campaign --tool 7in "
            "--bit CDE --column x1=AccZ_bit --column x5=AccZ_mwd")


def add_parsers(sub: Subparsers, parents: Parents) -> None:
    """Add ``campaign`` with its ``import`` and ``show`` sub-commands."""
    group = sub.add_parser(
        "campaign", help="import a continuous record with a surface log; show a campaign",
        description="Commands on campaign folders (RECORDINGS.md): 'import' writes one from a "
        "downhole record and a rig's surface log, 'show' prints what one holds. "
        f"Example: {_EXAMPLE}; then vadsim campaign show my-campaign.")
    cmds = group.add_subparsers(dest="campaign_command", required=True)
    _add_import(cmds, parents)
    show = cmds.add_parser(
        "show", help="print a campaign's events, flows, WOB, sensors, durations and clipping",
        description="Print what CAMPAIGN holds: tool and bit, each sensor (degree of "
        "freedom, rate, range, low-pass), each event (flow, WOB, duration, samples, clipped "
        "samples per sensor). Check an import here before a long diagnosis.")
    show.add_argument("campaign", help="campaign folder, its campaign.toml, or thesis:7in-cde, "
                      "thesis:7in-rc, thesis:9.5in-pdc")
    show.add_argument("--allow-outside", action="store_true",
                      help="let the campaign read files outside its folder (refused by default)")
    show.set_defaults(func=_cmd_show)


def _add_import(cmds: Any, parents: Parents) -> None:
    im = cmds.add_parser(
        "import", help="a downhole record + a surface log -> a campaign of steady stretches",
        description="Read a downhole record (CSV, Parquet, HDF5 or LAS 2.0; accelerations "
        "in g or m/s^2, the rate measured from its time column) and the rig's surface log "
        "(CSV, Excel or LAS: flow in gal/min or L/min and WOB in klbf or kN against time), "
        "align the two clocks (--clock-offset, or estimated from when the pumps come on), "
        "keep the stretches where flow and WOB held steady as events, and write a campaign "
        "folder (RECORDINGS.md) with import.md (events, refused stretches and why, clipping "
        f"per sensor) and import.png. Example: {_EXAMPLE}",
        parents=[parents.quiet])
    im.add_argument("record", nargs="+", help="the downhole record: one file or its pieces")
    im.add_argument("--surface", required=True, metavar="LOG", help="the rig's surface log")
    im.add_argument("--out", required=True, metavar="CAMPAIGN", help="campaign folder to write")
    im.add_argument("--tool", required=True, help="7in, 9.5in or a preset file")
    im.add_argument("--bit", required=True, choices=["CDE", "RC", "PDC"])
    im.add_argument("--column", action="append", metavar="SENSOR=COLUMN", required=True,
                    help="the record's column of a sensor (repeatable), e.g. --column "
                    "x1=AccZ_bit; x<k> sits on degree of freedom k; time=COLUMN names the "
                    "time column (default: one named like time)")
    im.add_argument("--surface-column", action="append", metavar="ROLE=COLUMN",
                    help="the log's time, flow or wob column, e.g. --surface-column "
                    "flow=SPP_FLOW (default: found by name)")
    im.add_argument("--units", action="append", metavar="UNIT|SENSOR=UNIT",
                    help="accelerations in g or m/s^2 (default: what the file says; a stated "
                    "unit must agree with it)")
    im.add_argument("--time-unit", help="the record's time column: s or ms (default s)")
    im.add_argument("--surface-time-unit", help="the log's time column: s or ms (default s)")
    im.add_argument("--flow-unit", help="gal/min or L/min, when the log does not say")
    im.add_argument("--wob-unit", help="klbf or kN, when the log does not say")
    im.add_argument("--rate", type=float, help="check the record's rate against this (Hz)")
    im.add_argument("--dof", action="append", metavar="SENSOR=K",
                    help="degree of freedom of a sensor not named x1..x7")
    im.add_argument("--range-g", action="append", metavar="G|SENSOR=G",
                    help="sensor range in g; samples at it count as clipped (default 250)")
    im.add_argument("--lowpass-hz", type=float, help="the sensors' anti-alias corner (Hz)")
    _add_rules(im)
    im.add_argument("--name", help="campaign name (default from the record's file name)")
    im.add_argument("--key", help="HDF5: the group holding the record's columns")
    im.add_argument("--sheet", help="Excel: the surface log's sheet (default the first)")
    im.add_argument("--no-figure", action="store_true", help="do not draw import.png")
    im.set_defaults(func=_cmd_import)


def _add_rules(im: argparse.ArgumentParser) -> None:
    im.add_argument("--clock-offset", type=float, metavar="S",
                    help="surface time minus record time, s (default: estimated from when "
                    "the pumps come on; the record must then start quiet)")
    im.add_argument("--flow-tol", type=float, default=10.0,
                    help="flow must stay within this of its level, gal/min (10)")
    im.add_argument("--wob-tol", type=float, default=1.0,
                    help="WOB must stay within this of its level, klbf (1)")
    im.add_argument("--min-duration", type=float, default=8.0,
                    help="shortest event after the settling seconds are dropped, s (8)")
    im.add_argument("--settle", type=float, default=2.0,
                    help="seconds dropped after each change of level (2)")
    im.add_argument("--min-flow", type=float, default=50.0,
                    help="below this flow the pumps are off, gal/min (50)")
    im.add_argument("--max-duration", type=float, help="cut longer stretches to this, s")


def _one_or_many(items: list[str] | None, flag: str, cast: Any) -> Any:
    """``--units g`` -> ``"g"``; ``--units x1=g --units x5=m/s^2`` -> a dict."""
    if not items:
        return None
    if len(items) == 1 and "=" not in items[0]:
        return cast(items[0])
    return {k: cast(v) for k, v in parse_pairs(items, flag, "x1=...").items()}


def _cmd_import(args: argparse.Namespace) -> int:
    from vadsim.campaigns import StretchRules, import_campaign
    from vadsim.campaigns.importing import IMPORT_SUMMARY, write_import

    for name, value in (("--flow-tol", args.flow_tol), ("--wob-tol", args.wob_tol),
                        ("--min-duration", args.min_duration), ("--min-flow", args.min_flow)):
        if not value > 0:
            raise ValueError(f"{name} {value:g}: must be > 0")
    rules = StretchRules(args.flow_tol, args.wob_tol, args.min_duration, args.settle,
                         args.min_flow, args.max_duration)
    say = None if args.quiet else (lambda msg: print(f"  {msg}", file=sys.stderr, flush=True))
    sheet = int(args.sheet) if args.sheet and args.sheet.isdigit() else args.sheet
    result = import_campaign(
        args.record, args.surface, None, tool=args.tool, bit=args.bit,
        columns=parse_pairs(args.column, "--column", "x1=AccZ_bit"),
        surface_columns=parse_pairs(args.surface_column, "--surface-column", "flow=FLOW"),
        units=_one_or_many(args.units, "--units", str), time_unit=args.time_unit,
        rate_hz=args.rate, dof=_one_or_many(args.dof, "--dof", int),
        range_g=_one_or_many(args.range_g, "--range-g", float) or 250.0,
        lowpass_hz=args.lowpass_hz, flow_unit=args.flow_unit, wob_unit=args.wob_unit,
        surface_time_unit=args.surface_time_unit, clock_offset_s=args.clock_offset,
        rules=rules, name=args.name, key=args.key, sheet=sheet, progress=say or False)
    figure = None
    if not args.no_figure:
        from vadsim.plots import import_figure

        figure = "import.png"
        import_figure(result, path=f"{args.out}/{figure}")
    folder = write_import(result, args.out, figure)
    print(result.summary())
    print(f"campaign: {folder} (summary {folder / IMPORT_SUMMARY}"
          + (f", figure {folder / figure})" if figure else ")"))
    return 0


def _cmd_show(args: argparse.Namespace) -> int:
    from vadsim.campaigns import ClippedSamplesWarning, campaign_text, load_any_campaign

    with warnings.catch_warnings():
        # the table counts the clipped samples of every event; the warning would repeat it
        warnings.simplefilter("ignore", ClippedSamplesWarning)
        campaign = load_any_campaign(args.campaign, allow_outside=args.allow_outside)
    print(campaign_text(campaign))
    return 0
