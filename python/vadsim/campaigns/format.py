"""Field-test campaigns: reading, validating and writing recordings.

Why this module exists: the simulator is only useful if its output can be held against what
downhole accelerometers recorded, and field files are where silent mistakes hide (a dropped
sample, a column bolted to the wrong sensor, a clipped peak taken at face value). So every rule
of the campaign format (``RECORDINGS.md``) is checked here, once, and every violation raises a
:class:`CampaignError` that names the file and the line or TOML key, so that the person holding
the file can fix it. Clipped samples are not an error (real sensors clip) but are flagged per
sample and announced with a warning, because a clipped peak under-reports the vibration.

Format extensions (all optional, all round-tripped by :func:`save_campaign`):

- top-level ``description`` (string): free text, e.g. where the data came from;
- per event ``reference`` (inline table of strings/numbers/booleans): values published for the
  event by someone else (the dissertation's own simulation, for the thesis campaigns).

Unknown keys are rejected rather than ignored, so that a typo such as ``lowpass = 400`` cannot
silently drop a sensor's anti-alias filter from the comparison.

Time check ("uniform at rate_hz within 1e-6 relative"): read as a sampling clock good to 1e-6
relative, printed with 7 decimals. Sample i must lie within
``1e-6 * i / rate_hz + min(1e-7 s, 0.01 / rate_hz)`` of ``t0 + i / rate_hz``. A per-step 1e-6
test would reject the format's own example (``0.0009766`` for 1/1024 s is off by 4e-5
relative); this one still catches a single dropped, repeated or shifted sample.

Numeric precision of :func:`save_campaign`: accelerations are written with Python's shortest
round-trip representation of the float64 value, so they read back bit-identical (float32 data
is widened to float64 first, hence also exact). ``time_s`` is written with a fixed number of
decimals, 7 as in the format's example (more only for rates above 10 kHz), so a time that is not
already on that decimal grid moves by at most half a unit of the last decimal (5e-8 s) on the
first save and is stable afterwards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vadsim._html import grid_table, key_value_table

__all__ = [
    "KNOWN_TOOLS",
    "KNOWN_BITS",
    "FEATURES",
    "CampaignError",
    "ClippedSamplesWarning",
    "Sensor",
    "Event",
    "Campaign",
    "excerpt",
    "CsvLimits",
    "csv_limits",
    "MAX_TOML_BYTES",
    "MAX_WOB_KLBF",
    "MIN_LOWPASS_FRACTION",
    "MAX_NAME_CHARS",
    "MAX_ID_CHARS",
    "MAX_DESCRIPTION_CHARS",
    "MAX_EVENTS",
    "MAX_SENSORS",
    "MAX_RECORDING_S",
    "MAX_SAMPLES",
    "MAX_CSV_FIELD_BYTES",
]

#: Tool presets the project knows by name. Kept as the single source of truth here until the
#: presets module owns the list (it can then re-export or replace this constant).
KNOWN_TOOLS: tuple[str, ...] = ("7in", "9.5in")

#: Bits the model has a bit mass ``m1`` for (MODEL.md).
KNOWN_BITS: tuple[str, ...] = ("CDE", "RC", "PDC")

#: Summary features an event may carry, per sensor, as ``<sensor>_<feature>`` (MODEL.md).
FEATURES: tuple[str, ...] = ("peak_mean_g", "peak_std_g", "impact_hz")

#: Relative error allowed between the recorded sampling clock and ``rate_hz``.
RATE_TOLERANCE = 1e-6

#: Absolute time jitter allowed per sample, on top of the clock tolerance: the format prints
#: ``time_s`` with 7 decimals, so a perfect clock still shows up to 5e-8 s of rounding.
TIME_RESOLUTION_S = 1e-7

#: Name of the campaign description file inside a campaign folder.
CAMPAIGN_FILE = "campaign.toml"

#: How much of a file's text or a TOML value an error message quotes at most (characters).
EXCERPT_CHARS = 80


# --- limits on what a campaign brings (RECORDINGS.md "Limits") ------------------------------
# A campaign folder may come from anyone. Each input is bounded before it is parsed, so that a
# hostile or broken file costs a bounded amount of memory and time and fails with an error
# naming the file and the limit, instead of growing the process until the kernel kills it.

#: Largest weight on bit a campaign may state (klbf): field WOBs are tens of klbf; beyond this
#: the model's static state leaves every physical range.
MAX_WOB_KLBF = 1000.0

#: Lowest anti-alias corner, as a fraction of the sensor's rate (``lowpass_hz >= rate_hz *
#: this``): a corner far below that is no anti-alias filter, and one near zero cannot be
#: designed (the filter's matrix is singular).
MIN_LOWPASS_FRACTION = 1e-3

#: Largest campaign.toml read (bytes): a campaign of a thousand events is a few hundred kB.
MAX_TOML_BYTES = 1 << 20

#: Longest campaign ``name`` (characters); it is drawn into every figure title.
MAX_NAME_CHARS = 200

#: Longest event ``id`` and sensor name (characters); they label tables and figure axes.
MAX_ID_CHARS = 64

#: Longest campaign ``description`` (characters).
MAX_DESCRIPTION_CHARS = 20_000

#: Most events in one campaign.
MAX_EVENTS = 1000

#: Most sensors in one campaign.
MAX_SENSORS = 32

#: Longest recording one event CSV may hold (s of samples at ``rate_hz``): an event is a
#: steady operating point of seconds to minutes; an hour is a generous bound.
MAX_RECORDING_S = 3600.0

#: Most sample rows in one event CSV whatever the rate (8.4 million: 200 MB of float64 at
#: three columns).
MAX_SAMPLES = 1 << 23

#: Longest CSV cell (bytes, padding included): a float64 written in full
#: (``-1.2345678901234567e-308``) takes 24.
MAX_CSV_FIELD_BYTES = 64


@dataclass(frozen=True)
class CsvLimits:
    """What one event CSV may hold, from its sensors' rate and its column count.

    Attributes
    ----------
    max_rows : int
        Sample rows: ``rate_hz * MAX_RECORDING_S``, at most :data:`MAX_SAMPLES`.
    max_line_bytes : int
        Bytes of one line, its end excluded: ``columns * (MAX_CSV_FIELD_BYTES + 1)``.
    max_bytes : int
        Bytes of the whole file: the header and ``max_rows`` lines of the longest kind.
    """

    max_rows: int
    max_line_bytes: int
    max_bytes: int


def csv_limits(rate_hz: float, columns: int) -> CsvLimits:
    """The :class:`CsvLimits` of an event CSV of ``columns`` columns sampled at ``rate_hz``."""
    rows = int(min(MAX_SAMPLES, max(2.0, math.floor(rate_hz * MAX_RECORDING_S))))
    line = columns * (MAX_CSV_FIELD_BYTES + 1)
    return CsvLimits(max_rows=rows, max_line_bytes=line, max_bytes=(rows + 1) * (line + 2))


def excerpt(value: object, limit: int = EXCERPT_CHARS) -> str:
    """``value`` quoted for an error message, cut to ``limit`` characters when longer.

    A string is shown as its repr, ``'abc...' (12345 characters)`` when cut; anything else as
    its repr, cut the same way. Error messages quote field files and TOML values through this
    one helper so that a 200 MB header line never becomes a 200 MB message.
    """
    if isinstance(value, str):
        if len(value) <= limit:
            return repr(value)
        quoted = repr(value[:limit])
        return f"{quoted[:-1]}...{quoted[-1]} ({len(value)} characters)"
    try:
        text = repr(value)
    except ValueError:  # ints beyond sys.get_int_max_str_digits() have no repr
        return f"<{type(value).__name__} too large to print>"
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text)} characters)"


class CampaignError(ValueError):
    """A campaign folder violates the format; the message names the file and line or key."""


class ClippedSamplesWarning(UserWarning):
    """Some samples of an event reached the sensor's range and are flagged as clipped."""


