"""Reading a campaign (RECORDINGS.md): every rule checked once, every violation a
:class:`~vadsim.campaigns.format.CampaignError` naming the file and the line or TOML key
(found by :class:`~vadsim.campaigns.toml_keys.TomlContext`)."""

from __future__ import annotations

import math
import os
import tomllib
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from vadsim.campaigns.event_csv import open_regular, read_event_csv
from vadsim.campaigns.format import (
    CAMPAIGN_FILE,
    EXCERPT_CHARS,
    FEATURES,
    KNOWN_BITS,
    KNOWN_TOOLS,
    MAX_DESCRIPTION_CHARS,
    MAX_EVENTS,
    MAX_ID_CHARS,
    MAX_NAME_CHARS,
    MAX_SENSORS,
    MAX_TOML_BYTES,
    MAX_WOB_KLBF,
    MIN_LOWPASS_FRACTION,
    Campaign,
    CampaignError,
    ClippedSamplesWarning,
    Event,
    Sensor,
    excerpt,
)
from vadsim.campaigns.toml_keys import BARE_KEY_RE, TomlContext

__all__ = ["CampaignPathError", "campaign_path", "load_campaign", "parse_document",
           "tool_file"]

_TOP_KEYS = ("name", "tool", "bit", "wob_klbf", "description", "sensors", "events")
_SENSOR_KEYS = ("dof", "rate_hz", "range_g", "lowpass_hz")
_EVENT_KEYS = ("id", "flow_gpm", "wob_klbf", "file", "features", "reference")


def _type_name(value: object) -> str:
    names = {bool: "boolean", int: "integer", float: "float", str: "string", dict: "table",
             list: "array"}
    return names.get(type(value), type(value).__name__)


def _get_str(ctx: TomlContext, table: Mapping[str, Any], path: tuple[str | int, ...],
             required: bool = True, label: str = "", limit: int | None = None) -> str | None:
    key = str(path[-1])
    if key not in table:
        if required:
            ctx.fail(path, "required key is missing", label)
        return None
    value = table[key]
    if not isinstance(value, str):
        ctx.fail(path, f"must be a string, got {_type_name(value)} {excerpt(value)}", label)
    if not value.strip():
        ctx.fail(path, "must not be empty", label)
    if limit is not None and len(value) > limit:
        ctx.fail(path, f"longer than {limit} characters ({len(value)}), the limit for this key",
                 label)
    return value


def _get_number(ctx: TomlContext, table: Mapping[str, Any], path: tuple[str | int, ...],
                required: bool = True, label: str = "") -> float | None:
    """A finite number; bools are rejected even though Python treats them as ints."""
    key = str(path[-1])
    if key not in table:
        if required:
            ctx.fail(path, "required key is missing", label)
        return None
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        ctx.fail(path, f"must be a number, got {_type_name(value)} {excerpt(value)}", label)
    try:
        number = float(value)
    except OverflowError:
        ctx.fail(path, f"number out of range: {excerpt(value)}", label)
    if not math.isfinite(number):
        ctx.fail(path, f"must be a finite number, got {excerpt(value)}", label)
    return number


def _get_positive(ctx: TomlContext, table: Mapping[str, Any], path: tuple[str | int, ...],
                  required: bool = True, label: str = "") -> float | None:
    number = _get_number(ctx, table, path, required, label)
    if number is not None and number <= 0:
        ctx.fail(path, f"must be > 0, got {excerpt(table[str(path[-1])])}", label)
    return number


def _get_wob(ctx: TomlContext, table: Mapping[str, Any], path: tuple[str | int, ...],
             label: str = "") -> float | None:
    """An optional weight on bit: > 0 and at most :data:`MAX_WOB_KLBF`."""
    wob = _get_positive(ctx, table, path, required=False, label=label)
    if wob is not None and wob > MAX_WOB_KLBF:
        ctx.fail(path, f"must be at most {MAX_WOB_KLBF:g} klbf (a stated limit: field weights "
                 f"on bit are tens of klbf), got {wob:g}", label)
    return wob


def _check_keys(ctx: TomlContext, table: Mapping[str, Any], path: tuple[str | int, ...],
                allowed: tuple[str, ...], label: str = "") -> None:
    for key in table:
        if key not in allowed:
            ctx.fail(path + (key,), f"unknown key (allowed: {', '.join(allowed)})", label)


