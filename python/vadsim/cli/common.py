"""What the sub-commands share: parent parsers, NAME=VALUE parsing, axes and figure names.

Why this module exists: ``--set``, ``--cycles``, ``--wob-klbf`` and the execution options mean
the same thing in every command that takes them, so each is declared once here, in an argparse
*parent parser*, and the commands list the parents they take (``Parents``). A parent is a
factory with default arguments where a command's default differs (``diagnose`` runs 300
cycles, the others 400); commands with the same defaults share one parser object.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from vadsim.model.defaults import DEFAULTS

__all__ = [
    "DEFAULT_PRESET",
    "FIGURE_SUFFIXES",
    "LAWS",
    "Parents",
    "arange",
    "figure_file",
    "figure_path",
    "length_parent",
    "load_parent",
    "make_parents",
    "overrides_parent",
    "pandas_display",
    "parse_overrides",
    "parse_pairs",
    "quiet_parent",
    "scheduler_parent",
    "Subparsers",
    "workers_parent",
]

DEFAULT_PRESET = "7in-cde"
LAWS = ("kelvin_voigt", "kelvin_voigt_no_tension", "hunt_crossley", "power_damping",
        "power_damping_impact")
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


class Subparsers(Protocol):
    """What ``add_parsers`` needs of ``ArgumentParser.add_subparsers()``'s result."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser: ...


def _parent() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(add_help=False)


def overrides_parent() -> argparse.ArgumentParser:
    """``--set NAME=VALUE`` (repeatable): model parameter overrides, see ``parse_overrides``."""
    p = _parent()
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="override a model parameter for every run, e.g. --set kS=4.7e5 "
                   "(repeatable)")
    return p


def length_parent(cycles: float = DEFAULTS.cycles, analyse: float = DEFAULTS.analyse_cycles
                  ) -> argparse.ArgumentParser:
    """``--cycles`` and ``--analyse``: run length and the steady window, in excitation cycles."""
    p = _parent()
    p.add_argument("--cycles", type=float, default=cycles,
                   help="run length in excitation cycles (default %(default)s)")
    p.add_argument("--analyse", type=float, default=analyse,
                   help="steady window: the last N cycles (default %(default)s)")
    return p


def load_parent() -> argparse.ArgumentParser:
    """``--wob-klbf`` (old name ``--wob``) and ``--law``: the load on the bit, the contact law."""
    p = _parent()
    p.add_argument("--wob-klbf", "--wob", dest="wob_klbf", type=float, default=None,
                   metavar="KLBF", help="weight on bit in klbf (default: the preset's)")
    p.add_argument("--law", default=None, choices=LAWS,
                   help="contact law of the impact surfaces (default kelvin_voigt)")
    return p


def workers_parent(default: int | None = None, what: str = "local threads"
                   ) -> argparse.ArgumentParser:
    """``--workers``: how many threads or processes run at once (None: all cores)."""
    p = _parent()
    p.add_argument("--workers", type=int, default=default,
                   help=f"{what} (default: {'all cores' if default is None else default})")
    return p


def scheduler_parent() -> argparse.ArgumentParser:
    """``--scheduler ADDRESS``: run on a Dask cluster instead of local threads."""
    p = _parent()
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster, e.g. tcp://10.0.0.5:8786")
    return p


def quiet_parent() -> argparse.ArgumentParser:
    """``--quiet``: no progress bar or progress lines."""
    p = _parent()
    p.add_argument("--quiet", action="store_true", help="no progress output")
    return p


@dataclass(frozen=True)
class Parents:
    """The parent parsers of one ``build_parser()`` call, shared by the commands that take them.

    A command with different defaults calls the factory itself, e.g.
    ``length_parent(DEFAULTS.recording_cycles)``.
    """

    overrides: argparse.ArgumentParser
    length: argparse.ArgumentParser
    load: argparse.ArgumentParser
    workers: argparse.ArgumentParser
    scheduler: argparse.ArgumentParser
    quiet: argparse.ArgumentParser

    @property
    def execution(self) -> list[argparse.ArgumentParser]:
        """``--workers`` (local threads, default all cores), ``--scheduler``, ``--quiet``."""
        return [self.workers, self.scheduler, self.quiet]


def make_parents() -> Parents:
    return Parents(overrides=overrides_parent(), length=length_parent(), load=load_parent(),
                   workers=workers_parent(), scheduler=scheduler_parent(),
                   quiet=quiet_parent())


def parse_pairs(items: Sequence[str] | None, flag: str, example: str = "") -> dict[str, str]:
    """``["a=1", "b=2"]`` -> ``{"a": "1", "b": "2"}``; a ValueError names ``flag`` otherwise."""
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep:
            hint = f", e.g. {flag} {example}" if example else ""
            raise ValueError(f"{flag} {item!r}: expected NAME=VALUE{hint}")
        out[name.strip()] = value.strip()
    return out


def parse_overrides(items: Sequence[str] | None) -> dict[str, float]:
    """The values of ``--set NAME=VALUE`` as numbers (names are checked by the model)."""
    out: dict[str, float] = {}
    for name, value in parse_pairs(items, "--set", "kS=4.7e5").items():
        try:
            out[name] = float(value)
        except ValueError as exc:
            raise ValueError(f"--set {name}={value}: {value!r} is not a number") from exc
    return out


def arange(lo: float, hi: float, step: float, *, flag: str) -> list[float]:
    """``lo, lo + step, ...`` up to ``hi`` inclusive (within rounding), for axis flags."""
    if not (step > 0) or hi < lo:
        raise ValueError(f"{flag} {lo:g} {hi:g} {step:g}: need FROM <= TO and STEP > 0")
    n = int(round((hi - lo) / step)) + 1
    return [lo + i * step for i in range(n) if lo + i * step <= hi + 1e-9 * max(1.0, abs(hi))]


def figure_file(text: str) -> str:
    """argparse type of ``--plot``: a file name ending in .png, .pdf or .svg."""
    if Path(text).suffix.lower() not in FIGURE_SUFFIXES:
        raise argparse.ArgumentTypeError(
            f"{text!r}: a figure file must end in {', '.join(FIGURE_SUFFIXES)}")
    return text


def figure_path(base: str, kind: str) -> str:
    """The file of one figure of several: ``figure_path("x.pdf", "peaks") == "x-peaks.pdf"``."""
    suffix = Path(base).suffix
    stem = base[: len(base) - len(suffix)] if suffix else base
    return f"{stem}-{kind}{suffix or '.png'}"


@contextmanager
def pandas_display() -> Iterator[None]:
    """Wide pandas tables for the terminal (imports pandas only when a table is printed)."""
    import pandas as pd

    with pd.option_context("display.width", 200, "display.max_columns", 30):
        yield

