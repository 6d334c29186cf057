"""The ``vadsim`` command line.

Why this package exists: drilling engineers run the model by tool name and flow rate without
writing Python. Every sub-command prints a table a person can read and, with ``--json``, one
JSON object a script can parse. Dependencies point one way: cli -> analysis -> core; nothing
imports cli.

Layout: ``common`` holds the options several commands share (as argparse parent parsers) and
the small parsing helpers; ``run`` (run, presets, plot), ``studies`` (sweep, map, design,
thesis), ``campaigns`` (validate, calibrate, diagnose, blind) and ``imports`` (campaign
import, campaign show) each add their sub-commands
with ``add_parsers(subparsers, parents)`` and hold their handlers.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from vadsim import __version__
from vadsim.cli import campaigns, imports, run, studies
from vadsim.cli.common import make_parents
from vadsim.model.simulation import SolverError

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for the docs and tests)."""
    parser = argparse.ArgumentParser(
        prog="vadsim",
        description="Simulate a vibration-assisted drilling tool: impact regimes, "
        "impulse per second J*, vibration peaks.",
    )
    parser.add_argument("--version", action="version", version=f"vadsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    parents = make_parents()
    for group in (run, studies, campaigns, imports):
        group.add_parsers(sub, parents)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vadsim`` command."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, SolverError, OSError) as exc:
        print(f"vadsim: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # finished work is already kept (a map's store holds every finished chunk)
        print("vadsim: interrupted", file=sys.stderr)
        return 130