def _split_feature(key: str, sensors: Mapping[str, Sensor]) -> tuple[str, str] | None:
    # Matched by suffix so that sensor names may themselves contain underscores; no feature
    # name is an underscore-suffix of another, so the split is unique.
    for feat in FEATURES:
        suffix = "_" + feat
        if key.endswith(suffix) and key[: -len(suffix)] in sensors:
            return key[: -len(suffix)], feat
    return None


class CampaignPathError(CampaignError):
    """A path named in a campaign leaves the campaign folder or cannot be resolved.

    The message says what is wrong with the path; callers that know the file, line and key
    re-raise it with those in front.
    """


def campaign_path(root: Path, name: str, allow_outside: bool = False) -> Path:
    """The real path (symlinks resolved) of ``name``, relative to the campaign folder ``root``.

    Why: a campaign folder may come from anyone, and its TOML decides which files are read. So a
    campaign may only read files inside its own folder: the real path of the file must lie
    within the real path of ``root``, which refuses ``..``, absolute paths and symbolic links
    that lead out, wherever they sit in the path.

    Raises
    ------
    CampaignPathError
        If the file lies outside ``root`` (unless ``allow_outside``) or cannot be resolved.
        The message quotes the name, never the file's contents.
    """
    try:
        real_root = root.resolve()
        real = (root / name).resolve()
    except (OSError, RuntimeError, ValueError) as exc:
        # NUL bytes (ValueError), symlink loops (RuntimeError before Python 3.13, then OSError).
        raise CampaignPathError(f"path {excerpt(name)} cannot be resolved: "
                                f"{excerpt(str(exc))}") from None
    if not allow_outside and not real.is_relative_to(real_root):
        raise CampaignPathError(
            f"path {excerpt(name)} leaves the campaign folder {real_root}; a campaign may only "
            f"read files inside its folder (load_campaign(..., allow_outside=True) lifts this)")
    return real


def tool_file(root: Path, tool: str, allow_outside: bool = False) -> Path | None:
    """The preset file ``tool`` names inside the campaign folder ``root`` (real path), or None
    when there is no such file.

    Raises
    ------
    CampaignPathError
        If ``tool`` names a path outside ``root`` and ``allow_outside`` is false.
    """
    candidate = campaign_path(root, tool, allow_outside)
    try:
        return candidate if candidate.is_file() else None
    except (OSError, ValueError):
        # Names too long are not files; is_file() does not swallow all errors.
        return None


def parse_document(doc: Mapping[str, Any], ctx: TomlContext, root: Path | None,
                   allow_outside: bool = False) -> Campaign:
    """Validate a parsed campaign.toml and build a Campaign without sample data.

    ``root`` is the folder used to resolve a preset-file tool; None skips that check.
    ``allow_outside`` lets that file lie outside ``root`` (see :func:`campaign_path`).
    """
    _check_keys(ctx, doc, (), _TOP_KEYS)
    name = _get_str(ctx, doc, ("name",), limit=MAX_NAME_CHARS)
    tool = _get_str(ctx, doc, ("tool",))
    bit = _get_str(ctx, doc, ("bit",))
    assert name is not None and tool is not None and bit is not None
    if bit not in KNOWN_BITS:
        ctx.fail(("bit",), f"unknown bit {excerpt(bit)} (allowed: {' | '.join(KNOWN_BITS)})")
    if tool not in KNOWN_TOOLS and root is not None:
        try:
            preset_file = tool_file(root, tool, allow_outside)
        except CampaignPathError as exc:
            ctx.fail(("tool",), str(exc))
        if preset_file is None:
            ctx.fail(("tool",), f"unknown tool {excerpt(tool)}: neither a known preset "
                     f"({', '.join(KNOWN_TOOLS)}) nor an existing preset file in {root}")
    wob_default = _get_wob(ctx, doc, ("wob_klbf",))
    description = ""
    if "description" in doc:
        if not isinstance(doc["description"], str):
            ctx.fail(("description",), f"must be a string, got {_type_name(doc['description'])}")
        if len(doc["description"]) > MAX_DESCRIPTION_CHARS:
            ctx.fail(("description",), f"longer than {MAX_DESCRIPTION_CHARS} characters "
                     f"({len(doc['description'])}), the limit for this key")
        description = doc["description"]

    sensors = _parse_sensors(ctx, doc)
    events = _parse_events(ctx, doc, sensors, wob_default)
    return Campaign(name=name, tool=tool, bit=bit, wob_klbf=wob_default, sensors=sensors,
                    events=events, root=root, description=description,
                    allow_outside=allow_outside)


