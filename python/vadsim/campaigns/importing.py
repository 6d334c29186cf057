"""Importing a continuous downhole record and a rig's surface log as a campaign.

Why this module exists: a drilling engineer has a memory sub's record (hours of acceleration,
the vendor's columns and units) and the rig's surface log (flow and WOB against time, on
another clock), not a campaign folder. :func:`import_campaign` reads both
(:mod:`~vadsim.campaigns.sources`), converts the units, checks the record's sampling,
aligns the clocks and keeps the stretches where flow and WOB held steady
(:mod:`~vadsim.campaigns.stretches`) as events of a campaign in RECORDINGS.md's format, with
a summary that says what was found, what was refused and why, and how much each sensor
clipped. ``vadsim campaign import`` is the same from the command line (it also draws the
figure, :func:`vadsim.plots.import_figure`).
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
    Sensor,
)
from vadsim.campaigns.sources import (
    Table,
    canonical_unit,
    open_table,
    split_unit,
    unit_factor,
)
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
    "Record",
    "SurfaceLog",
    "import_campaign",
    "read_record",
    "read_surface_log",
]

#: The summary an import writes into the campaign folder.
IMPORT_SUMMARY = "import.md"

#: Largest jitter of a record's time column, in sample periods, before it is refused.
MAX_JITTER = 0.25

#: Longest campaign name an import accepts (it goes into every figure title and report).
MAX_NAME_CHARS = 200

#: How far the rates of the record's pieces (files, or runs between gaps) may differ.
RATE_AGREEMENT = 1e-3

_TIME_NAMES = ("time", "t", "timestamp", "datetime", "date_time", "elapsed", "elapsed_time",
               "seconds", "tim", "etim")
_FLOW_NAMES = ("flow", "flow_rate", "flowrate", "flow_in", "flowin", "mud_flow", "pump_flow",
               "q", "tflo", "mflo")
_WOB_NAMES = ("wob", "weight_on_bit", "bit_weight", "swob")
_EPOCH = np.datetime64("2000-01-01T00:00:00", "ns")


@dataclass
class Piece:
    """A run of the record on one uniform grid: first sample time (record clock, s), rate,
    and each sensor's samples (g)."""

    file: Path
    t0_s: float
    rate_hz: float
    accel_g: dict[str, np.ndarray]

    @property
    def n(self) -> int:
        """Samples in the piece."""
        return next(iter(self.accel_g.values())).size

    @property
    def t1_s(self) -> float:
        """Time of the last sample."""
        return self.t0_s + (self.n - 1) / self.rate_hz


@dataclass
class Record:
    """The downhole record as read: pieces on one rate, the sensors, where each came from."""

    files: list[Path]
    pieces: list[Piece]
    rate_hz: float
    sensors: dict[str, Sensor]
    columns: dict[str, str]
    units: dict[str, str]
    time_column: str

    @property
    def covered(self) -> list[tuple[float, float]]:
        """The record clock spans the record covers, one per piece."""
        return [(p.t0_s, p.t1_s) for p in self.pieces]

    @property
    def n_samples(self) -> int:
        """Samples over all pieces."""
        return sum(p.n for p in self.pieces)


@dataclass
class SurfaceLog:
    """The rig's log as read: time (surface clock, s), flow (gal/min), WOB (klbf)."""

    file: Path
    time_s: np.ndarray
    flow_gpm: np.ndarray
    wob_klbf: np.ndarray
    columns: dict[str, str]
    units: dict[str, str]


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
# Columns and units


def _normal(name: str) -> str:
    for quantity in ("time", "flow", "wob", "acceleration"):
        name = split_unit(name, quantity)[0]
    return name.strip().lower().replace(" ", "_").replace("-", "_")


def _stem(name: str) -> str:
    """A column name without a bracketed unit: ``"AccZ [m/s^2]"`` -> ``"AccZ"``."""
    for quantity in ("acceleration", "time", "flow", "wob"):
        stem, unit = split_unit(name, quantity)
        if unit is not None and stem != name and not name.startswith(stem + "_"):
            return stem.strip()
    return name.strip()