@dataclass
class Sensor:
    """One downhole accelerometer channel.

    Parameters
    ----------
    name : str
        Column prefix in the event CSVs (``<name>_g``) and key in ``[sensors.<name>]``.
    dof : int
        Degree of freedom (1..7) the sensor is bolted to.
    rate_hz : float
        Sampling rate.
    range_g : float
        Full-scale range; samples with ``|a| >= range_g`` are clipped.
    lowpass_hz : float or None
        Anti-alias corner frequency, or None when the sensor has none.
    """

    name: str
    dof: int
    rate_hz: float
    range_g: float
    lowpass_hz: float | None = None

    @property
    def column(self) -> str:
        """Name of this sensor's column in an event CSV."""
        return f"{self.name}_g"


@dataclass(eq=False)
class Event:
    """One steady operating point of a campaign.

    Parameters
    ----------
    id : str
        Identifier, unique within the campaign.
    flow_gpm : float
        Flow rate in gal/min.
    wob_klbf : float
        Weight on bit in klbf (the campaign default already applied).
    file : str or None
        CSV path relative to the campaign folder, or None for a summary-only event.
    features : dict of str to float
        Summary features keyed ``<sensor>_<feature>``.
    data : pandas.DataFrame or None
        Samples: ``time_s`` (s) then one ``<sensor>_g`` column per sensor, in sensor
        declaration order, float64; axial acceleration in g, positive downward.
    clipped : dict of str to numpy.ndarray
        Per sensor name, a boolean mask over the samples, True where ``|a| >= range_g``.
        Derived from ``data`` by :func:`load_campaign`; not part of equality.
    reference : dict
        Values published for this event by others (format extension, see module docstring).
    """

    id: str
    flow_gpm: float
    wob_klbf: float
    file: str | None = None
    features: dict[str, float] = field(default_factory=dict)
    data: pd.DataFrame | None = field(default=None, repr=False)
    clipped: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    reference: dict[str, Any] = field(default_factory=dict)

    @property
    def n_clipped(self) -> int:
        """Total number of clipped samples over all sensors."""
        return int(sum(int(np.count_nonzero(m)) for m in self.clipped.values()))

    def __eq__(self, other: object) -> bool:
        # Written by hand because DataFrame == DataFrame is elementwise, which breaks the
        # dataclass-generated comparison; `clipped` is derived from `data`, so it is skipped.
        if not isinstance(other, Event):
            return NotImplemented
        if (self.id, self.flow_gpm, self.wob_klbf, self.file) != (
            other.id, other.flow_gpm, other.wob_klbf, other.file
        ):
            return False
        if self.features != other.features or self.reference != other.reference:
            return False
        if self.data is None or other.data is None:
            return self.data is None and other.data is None
        return list(self.data.columns) == list(other.data.columns) and np.array_equal(
            self.data.to_numpy(dtype=np.float64), other.data.to_numpy(dtype=np.float64)
        )

    __hash__ = None  # type: ignore[assignment]  # mutable, compared by value


