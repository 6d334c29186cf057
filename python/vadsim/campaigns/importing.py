"""Importing a continuous downhole record and a rig's surface log as a campaign.

Why this module exists: a drilling engineer has a memory sub's record (hours of acceleration,
the vendor's columns and units) and the rig's surface log (flow and WOB against time, on
another clock), not a campaign folder. :func:`import_campaign` reads both
(:mod:`~vadsim.campaigns.records`, on the files :mod:`~vadsim.campaigns.sources` opens),
converts the units, checks the record's sampling, aligns the clocks and keeps the
stretches where flow and WOB held steady (:mod:`~vadsim.campaigns.stretches`) as events of a
campaign in RECORDINGS.md's format, with a summary that says what was found, what was refused
and why, and how much each sensor clipped. ``vadsim campaign import`` is the same from the
command line (it also draws the figure, :func:`vadsim.plots.import_figure`).
"""

from __future__ import annotations

import math
import os
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from vadsim._progress import ProgressArg, reporter
from vadsim.campaigns.format import (
    KNOWN_BITS,
    Campaign,
    CampaignError,
    Event,
)
from vadsim.campaigns.records import Record, SurfaceLog, read_record, read_surface_log
from vadsim.campaigns.stretches import (
    ClockAlignment,
    Stretch,
    StretchRules,
    estimate_offset,
    find_stretches,
    vibration_onset,
)
from vadsim.campaigns.writing import save_campaign

__all__ = [
    "IMPORT_SUMMARY",
    "ImportResult",
    "import_campaign",
]

#: The summary an import writes into the campaign folder.
IMPORT_SUMMARY = "import.md"

#: Longest campaign name an import accepts (it goes into every figure title and report).
MAX_NAME_CHARS = 200


@dataclass
class ImportResult:
    """What an import found and wrote.

    Attributes
    ----------
    campaign
        The campaign (events with their samples).
    record, surface
        The files as read.
    alignment
        The clock offset and where it came from.
    stretches
        Every level of the surface log: the events and the refused ones with their reason.
    rules
        What counted as steady.
    folder
        Where the campaign was written (None if it was not).
    """

    campaign: Campaign
    record: Record
    surface: SurfaceLog
    alignment: ClockAlignment
    stretches: list[Stretch]
    rules: StretchRules
    folder: Path | None = None
    clipped: dict[str, tuple[int, int]] = field(default_factory=dict)

    def summary(self, figure: str | None = None, markdown: bool = False) -> str:
        """What was imported: plain text for a terminal, or the Markdown of ``import.md``
        (``markdown=True``; ``figure`` is the image it links)."""
        lines = _summary_lines(self, figure)
        if markdown:
            return "\n".join(lines)
        plain = [line.lstrip("#").lstrip() if line.startswith("#") else line
                 for line in lines if line != "```" and not line.startswith("![")]
        return "\n".join(plain)

    def __repr__(self) -> str:
        return (f"ImportResult({self.campaign.name!r}: {len(self.campaign.events)} events, "
                f"{sum(not s.accepted for s in self.stretches)} stretches refused; "
                f".summary() says which and why)")


# --------------------------------------------------------------------------------------------
# The campaign


def _event(stretch: Stretch, record: Record, event_id: str) -> Event:
    """The event of an accepted stretch: the record's samples over ``kept_s``."""
    assert stretch.kept_s is not None
    lo, hi = stretch.kept_s
    piece = next(p for p in record.pieces if p.t0_s <= lo + 1e-9 and hi <= p.t1_s + 1e-9)
    i0 = max(0, math.ceil((lo - piece.t0_s) * piece.rate_hz - 1e-6))
    i1 = min(piece.n - 1, math.floor((hi - piece.t0_s) * piece.rate_hz + 1e-6))
    n = i1 - i0 + 1
    data = pd.DataFrame({"time_s": np.round(np.arange(n) / record.rate_hz, 7),
                         **{record.sensors[s].column: piece.accel_g[s][i0:i1 + 1]
                            for s in record.sensors}})
    clipped = {s: np.abs(piece.accel_g[s][i0:i1 + 1]) >= sen.range_g
               for s, sen in record.sensors.items()}
    return Event(id=event_id, flow_gpm=round(stretch.flow_gpm, 1),
                 wob_klbf=round(stretch.wob_klbf, 2), file=f"{event_id}.csv", data=data,
                 clipped=clipped)