def _pick(table: Table, given: str | None, names: Sequence[str], role: str,
          option: str) -> str:
    """The column for ``role``: the one given (which must exist), else one of ``names``."""
    if given is not None:
        if given in table.columns:
            return given
        stems = [c for c in table.columns if _stem(c) == given.strip()]
        if len(stems) == 1:  # "AccZ_bit" names "AccZ_bit [m/s^2]"
            return stems[0]
        close = [c for c in table.columns if _stem(c).lower() == given.strip().lower()]
        if table.format == "LAS" and len(close) == 1:  # LAS mnemonics ignore case
            return close[0]
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise CampaignError(f"{table.where}: no column {given!r} for {role} ({option}){hint}; "
                            f"the columns are {table.listing()}")
    found = [c for c in table.columns if _normal(c) in names]
    if table.index_column is not None and role == "time" and not found:
        found = [table.index_column]
    if not found:
        raise CampaignError(f"{table.where}: no {role} column found (looked for "
                            f"{', '.join(names[:6])}, ...); name it with {option}=COLUMN; "
                            f"the columns are {table.listing()}")
    return found[0]


def _unit(table: Table, column: str, quantity: str, stated: str | None,
          option: str) -> tuple[str, str]:
    """The unit of a column (canonical) and where it came from; the stated one must agree
    with what the file says."""
    choices = " or ".join(f"{option} {u}" for u in list(_QUANTITY_UNITS[quantity])[:2])
    raw = table.units.get(column)
    from_file = canonical_unit(raw, quantity)
    if raw and from_file is None and stated is None:
        raise CampaignError(f"{table.where}: column {column!r} is in {raw!r}, not a unit of "
                            f"{quantity} the import knows ({', '.join(_QUANTITY_UNITS[quantity])})"
                            f"; state it: {choices}")
    from_name = split_unit(column, quantity)[1]
    found, how = ((from_file, "from the file") if from_file else
                  (from_name, "from the column name") if from_name else (None, ""))
    if stated is not None:
        unit = canonical_unit(stated, quantity)
        if unit is None:
            raise CampaignError(f"{option} {stated!r}: not a unit of {quantity} (one of "
                                f"{', '.join(_QUANTITY_UNITS[quantity])})")
        if found is not None and found != unit:
            raise CampaignError(f"{table.where}: column {column!r} is in {found} ({how}), "
                                f"but {option} says {unit}")
        return unit, "stated"
    if found is None:
        raise CampaignError(f"{table.where}: column {column!r}: the file does not say its unit;"
                            f" state it: {choices}")
    return found, how


_QUANTITY_UNITS = {"acceleration": ("g", "m/s^2"), "flow": ("gal/min", "L/min", "m3/min"),
                   "wob": ("klbf", "kN", "lbf"), "time": ("s", "ms", "min", "h")}


def _seconds(values: np.ndarray, table: Table, column: str, stated: str | None,
             option: str) -> tuple[np.ndarray, str]:
    """A time column in seconds: dates as seconds since 2000-01-01, numbers by their unit
    (seconds when neither the file nor the name says)."""
    if np.issubdtype(values.dtype, np.datetime64):
        ns = (values.astype("datetime64[ns]") - _EPOCH).astype(np.int64)
        return ns.astype(np.float64) / 1e9, "dates"
    raw = table.units.get(column)
    if stated is None and canonical_unit(raw, "time") is None and \
            split_unit(column, "time")[1] is None:
        return values.astype(np.float64), "s (assumed)"
    unit, how = _unit(table, column, "time", stated, option)
    return values * unit_factor(unit, "time"), f"{unit} ({how})"


# --------------------------------------------------------------------------------------------
# The record


