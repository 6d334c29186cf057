"""Writing a campaign in the RECORDINGS.md format (round-trips through
:func:`~vadsim.campaigns.reading.load_campaign`)."""

from __future__ import annotations

import math
import re
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import tomli_w

from vadsim.campaigns.event_csv import time_problem
from vadsim.campaigns.format import (
    CAMPAIGN_FILE,
    KNOWN_TOOLS,
    Campaign,
    CampaignError,
    Sensor,
    excerpt,
)
from vadsim.campaigns.reading import CampaignPathError, parse_document, tool_file
from vadsim.campaigns.toml_keys import TomlContext

__all__ = ["save_campaign"]

#: First line of every campaign.toml written here (tomli-w writes no comments).
HEADER_COMMENT = "# Field-test campaign, format of RECORDINGS.md (written by vadsim.campaigns)."


def _as_number(value: Any) -> int | float:
    # numpy scalars would otherwise reach the writer as unknown types.
    if isinstance(value, np.generic):
        return value.item()
    return value


def _campaign_document(campaign: Campaign, tool: str, files: Mapping[str, str]) -> dict[str, Any]:
    """The campaign as a TOML-shaped dict, as :func:`tomllib.loads` would return it."""
    doc: dict[str, Any] = {"name": campaign.name, "tool": tool, "bit": campaign.bit}
    if campaign.wob_klbf is not None:
        doc["wob_klbf"] = float(_as_number(campaign.wob_klbf))
    if campaign.description:
        doc["description"] = campaign.description
    doc["sensors"] = {}
    for key, s in campaign.sensors.items():
        spec: dict[str, Any] = {"dof": int(_as_number(s.dof)),
                                "rate_hz": _as_number(s.rate_hz),
                                "range_g": _as_number(s.range_g)}
        if s.lowpass_hz is not None:
            spec["lowpass_hz"] = _as_number(s.lowpass_hz)
        doc["sensors"][key] = spec
    doc["events"] = []
    for ev in campaign.events:
        spec = {"id": ev.id, "flow_gpm": float(_as_number(ev.flow_gpm))}
        if campaign.wob_klbf is None or ev.wob_klbf != campaign.wob_klbf:
            spec["wob_klbf"] = float(_as_number(ev.wob_klbf))
        if ev.id in files:
            spec["file"] = files[ev.id]
        if ev.features:
            spec["features"] = {k: float(_as_number(v)) for k, v in ev.features.items()}
        if ev.reference:
            spec["reference"] = {k: _as_number(v) for k, v in ev.reference.items()}
        doc["events"].append(spec)
    return doc


def _toml_pairs(table: Mapping[str, Any]) -> list[str]:
    """``key = value`` for each entry of a table of plain values, as tomli-w spells them."""
    return [tomli_w.dumps({key: value}).rstrip("\n") for key, value in table.items()]


def _toml_text(doc: Mapping[str, Any]) -> str:
    """The document as TOML, laid out as RECORDINGS.md shows it.

    tomli-w does all the quoting and escaping; only the layout is chosen here: one
    ``[sensors.<name>]`` table per sensor, one ``[[events]]`` table per event (tomli-w would
    fold short events into one inline array, where an error could no longer be given a line)
    and each event's ``features`` and ``reference`` as one-line inline tables, joined from
    tomli-w's pairs.
    """
    top = {k: v for k, v in doc.items() if k not in ("sensors", "events")}
    blocks = [HEADER_COMMENT + "\n" + tomli_w.dumps(top)]
    blocks += [tomli_w.dumps({"sensors": {key: spec}}) for key, spec in doc["sensors"].items()]
    for spec in doc["events"]:
        lines = ["[[events]]"]
        lines += _toml_pairs({k: v for k, v in spec.items() if not isinstance(v, Mapping)})
        for key, table in spec.items():
            if isinstance(table, Mapping):
                lines.append(f"{key} = {{ {', '.join(_toml_pairs(table))} }}")
        blocks.append("\n".join(lines) + "\n")
    return "\n".join(blocks)


def _safe_relative(name: str) -> bool:
    p = Path(name)
    return not p.is_absolute() and ".." not in p.parts and bool(p.parts)


def _event_values(data: pd.DataFrame, sensors: Mapping[str, Sensor], label: str) -> np.ndarray:
    """Check an event's samples as load_campaign would; return them in file column order."""
    columns = ["time_s"] + [s.column for s in sensors.values()]
    extra = [c for c in data.columns if c not in columns]
    missing = [c for c in columns if c not in data.columns]
    if extra or missing:
        unexpected = "; unexpected " + excerpt(", ".join(map(str, extra))) if extra else ""
        absent = "; missing " + excerpt(", ".join(missing)) if missing else ""
        raise CampaignError(f"event{label}: data columns must be "
                            f"{excerpt(', '.join(columns))}{unexpected}{absent}")
    values = data[columns].to_numpy(dtype=np.float64)
    if values.shape[0] < 2:
        raise CampaignError(f"event{label}: data needs at least 2 samples")
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        raise CampaignError(f"event{label}: data row {int(bad[0])} holds NaN or infinity")
    problem = time_problem(values[:, 0], next(iter(sensors.values())).rate_hz)
    if problem is not None:
        raise CampaignError(f"event{label}: data row {problem[0]}: {problem[1]}")
    return values