def _parse_sensors(ctx: TomlContext, doc: Mapping[str, Any]) -> dict[str, Sensor]:
    if "sensors" not in doc:
        ctx.fail(("sensors",), "required table is missing (one [sensors.<name>] per sensor)")
    table = doc["sensors"]
    if not isinstance(table, dict):
        ctx.fail(("sensors",), f"must be a table, got {_type_name(table)}")
    if not table:
        ctx.fail(("sensors",), "at least one sensor is required")
    if len(table) > MAX_SENSORS:
        ctx.fail(("sensors",), f"{len(table)} sensors, more than the limit of {MAX_SENSORS}")
    sensors: dict[str, Sensor] = {}
    for sname, spec in table.items():
        path: tuple[str | int, ...] = ("sensors", sname)
        if len(sname) > MAX_ID_CHARS:
            ctx.fail(path, f"sensor name {excerpt(sname)} is longer than "
                     f"{MAX_ID_CHARS} characters, the limit for a sensor name")
        if not BARE_KEY_RE.fullmatch(sname):
            ctx.fail(path, "sensor names may only use letters, digits, '_' and '-'")
        if not isinstance(spec, dict):
            ctx.fail(path, f"must be a table, got {_type_name(spec)}")
        _check_keys(ctx, spec, path, _SENSOR_KEYS)
        if "dof" not in spec:
            ctx.fail(path + ("dof",), "required key is missing")
        dof = spec["dof"]
        if isinstance(dof, bool) or not isinstance(dof, int):
            ctx.fail(path + ("dof",),
                     f"must be an integer 1..7, got {_type_name(dof)} {excerpt(dof)}")
        if not 1 <= dof <= 7:
            ctx.fail(path + ("dof",), f"must be an integer 1..7, got {excerpt(dof)}")
        rate = _get_positive(ctx, spec, path + ("rate_hz",))
        range_g = _get_positive(ctx, spec, path + ("range_g",))
        lowpass = _get_positive(ctx, spec, path + ("lowpass_hz",), required=False)
        assert rate is not None and range_g is not None
        if lowpass is not None and lowpass < rate * MIN_LOWPASS_FRACTION:
            ctx.fail(path + ("lowpass_hz",),
                     f"must be at least rate_hz / {1 / MIN_LOWPASS_FRACTION:g} = "
                     f"{rate * MIN_LOWPASS_FRACTION:g} Hz (an anti-alias corner), got "
                     f"{lowpass:g}")
        if lowpass is not None and lowpass >= rate / 2:
            ctx.fail(path + ("lowpass_hz",),
                     f"must be below the Nyquist frequency rate_hz/2 = {rate / 2:g} Hz, "
                     f"got {lowpass:g}")
        sensors[sname] = Sensor(name=sname, dof=dof, rate_hz=rate, range_g=range_g,
                                lowpass_hz=lowpass)
    return sensors