def _alignment(record: Record, surface: SurfaceLog, clock_offset_s: float | None,
               rules: StretchRules) -> ClockAlignment:
    if clock_offset_s is not None:
        return ClockAlignment(float(clock_offset_s), False)
    first = record.pieces[0]
    accel = np.column_stack([first.accel_g[s] for s in record.sensors])
    onset = vibration_onset(first.t0_s, first.rate_hz, accel, str(first.file))
    return estimate_offset(onset, surface.time_s, surface.flow_gpm, rules.min_flow_gpm,
                           str(surface.file))


def import_campaign(
    record: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    surface: str | os.PathLike[str],
    out: str | os.PathLike[str] | None = None,
    *,
    tool: str,
    bit: str,
    columns: Mapping[str, str],
    surface_columns: Mapping[str, str] | None = None,
    units: str | Mapping[str, str] | None = None,
    time_unit: str | None = None,
    rate_hz: float | None = None,
    dof: Mapping[str, int] | None = None,
    range_g: float | Mapping[str, float] = 250.0,
    lowpass_hz: float | None = None,
    flow_unit: str | None = None,
    wob_unit: str | None = None,
    surface_time_unit: str | None = None,
    clock_offset_s: float | None = None,
    rules: StretchRules | None = None,
    name: str | None = None,
    key: str | None = None,
    sheet: str | int | None = None,
    progress: ProgressArg = False,
) -> ImportResult:
    """Read a downhole record and a surface log and write the steady stretches as a campaign.

    Why so many parameters: each is one fact about a vendor's files that cannot be read from
    them (units, columns, clock offset, tolerances of a steady stretch), keyword-only; a
    wrong one is refused by name.

    Parameters
    ----------
    record
        The downhole record: one file or several (pieces of one record, any order): CSV,
        Parquet, HDF5 or LAS 2.0 (:func:`~vadsim.campaigns.sources.open_table`).
    surface
        The rig's surface log: CSV, Excel or LAS, with time, flow and WOB.
    out
        Campaign folder to write (``campaign.toml``, one CSV per event and ``import.md``);
        None: nothing is written.
    tool, bit
        The tool (``7in``, ``9.5in`` or a preset file) and bit (CDE, RC, PDC).
    columns
        Sensor name -> the record's column, e.g. ``{"x1": "AccZ_bit", "x5": "AccZ_mwd"}``,
        and optionally ``"time"`` -> the time column (default: a column named like time,
        or a LAS file's index curve). A sensor ``x<k>`` sits on degree of freedom k.
    surface_columns
        ``time``, ``flow`` and ``wob`` -> the surface log's columns (default: found by name).
    units
        The accelerations' unit, ``"g"`` or ``"m/s^2"``, for all sensors or per sensor;
        default what the file says (LAS curve units, HDF5/Parquet ``units`` attributes, a
        unit in the column name such as ``AccZ [m/s^2]``). A stated unit must agree with it.
    time_unit, surface_time_unit
        ``s`` or ``ms`` when the file does not say (default seconds; dates are read as such).
    rate_hz
        The record's sampling rate, to check the time column against (it is measured anyway).
    dof
        Degree of freedom of sensors not named ``x1``..``x7``.
    range_g, lowpass_hz
        Each sensor's range (one value or per sensor; samples at it count as clipped) and
        anti-alias corner (None: none).
    flow_unit, wob_unit
        ``gal/min`` or ``L/min``; ``klbf`` or ``kN``, when the log does not say.
    clock_offset_s
        Surface time minus record time for the same instant; None: estimated from when the
        pumps come on (the record must then start quiet).
    rules
        What counts as steady (:class:`~vadsim.campaigns.stretches.StretchRules`).
    name
        Campaign name (default from the record's file name).
    key, sheet
        The HDF5 group of the record, the Excel sheet of the surface log.
    progress
        A callable gets one line per stage (reading, aligning, writing); False: silent.

    Returns
    -------
    ImportResult
        The campaign, every stretch with its fate, the clock alignment; ``summary()``.

    Raises
    ------
    CampaignError
        Naming the file, the column and the problem (a column that does not exist lists the
        ones that do), or when no stretch qualifies (with every refusal's reason).
    """
    if bit not in KNOWN_BITS:
        raise CampaignError(f"bit {bit!r}: one of {', '.join(KNOWN_BITS)}")
    if name is not None and len(name) > MAX_NAME_CHARS:
        raise CampaignError(f"name: {len(name)} characters, more than the import's limit of "
                            f"{MAX_NAME_CHARS} (vadsim.campaigns.importing.MAX_NAME_CHARS)")
    paths = [record] if isinstance(record, str | os.PathLike) else list(record)
    rules = rules or StretchRules()
    say = reporter(progress)
    say(f"reading the downhole record ({len(paths)} file{'s' if len(paths) > 1 else ''})")
    rec = read_record(paths, columns, units=units, time_unit=time_unit, rate_hz=rate_hz,
                      dof=dof, range_g=range_g, lowpass_hz=lowpass_hz, key=key)
    say(f"read {rec.n_samples} samples at {rec.rate_hz:g} Hz; reading the surface log")
    log = read_surface_log(surface, surface_columns, flow_unit=flow_unit, wob_unit=wob_unit,
                           time_unit=surface_time_unit, sheet=sheet)
    alignment = _alignment(rec, log, clock_offset_s, rules)
    say(alignment.describe())
    stretches = find_stretches(log.time_s, log.flow_gpm, log.wob_klbf, rules, alignment,
                               rec.covered)
    events: list[Event] = []
    for st in stretches:
        if st.kept_s is not None:
            st.event_id = f"e{len(events) + 1:02d}"
            events.append(_event(st, rec, st.event_id))
    campaign = Campaign(name=name or f"imported from {Path(paths[0]).name}", tool=tool,
                        bit=bit, wob_klbf=None, sensors=rec.sensors, events=events,
                        description=f"imported by vadsim from {Path(paths[0]).name} "
                        f"(downhole) and {Path(surface).name} (surface log); "
                        f"{alignment.describe()}")
    result = ImportResult(campaign, rec, log, alignment, stretches, rules,
                          clipped=_clipping(rec))
    if not events:
        raise CampaignError("no steady stretch qualifies as an event:\n"
                            + "\n".join(_stretch_lines(result)))
    if out is not None:
        say(f"writing {len(events)} events to {out}")
        write_import(result, out)
    return result


