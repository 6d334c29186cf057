"""The two inputs of an import as read: a continuous downhole record and a rig's surface log.

Why this module exists: :func:`~vadsim.campaigns.importing.import_campaign` needs the record
on one sampling grid (in g, its pieces between gaps or files, the rate measured and checked)
and the surface log in gal/min and klbf on its own clock, each column found by name or as
given and each unit taken from the file, the column name or the user, with an error that
names the file, the column and the problem. :func:`read_record` and :func:`read_surface_log`
do this on the tables :mod:`~vadsim.campaigns.sources` opens; finding the steady stretches
and writing the campaign are the import's.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vadsim.campaigns.format import CampaignError, Sensor
from vadsim.campaigns.sources import (
    Table,
    canonical_unit,
    open_table,
    split_unit,
    unit_factor,
)

__all__ = [
    "Record",
    "SurfaceLog",
    "read_record",
    "read_surface_log",
]

#: Largest jitter of a record's time column, in sample periods, before it is refused.
MAX_JITTER = 0.25

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

    Why so many parameters: a vendor's record needs what its file does not say (columns, units,
    rate, time format); each is keyword-only, read from the file where it can be.

    Parameters are those of :func:`~vadsim.campaigns.importing.import_campaign`. The rate is
    measured from the time column (gaps split the record into pieces) and must agree with
    ``rate_hz`` when given.
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