def _parse_events(ctx: TomlContext, doc: Mapping[str, Any], sensors: Mapping[str, Sensor],
                  wob_default: float | None) -> list[Event]:
    if "events" not in doc:
        ctx.fail(("events",), "required array is missing (one [[events]] table per event)")
    items = doc["events"]
    if not isinstance(items, list):
        ctx.fail(("events",), f"must be an array of tables ([[events]]), got {_type_name(items)}")
    if not items:
        ctx.fail(("events",), "at least one event is required")
    if len(items) > MAX_EVENTS:
        ctx.fail(("events",), f"{len(items)} events, more than the limit of {MAX_EVENTS}")
    events: list[Event] = []
    first_index: dict[str, int] = {}
    for i, spec in enumerate(items):
        path: tuple[str | int, ...] = ("events", i)
        if not isinstance(spec, dict):
            ctx.fail(path, f"must be a table, got {_type_name(spec)}")
        event_id = _get_str(ctx, spec, path + ("id",), limit=MAX_ID_CHARS)
        assert event_id is not None
        label = f" (event {excerpt(event_id)})"
        _check_keys(ctx, spec, path, _EVENT_KEYS, label)
        if event_id in first_index:
            ctx.fail(path + ("id",), f"duplicate event id {excerpt(event_id)}, already used by "
                     f"events[{first_index[event_id]}]", label)
        first_index[event_id] = i
        flow = _get_positive(ctx, spec, path + ("flow_gpm",), label=label)
        wob = _get_wob(ctx, spec, path + ("wob_klbf",), label)
        if wob is None:
            if wob_default is None:
                ctx.fail(path + ("wob_klbf",), "missing, and the campaign has no default "
                         "wob_klbf", label)
            wob = wob_default
        file = _get_str(ctx, spec, path + ("file",), required=False, label=label)
        features = _parse_features(ctx, spec, path, sensors, label)
        reference = _parse_reference(ctx, spec, path, label)
        if file is None and not features:
            ctx.fail(path, "needs a time-series `file`, or `features` (summary-only event), "
                     "or both; it has neither", label)
        assert flow is not None and wob is not None
        events.append(Event(id=event_id, flow_gpm=flow, wob_klbf=wob, file=file,
                            features=features, reference=reference))
    if any(ev.file is not None for ev in events):
        rates = {s.rate_hz for s in sensors.values()}
        if len(rates) > 1:
            first = next(iter(sensors.values()))
            for s in sensors.values():
                if s.rate_hz != first.rate_hz:
                    ctx.fail(("sensors", s.name, "rate_hz"),
                             f"{s.rate_hz:g} Hz differs from sensors.{first.name}.rate_hz = "
                             f"{first.rate_hz:g} Hz, but event CSVs share one time_s column")
    return events


def _parse_features(ctx: TomlContext, spec: Mapping[str, Any], path: tuple[str | int, ...],
                    sensors: Mapping[str, Sensor], label: str) -> dict[str, float]:
    if "features" not in spec:
        return {}
    table = spec["features"]
    if not isinstance(table, dict):
        ctx.fail(path + ("features",), f"must be a table, got {_type_name(table)}", label)
    features: dict[str, float] = {}
    for key in table:
        kpath = path + ("features", key)
        if _split_feature(key, sensors) is None:
            ctx.fail(kpath, f"feature keys are <sensor>_<feature> with a declared sensor "
                     f"({excerpt(', '.join(sensors))}) and a feature in {{{', '.join(FEATURES)}}}",
                     label)
        value = _get_number(ctx, table, kpath, label=label)
        assert value is not None
        if value < 0:
            ctx.fail(kpath, f"must be >= 0, got {excerpt(value)}", label)
        features[key] = value
    return features


def _parse_reference(ctx: TomlContext, spec: Mapping[str, Any], path: tuple[str | int, ...],
                     label: str) -> dict[str, Any]:
    if "reference" not in spec:
        return {}
    table = spec["reference"]
    if not isinstance(table, dict):
        ctx.fail(path + ("reference",), f"must be a table, got {_type_name(table)}", label)
    for key, value in table.items():
        if not isinstance(value, str | int | float | bool):
            ctx.fail(path + ("reference", key),
                     f"must be a string, number or boolean, got {_type_name(value)}", label)
    return dict(table)


# --------------------------------------------------------------------------------------------
# Event CSVs


# --------------------------------------------------------------------------------------------
# Public entry points


def load_campaign(path: str | Path, *, allow_outside: bool = False) -> Campaign:
    """Read and validate a campaign folder.

    Parameters
    ----------
    path : str or pathlib.Path
        The campaign folder (holding ``campaign.toml``) or the TOML file itself.
    allow_outside : bool
        Let ``campaign.toml`` itself, event CSVs and a preset-file ``tool`` lie outside the
        campaign folder. By default a campaign may only read files inside its folder (real
        paths compared, so ``..``, absolute paths and symbolic links leading out are refused);
        the flag is kept on the returned campaign for
        :func:`~vadsim.campaigns.resolve.campaign_preset`. Every file read must be a regular
        file within the limits of RECORDINGS.md (sizes, line lengths, rows), checked before
        it is parsed; the CSVs are parsed in chunks.

    Returns
    -------
    Campaign
        With every event's CSV read into ``Event.data`` (float64) and clipping masks in
        ``Event.clipped``.

    Raises
    ------
    CampaignError
        On any violation of the format; the message names the file and the line or key.
        Also when a file the campaign names lies outside its folder (see ``allow_outside``).

    Warns
    -----
    ClippedSamplesWarning
        For each event CSV holding samples at or beyond a sensor's ``range_g``.
    """
    path = Path(path)
    try:
        is_dir = path.is_dir()
    except (OSError, ValueError):
        is_dir = False
    toml_path = path / CAMPAIGN_FILE if is_dir else path
    root = toml_path.parent
    text = _read_toml_text(toml_path, root, is_dir, allow_outside)
    doc = _parse_toml(toml_path, text)
    ctx = TomlContext(toml_path, text)
    campaign = parse_document(doc, ctx, root, allow_outside)
    for i, event in enumerate(campaign.events):
        if event.file is not None:
            _load_event_data(ctx, campaign, i, root, allow_outside)
    return campaign