def _pieces(t: np.ndarray, where: str, column: str) -> list[tuple[int, int, float]]:
    """Runs of a uniform time grid between gaps: ``(first, last, rate)``; refuses time that
    does not increase or wanders off its grid by more than MAX_JITTER of a period."""
    if t.size < 2:
        raise CampaignError(f"{where}: fewer than 2 samples")
    steps = np.diff(t)
    bad = np.flatnonzero(~(steps > 0))
    if bad.size:
        k = int(bad[0]) + 1
        raise CampaignError(f"{where}: time column {column!r}, row {k}: {t[k]!r} s does not "
                            f"increase (previous row {t[k - 1]!r} s)")
    dt = float(np.median(steps))
    cuts = np.flatnonzero(steps > 1.5 * dt) + 1
    out = []
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, t.size], strict=True):
        a, b = int(a), int(b) - 1
        step = (t[b] - t[a]) / (b - a) if b > a else dt
        dev = np.abs(t[a:b + 1] - (t[a] + np.arange(b - a + 1) * step))
        if dev.size and float(dev.max()) > MAX_JITTER * step:
            k = a + int(np.argmax(dev))
            raise CampaignError(f"{where}: time column {column!r}, row {k}: {t[k]!r} s is "
                                f"{dev.max() / step:.2f} sample periods off the uniform grid "
                                f"(at most {MAX_JITTER:g}): the sampling is not uniform")
        out.append((a, b, 1.0 / step))
    return out


def _nice_rate(rate: float) -> float:
    near = round(rate)
    return float(near) if abs(rate - near) <= 1e-6 * rate else float(f"{rate:.9g}")


def _record_file(path: Path, columns: Mapping[str, str], units: Mapping[str, str | None],
                 time_unit: str | None, key: str | None) -> tuple[list[Piece], dict, str]:
    """One record file as pieces, with each sensor's (column, unit, how)."""
    table = open_table(path, key=key)
    time_col = _pick(table, columns.get("time"), _TIME_NAMES, "time", "--column time")
    sensors = {s: _pick(table, c, (), f"sensor {s}", f"--column {s}")
               for s, c in columns.items() if s != "time"}
    info = {s: (c, *_unit(table, c, "acceleration", units.get(s), "--units"))
            for s, c in sensors.items()}
    data = table.read([time_col, *dict.fromkeys(sensors.values())])
    t, _ = _seconds(data[time_col], table, time_col, time_unit, "--time-unit")
    pieces = []
    for a, b, rate in _pieces(t, table.where, time_col):
        accel = {s: data[c][a:b + 1] * unit_factor(info[s][1], "acceleration")
                 for s, c in sensors.items()}
        pieces.append(Piece(path, float(t[a]), rate, accel))
    return pieces, info, time_col


def read_record(paths: Sequence[str | os.PathLike[str]], columns: Mapping[str, str],
                *, units: str | Mapping[str, str] | None = None, time_unit: str | None = None,
                rate_hz: float | None = None, dof: Mapping[str, int] | None = None,
                range_g: float | Mapping[str, float] = 250.0,
                lowpass_hz: float | None = None, key: str | None = None) -> Record:
    """Read a downhole record (one or more files, in any order) onto one sampling grid.

    Parameters are those of :func:`import_campaign`. The rate is measured from the time
    column (gaps split the record into pieces) and must agree with ``rate_hz`` when given.
    """
    if not paths:
        raise CampaignError("no downhole record given")
    sensor_names = [s for s in columns if s != "time"]
    if not sensor_names:
        raise CampaignError("no sensor column chosen: name one per sensor, e.g. "
                            "--column x1=AccZ_bit (a sensor x<k> sits on degree of freedom k)")
    unit_map = ({s: units for s in sensor_names} if isinstance(units, str) or units is None
                else dict(units))
    pieces: list[Piece] = []
    info: dict = {}
    time_col = ""
    for p in paths:
        got, info, time_col = _record_file(Path(p), columns, unit_map, time_unit, key)
        pieces += got
    pieces.sort(key=lambda pc: pc.t0_s)
    longest = max(pieces, key=lambda pc: pc.n)
    rate = _nice_rate(longest.rate_hz)
    for pc in pieces:
        if abs(pc.rate_hz - rate) > RATE_AGREEMENT * rate and pc.n > 1:
            raise CampaignError(f"{pc.file}: sampled at {pc.rate_hz:.6g} Hz from "
                                f"{pc.t0_s:.3f} s, but the record's rate is {rate:.6g} Hz")
        pc.rate_hz = rate
    if rate_hz is not None and abs(rate - rate_hz) > RATE_AGREEMENT * rate_hz:
        raise CampaignError(f"{longest.file}: the time column {time_col!r} says "
                            f"{rate:.6g} Hz, but the rate given is {rate_hz:g} Hz")
    for a, b in zip(pieces, pieces[1:], strict=False):
        if b.t0_s <= a.t1_s:
            raise CampaignError(f"{b.file}: starts at {b.t0_s:.3f} s, inside {a.file} (which "
                                f"ends at {a.t1_s:.3f} s): the record's files overlap")
    return Record([Path(p) for p in paths], pieces, rate,
                  _sensors(sensor_names, rate, dof, range_g, lowpass_hz),
                  {s: info[s][0] for s in sensor_names},
                  {s: f"{info[s][1]} ({info[s][2]})" for s in sensor_names}, time_col)