def write_import(result: ImportResult, out: str | os.PathLike[str],
                 figure: str | None = None) -> Path:
    """Write the campaign and its summary (``import.md``, naming ``figure`` if given)."""
    folder = save_campaign(result.campaign, Path(out))
    result.folder = folder
    result.campaign.root = folder
    (folder / IMPORT_SUMMARY).write_text(result.summary(figure, markdown=True) + "\n",
                                         encoding="utf-8")
    return folder


def _clipping(record: Record) -> dict[str, tuple[int, int]]:
    """Per sensor: samples at or beyond its range over the whole record, and all samples."""
    return {s: (sum(int(np.count_nonzero(np.abs(p.accel_g[s]) >= sen.range_g))
                    for p in record.pieces), record.n_samples)
            for s, sen in record.sensors.items()}


# --------------------------------------------------------------------------------------------
# The summary


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.1f} s"
    h, m = divmod(int(round(seconds / 60)), 60)
    return f"{h} h {m} min" if h else f"{m} min"


def _stretch_lines(result: ImportResult) -> list[str]:
    out = ["  (surface clock)", f"  {'':<4} {'from s':>8} {'to s':>8}  {'flow gal/min':>12}  "
           f"{'WOB klbf':>8}  reason"]
    refused = [st for st in result.stretches if not st.accepted]
    for k, st in enumerate(refused, start=1):
        out.append(f"  {'r' + str(k):<4} {st.start_s:8.1f} {st.end_s:8.1f}  "
                   f"{st.flow_gpm:12.1f}  {st.wob_klbf:8.2f}  {st.reason}")
    return out