def _read_toml_text(toml_path: Path, root: Path, is_dir: bool, allow_outside: bool) -> str:
    """The text of a campaign.toml: confined to its folder like every file a campaign names
    (a symlink leading out is refused unless ``allow_outside``), a regular file of at most
    :data:`~vadsim.campaigns.format.MAX_TOML_BYTES`, UTF-8."""
    try:
        exists = toml_path.exists() or toml_path.is_symlink()
    except (OSError, ValueError):
        exists = False
    if not exists:
        if is_dir:
            raise CampaignError(f"{toml_path}: missing; a campaign folder must hold "
                                f"{CAMPAIGN_FILE}")
        raise CampaignError(f"{toml_path}: no such campaign folder or file")
    try:
        real = campaign_path(root, toml_path.name, allow_outside)
    except CampaignPathError as exc:
        raise CampaignError(f"{toml_path}: {exc}") from None
    with open_regular(real, str(toml_path), MAX_TOML_BYTES, "a campaign file") as f:
        raw = f.read(MAX_TOML_BYTES + 1)
    if len(raw) > MAX_TOML_BYTES:  # it grew since it was measured
        raise CampaignError(f"{toml_path}: larger than the limit of {MAX_TOML_BYTES} bytes "
                            "for a campaign file")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise CampaignError(f"{toml_path}, line {line}: not valid UTF-8 text") from None


def _parse_toml(toml_path: Path, text: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        if "line" not in msg:
            msg += f" (line {text.count(chr(10)) + 1}, end of file)"
        raise CampaignError(f"{toml_path}: TOML syntax error: {msg}") from None
    except RecursionError:
        raise CampaignError(f"{toml_path}: TOML syntax error: nesting too deep") from None
    except ValueError as exc:
        # Not a TOMLDecodeError: an integer beyond Python's digit limit for int(str).
        raise CampaignError(f"{toml_path}: TOML value cannot be read: {excerpt(str(exc))}"
                            ) from None


def _load_event_data(ctx: TomlContext, campaign: Campaign, i: int, root: Path,
                     allow_outside: bool) -> None:
    """Read event ``i``'s CSV into ``data`` and ``clipped`` (warning of clipped samples)."""
    event = campaign.events[i]
    assert event.file is not None
    label = f" (event {excerpt(event.id)})"
    try:
        # The checked real path is what is read, not the name resolved again later.
        csv_path = campaign_path(root, event.file, allow_outside)
    except CampaignPathError as exc:
        ctx.fail(("events", i, "file"), str(exc), label)
    shown = (root / event.file if len(event.file) <= EXCERPT_CHARS
             else f"{root}{os.sep}{excerpt(event.file)}")
    try:
        exists, regular = csv_path.exists(), csv_path.is_file()
    except (OSError, ValueError):
        exists = regular = False
    if not exists:
        ctx.fail(("events", i, "file"), f"CSV file not found: {shown}", label)
    if not regular:
        ctx.fail(("events", i, "file"), f"{shown} is not a regular file (a folder, a pipe or "
                 "a device); a campaign reads regular files only", label)
    event.data, event.clipped = read_event_csv(csv_path, campaign.sensors, f"{shown}{label}")
    if event.n_clipped:
        per_sensor = ", ".join(f"{name}: {int(np.count_nonzero(m))}"
                               for name, m in event.clipped.items() if m.any())
        warnings.warn(
            f"{shown}{label}: {event.n_clipped} samples at or beyond the sensor range "
            f"({per_sensor}); flagged in Event.clipped, do not trust their values",
            ClippedSamplesWarning, stacklevel=3,
        )