def _sensors(names: Sequence[str], rate: float, dof: Mapping[str, int] | None,
             range_g: float | Mapping[str, float], lowpass_hz: float | None) -> dict:
    out = {}
    for s in names:
        d = (dof or {}).get(s)
        if d is None and len(s) == 2 and s[0] == "x" and s[1] in "1234567":
            d = int(s[1])
        if d is None:
            raise CampaignError(f"sensor {s!r}: which degree of freedom (1..7) is it on? "
                                f"Name sensors x1..x7, or give --dof {s}=K")
        rng = range_g if isinstance(range_g, int | float) else range_g.get(s, 250.0)
        out[s] = Sensor(s, int(d), rate, float(rng), lowpass_hz)
    return out


# --------------------------------------------------------------------------------------------
# The surface log


def read_surface_log(path: str | os.PathLike[str], columns: Mapping[str, str] | None = None,
                     *, flow_unit: str | None = None, wob_unit: str | None = None,
                     time_unit: str | None = None, sheet: str | int | None = None
                     ) -> SurfaceLog:
    """Read a rig's surface log: time, flow (gal/min or L/min) and WOB (klbf or kN).

    ``columns`` maps ``time``, ``flow`` and ``wob`` to the file's column names; a role not
    given is looked for under common names (``flow``, ``Flow (L/min)``, ``wob_kn``, ...).
    """
    columns = dict(columns or {})
    unknown = set(columns) - {"time", "flow", "wob"}
    if unknown:
        raise CampaignError(f"surface columns are time, flow and wob; got {sorted(unknown)}")
    table = open_table(Path(path), sheet=sheet)
    names = {"time": _TIME_NAMES, "flow": _FLOW_NAMES, "wob": _WOB_NAMES}
    chosen = {r: _pick(table, columns.get(r), names[r], r, f"--surface-column {r}")
              for r in ("time", "flow", "wob")}
    flow_u, flow_how = _unit(table, chosen["flow"], "flow", flow_unit, "--flow-unit")
    wob_u, wob_how = _unit(table, chosen["wob"], "wob", wob_unit, "--wob-unit")
    data = table.read(list(dict.fromkeys(chosen.values())))
    t, t_how = _seconds(data[chosen["time"]], table, chosen["time"], time_unit,
                        "--surface-time-unit")
    order = np.diff(t)
    bad = np.flatnonzero(~(order > 0))
    if bad.size:
        k = int(bad[0]) + 1
        raise CampaignError(f"{table.where}: time column {chosen['time']!r}, row {k}: does "
                            f"not increase ({t[k - 1]!r} then {t[k]!r} s)")
    if t.size < 3:
        raise CampaignError(f"{table.where}: fewer than 3 rows")
    return SurfaceLog(Path(path), t, data[chosen["flow"]] * unit_factor(flow_u, "flow"),
                      data[chosen["wob"]] * unit_factor(wob_u, "wob"), chosen,
                      {"time": t_how, "flow": f"{flow_u} ({flow_how})",
                       "wob": f"{wob_u} ({wob_how})"})


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