def _source_lines(result: ImportResult) -> list[str]:
    rec, log = result.record, result.surface
    span = sum(p.t1_s - p.t0_s for p in rec.pieces)
    gaps = f", {len(rec.pieces)} pieces (gaps or files)" if len(rec.pieces) > 1 else ""
    lines = [f"downhole record: {', '.join(str(f) for f in rec.files)}",
             f"  {rec.n_samples} samples at {rec.rate_hz:g} Hz (measured from column "
             f"{rec.time_column!r}), {_duration(span)}{gaps}"]
    for s, sen in rec.sensors.items():
        lines.append(f"  {s} <- {rec.columns[s]!r} in {rec.units[s]}, written in g; "
                     f"dof {sen.dof}, range {sen.range_g:g} g"
                     + (f", low-pass {sen.lowpass_hz:g} Hz" if sen.lowpass_hz else ""))
    period = float(np.median(np.diff(log.time_s)))
    lines += [f"surface log: {log.file}",
              f"  {log.time_s.size} rows every {period:g} s, "
              f"{_duration(float(log.time_s[-1] - log.time_s[0]))}",
              f"  time <- {log.columns['time']!r} in {log.units['time']}",
              f"  flow <- {log.columns['flow']!r} in {log.units['flow']}, written in gal/min",
              f"  WOB <- {log.columns['wob']!r} in {log.units['wob']}, written in klbf",
              *textwrap.wrap(result.alignment.describe(), 96)]
    return lines


def _summary_lines(result: ImportResult, figure: str | None) -> list[str]:
    camp = result.campaign
    where = f" -> {result.folder}" if result.folder else ""
    lines = [f"# Import: {camp.name}{where}", "", "```", *_source_lines(result), "```", "",
             *textwrap.wrap(f"Steady: {result.rules.describe()}.", 96), "",
             f"## {len(camp.events)} events", "", "```",
             "  (record clock)",
             f"  {'event':<6} {'from s':>8} {'to s':>8} {'duration s':>10} {'flow gal/min':>12} "
             f"{'WOB klbf':>8}  clipped samples"]
    stretch_of = {st.event_id: st for st in result.stretches if st.accepted}
    for ev in camp.events:
        lo, hi = stretch_of[ev.id].kept_s or (math.nan, math.nan)
        clips = ", ".join(f"{s} {int(np.count_nonzero(m))}" for s, m in ev.clipped.items())
        lines.append(f"  {ev.id:<6} {lo:8.1f} {hi:8.1f} {hi - lo:10.1f} {ev.flow_gpm:12.1f} "
                     f"{ev.wob_klbf:8.2f}  {clips}")
    refused = [st for st in result.stretches if not st.accepted]
    lines += ["```", "", f"## {len(refused)} stretch{'es' if len(refused) != 1 else ''} "
              "refused", ""]
    lines += (["```", *_stretch_lines(result), "```"] if refused else ["none"])
    lines += ["", "## Clipping per sensor (whole record)", "", "```"]
    for s, (k, n) in result.clipped.items():
        lines.append(f"  {s}: {k} of {n} samples at or beyond +-{camp.sensors[s].range_g:g} g "
                     f"({100.0 * k / max(n, 1):.3f} %)")
    lines.append("```")
    if figure:
        lines += ["", f"![record, surface log and the chosen stretches]({figure})"]
    folder = result.folder or "FOLDER"
    lines += ["", f"Check it: `vadsim campaign show {folder}`; then `vadsim validate {folder}`."]
    return lines