@dataclass
class Campaign:
    """One field test: a tool, a bit, sensors and events.

    Parameters
    ----------
    name : str
        Human-readable name.
    tool : str
        A name in :data:`KNOWN_TOOLS` or a preset file path relative to the campaign folder.
    bit : str
        One of :data:`KNOWN_BITS`.
    wob_klbf : float or None
        Default weight on bit for events that do not give one.
    sensors : dict of str to Sensor
        Keyed by sensor name, in declaration order.
    events : list of Event
        In file order.
    root : pathlib.Path or None
        Folder the campaign was loaded from; not part of equality.
    description : str
        Free text (format extension).
    allow_outside : bool
        Whether a preset-file ``tool`` may lie outside ``root`` (set by
        ``load_campaign(..., allow_outside=True)``); not part of equality.
    """

    name: str
    tool: str
    bit: str
    wob_klbf: float | None
    sensors: dict[str, Sensor]
    events: list[Event]
    root: Path | None = field(default=None, compare=False)
    description: str = ""
    allow_outside: bool = field(default=False, compare=False, repr=False)

    def _repr_html_(self) -> str:
        sensors = "; ".join(f"{s.name} (dof {s.dof}, {s.rate_hz:g} Hz, {s.range_g:g} g)"
                            for s in self.sensors.values())
        head = key_value_table(f"Campaign: {self.name}", [
            ("tool, bit", f"{self.tool}, {self.bit}"),
            ("sensors", sensors or "none"),
            ("events", str(len(self.events))),
            ("folder", str(self.root) if self.root else "in memory"),
        ])
        rows = [(e.id, f"{e.flow_gpm:g}", f"{e.wob_klbf:g}",
                 "time series" if e.data is not None else
                 (", ".join(sorted(e.features)) or "-"))
                for e in self.events]
        return head + grid_table(("event", "flow (gal/min)", "WOB (klbf)", "data"), rows)

    def event(self, event_id: str) -> Event:
        """Return the event with this id.

        Raises
        ------
        KeyError
            If no event has this id.
        """
        for ev in self.events:
            if ev.id == event_id:
                return ev
        raise KeyError(event_id)