def _write_event_csv(path: Path, values: np.ndarray, sensors: Mapping[str, Sensor]) -> None:
    columns = ["time_s"] + [s.column for s in sensors.values()]
    rate = next(iter(sensors.values())).rate_hz
    # 7 decimals as in the format's example; more when the period needs them (> 10 kHz), so
    # the rounding stays far inside the loader's time tolerance.
    decimals = max(7, math.ceil(math.log10(rate)) + 3)
    time_text = [f"{t:.{decimals}f}" for t in values[:, 0].tolist()]
    # repr is the shortest string that reads back to the same float64: exact round trip.
    cols = [time_text] + [list(map(repr, values[:, j].tolist()))
                          for j in range(1, values.shape[1])]
    body = "\n".join(map(",".join, zip(*cols, strict=True)))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(",".join(columns) + "\n" + body + "\n", encoding="utf-8", newline="\n")


def save_campaign(campaign: Campaign, folder: str | Path) -> Path:
    """Write a campaign folder that :func:`load_campaign` reads back equal.

    Parameters
    ----------
    campaign : Campaign
        The campaign. Events with ``data`` get a CSV named by ``Event.file`` (or
        ``<id>.csv`` when it has none or it points outside the folder).
    folder : str or pathlib.Path
        Destination, created if needed; existing files of the same names are overwritten.

    Returns
    -------
    pathlib.Path
        ``folder``, ready for :func:`load_campaign`.

    Raises
    ------
    CampaignError
        If the campaign would not load back: any rule of the format broken (checked before
        anything is written), an event with ``file`` but no ``data``, two files of the same
        name. Also when the preset-file ``tool`` lies outside ``campaign.root`` (the current
        folder when None) and ``campaign.allow_outside`` is false.

    Notes
    -----
    Accelerations are written exactly (shortest float64 repr); ``time_s`` with 7 decimals
    (see the module docstring). A tool given as a preset file is copied into the new folder:
    to the same relative path when it has one inside ``campaign.root``, else (a file outside,
    read with ``allow_outside``) under its own file name, so the saved folder is self-contained
    and loads without ``allow_outside``. ``campaign.toml`` is written with tomli-w.
    """
    folder = Path(folder)
    for key, sensor in campaign.sensors.items():
        if sensor.name != key:
            raise CampaignError(f"sensors[{excerpt(key)}]: Sensor.name is "
                                f"{excerpt(sensor.name)}, it must equal its key")

    tool = campaign.tool
    tool_source: Path | None = None
    if tool not in KNOWN_TOOLS:
        base = Path(campaign.root) if campaign.root is not None else Path.cwd()
        try:
            tool_source = tool_file(base, tool, campaign.allow_outside)
        except CampaignPathError as exc:
            raise CampaignError(f"campaign {excerpt(campaign.name)}: key tool: {exc}") from None
        if tool_source is None:
            raise CampaignError(f"tool {excerpt(tool)}: neither a known preset "
                                f"({', '.join(KNOWN_TOOLS)}) nor an existing file in {base}")
        if not (_safe_relative(tool) and tool_source.is_relative_to(base.resolve())):
            tool = tool_source.name

    files: dict[str, str] = {}
    owners: dict[str, str] = {}
    for ev in campaign.events:
        if ev.data is None:
            if ev.file is not None:
                raise CampaignError(f"event {excerpt(ev.id)}: file {excerpt(ev.file)} is set "
                                    f"but data is None; nothing to write")
            continue
        name = ev.file if ev.file is not None and _safe_relative(ev.file) else (
            re.sub(r"[^A-Za-z0-9._-]", "_", ev.id) + ".csv")
        if name in owners:
            raise CampaignError(f"events {excerpt(owners[name])} and {excerpt(ev.id)} would "
                                f"both be written to {excerpt(name)}")
        if name == CAMPAIGN_FILE or (tool_source is not None and name == tool):
            raise CampaignError(f"event {excerpt(ev.id)}: file {excerpt(name)} would overwrite "
                                f"the campaign's {'TOML' if name == CAMPAIGN_FILE else 'tool'}")
        owners[name] = ev.id
        files[ev.id] = name
    if tool == CAMPAIGN_FILE:
        raise CampaignError(f"tool {excerpt(campaign.tool)}: a preset file named "
                            f"{CAMPAIGN_FILE} would overwrite the campaign's own")

    doc = _campaign_document(campaign, tool, files)
    # Same validator as load_campaign, so nothing is written that would not load back.
    parse_document(doc, TomlContext(f"campaign {excerpt(campaign.name)}", None), None)
    try:
        text = _toml_text(doc)
    except (TypeError, ValueError) as exc:  # a value tomli-w cannot write
        raise CampaignError(f"campaign {excerpt(campaign.name)}: cannot write TOML: "
                            f"{excerpt(str(exc))}") from None

    # All samples are checked before the first byte is written: no half-written folder.
    for ev in campaign.events:
        if ev.id in files:
            _event_values(ev.data, campaign.sensors, f" {excerpt(ev.id)}")

    folder.mkdir(parents=True, exist_ok=True)
    for ev in campaign.events:
        if ev.id in files:
            values = _event_values(ev.data, campaign.sensors, f" {excerpt(ev.id)}")
            _write_event_csv(folder / files[ev.id], values, campaign.sensors)
    if tool_source is not None:
        dest = folder / tool
        if not (dest.exists() and dest.resolve() == tool_source.resolve()):
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(tool_source, dest)
    (folder / CAMPAIGN_FILE).write_text(text, encoding="utf-8", newline="\n")
    return folder
