"""Flow sweeps and 2-D maps over flow and design parameters, in parallel and resumable.

Why this module exists: the dissertation's chapter 4 and 5 results are maps of impact regime
and impulse per second J* over flow rate and a design parameter, each point one 400-cycle run.
This module runs such grids on all local cores (threads: the core releases the GIL) or on a
Dask cluster through the same ``concurrent.futures`` interface, writes every finished chunk to
disk atomically so that a map killed at any moment resumes without losing or repeating a
point, and returns an :class:`xarray.Dataset` with one variable per label.

A grid point is described by plain data (a :class:`~vadsim.model.settings.RunSettings`, the
flows and the design values), never by live C++ objects, so it can travel to a Dask worker.

:func:`sweep` goes through five named steps: check the inputs (:func:`_make_grid`), cut the
grid into chunks (:meth:`_Grid.chunks`), open and verify the store (:class:`_Store`), run the
chunks still to do (:func:`_run_chunks`) and assemble the dataset (:func:`_assemble`).

The store trusts nothing it reads. ``grid.json`` describes the grid; every chunk file carries
the grid's hash, the exact grid indices and flows it holds and a checksum of its rows, and a
chunk that does not verify is recomputed with a :class:`StoreWarning` naming it and why. A
store whose grid cannot be verified (``grid.json`` missing, unreadable or of another grid while
chunks are present) is refused. Several processes on one store share the work: a process
claims a chunk (``chunk-....claim``, created atomically) before computing it, skips chunks a
live process has claimed and loads them once they are written; the claim of a process that
ended (same host) or that gave no sign of life for :data:`CLAIM_STALE_S` is taken over.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import socket
import tempfile
import time
import uuid
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from functools import cached_property
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from vadsim._executors import dask_pool, local_threads
from vadsim._version import __version__ as _version
from vadsim.model.presets import get_preset, make_params, param_table
from vadsim.model.settings import ExtraSpec, RunSettings
from vadsim.model.simulate import SURFACES, G, SolverError
from vadsim.signals.labels import impact_frequency, periodicity, poincare_period, scenario
from vadsim.studies.refine import Refinement, fill, lattice, next_points

__all__ = [
    "CONTINUATION_SETTLE_CYCLES",
    "CLAIM_STALE_S",
    "CLAIM_WRITE_GRACE_S",
    "process_start",
    "DERIVED_PARAMETERS",
    "FEATURES",
    "GAP_REALISATIONS",
    "PointSpec",
    "StoreWarning",
    "design_overrides",
    "flow_sweep",
    "flows_from_hz",
    "load_dataset",
    "run_point",
    "save_dataset",
    "sweep",
]

GAP_REALISATIONS = ("spring", "anvil", "housing")
"""How a change of the anvil-spring gap (MODEL.md Eq. 5.1) is built: moving the spring's end
(``LS``), changing the anvil length above its face (``L2``) or the housing length (``L3``)."""

DERIVED_PARAMETERS = ("gap_ratio", "gap")
"""Axes that are not Table 2.1 names: the gap as a ratio of the preset's gap, or in l0."""

FEATURES: dict[str, str] = {
    "z_spring": "impacts per cycle at the recoil spring (#1)",
    "z_impact": "impacts per cycle at the impact face (#2)",
    "z_off_bottom": "impacts per cycle at the off-bottom shoulder (#3)",
    "z_on_bottom": "impacts per cycle at the on-bottom shoulder (#4)",
    "z_rock": "bit-rock contact onsets per cycle",
    "scenario": "impact scenario, dissertation Table 4.2 (0: no impact, 7: spring only)",
    "j_mean": "J*: mean impact-face force over the window (N/kg)",
    "j_pos": "J*: mean of max(F_I, 0) over the window (N/kg)",
    "j_pos_kN": "J* (mean of max(F_I, 0)) in kN, times the preset's reference mass",
    "x1_peak_mean_g": "mean of 200 ms peaks of |a| at the bit sub, full resolution (g)",
    "x1_peak_std_g": "dispersion of those peaks (g)",
    "x5_peak_mean_g": "mean of 200 ms peaks of |a| above the motor, full resolution (g)",
    "x5_peak_std_g": "dispersion of those peaks (g)",
    "x1_impact_hz": "major x1 acceleration peaks per second",
    "period": "period of the steady response in cycles (0: not periodic)",
    "periodicity": "period-n, quasi-periodic or aperiodic (Poincare section)",
    "steps": "CVODE steps",
    "steady_period": "cycles of the periodic orbit the run stopped at and was built from "
                     "(0: every cycle integrated)",
    "error": "empty, or why the run failed",
}

_TEXT_FEATURES = ("periodicity", "error")
_INT_FEATURES = ("scenario", "period", "steps", "steady_period")

# CF-style (units, long_name) of every variable, so that xarray's plots label themselves.
# "1" is a dimensionless number; labels (text) have no unit, hence "".
_FEATURE_ATTRS: dict[str, tuple[str, str]] = {
    "z_spring": ("1", "impacts per cycle, recoil spring (#1)"),
    "z_impact": ("1", "impacts per cycle, impact face (#2)"),
    "z_off_bottom": ("1", "impacts per cycle, off-bottom shoulder (#3)"),
    "z_on_bottom": ("1", "impacts per cycle, on-bottom shoulder (#4)"),
    "z_rock": ("1", "bit-rock contact onsets per cycle"),
    "scenario": ("1", "impact scenario (Table 4.2)"),
    "j_mean": ("N/kg", "mean impact-face force J*"),
    "j_pos": ("N/kg", "impulse per second J*"),
    "j_pos_kN": ("kN", "impulse per second J*"),
    "x1_peak_mean_g": ("g", "bit-sub acceleration peaks, mean"),
    "x1_peak_std_g": ("g", "bit-sub acceleration peaks, dispersion"),
    "x5_peak_mean_g": ("g", "acceleration peaks above the motor, mean"),
    "x5_peak_std_g": ("g", "acceleration peaks above the motor, dispersion"),
    "x1_impact_hz": ("Hz", "bit-sub impact frequency"),
    "period": ("1", "period of the steady response (excitation cycles)"),
    "periodicity": ("", "periodicity of the steady response"),
    "steps": ("1", "CVODE steps"),
    "steady_period": ("1", "period of the orbit the run was built from (cycles)"),
    "error": ("", "why the run failed"),
}
_FLOW_ATTRS = {"units": "gal/min", "long_name": "mud flow rate"}
_F_EXC_ATTRS = {"units": "Hz", "long_name": "excitation frequency"}
_DERIVED_ATTRS = {
    "gap_ratio": {"units": "1", "long_name": "anvil-spring gap / preset gap"},
    "gap": {"units": "l0", "long_name": "anvil-spring gap"},
}

STORE_FORMAT = 3
"""Version of the store's files (1: vadsim 0.1, chunks without grid hash or checksum; 2:
rows without ``steady_period``, runs integrated to their end)."""

CLAIM_STALE_S = 600.0
"""A claim not refreshed for this long (s) is taken over, whoever holds it. A live process
refreshes its claims every few seconds, so only a dead or frozen one reaches this age."""

CLAIM_WRITE_GRACE_S = 30.0
"""No longer waited for: a claim is hard-linked into place only once its owner record is
written, so a claim without a valid record (empty, garbage) is taken over at once. Kept for
code that reads it."""

_HEARTBEAT_S = 5.0
_POLL_S = 0.2
_CHUNK_FLOWS = 8

# Poincare section scales: 1 mm and 1 m/s, so that "same state" means within 1 um and 1 mm/s
# (POINCARE_RTOL = 1e-3). A periodic 7in run at rtol 1e-6 repeats to 0.2 um and 0.2 mm/s
# (the ~1 kHz sub-LWD mode keeps that much numerical noise), intermittent ones differ by mm.
_SECTION_SCALE = np.r_[np.full(7, 1e-3), np.full(7, 1.0)]
_IMPACT_RATE_HZ = 4096.0


CONTINUATION_SETTLE_CYCLES = 50.0
"""In continuation mode, the cycles a point started from the previous flow's state settles
before its analysed window (the row's first flow starts from rest and settles the full
``cycles - analyse_cycles``): the previous flow's attractor is next to this one's, and a
periodic point stops at its orbit anyway (``steady="auto"``)."""


class StoreWarning(UserWarning):
    """Something in a sweep's store did not verify and was recomputed (or was taken over)."""


def flows_from_hz(preset: str | RunSettings, hz: Iterable[float]) -> np.ndarray:
    """Flow rates (gal/min) that give excitation frequencies ``hz`` (f = alpha Q / 2 pi), for a
    preset (name) or run settings (whose ``alpha`` override, if any, counts)."""
    settings = preset if isinstance(preset, RunSettings) else RunSettings(get_preset(preset))
    return settings.flows_for_hz(hz)


def design_overrides(
    base: Mapping[str, float], values: Mapping[str, float], gap_via: str = "spring"
) -> dict[str, float]:
    """Translate axis values (Table 2.1 names or derived ones) into parameter overrides.

    Parameters
    ----------
    base
        The parameters the values apply to (a preset's ``params`` merged with overrides).
    values
        ``{name: value}``; ``gap_ratio`` scales the gap (``L_gap`` if set, else
        L3 - (L2 + LS + LI + LOn)), ``gap``
        sets it (in l0); every other name is a Table 2.1 parameter.
    gap_via
        Which length realises a gap change (see :data:`GAP_REALISATIONS`).
    """
    if gap_via not in GAP_REALISATIONS:
        raise ValueError(f"gap_via = {gap_via!r} must be one of {', '.join(GAP_REALISATIONS)}")
    out: dict[str, float] = {}
    held = not math.isnan(base.get("L_gap", math.nan))  # L_gap set: LS follows from it
    gap0 = base["L_gap"] if held else base["L3"] - (base["L2"] + base["LS"] + base["LI"]
                                                    + base["LOn"])
    for name, value in values.items():
        if name in DERIVED_PARAMETERS:
            target = gap0 * value if name == "gap_ratio" else value
            delta = target - gap0
            if held:
                out["L_gap"] = target  # and the spring's end stays unless it realises it
            if gap_via == "spring":
                if not held:
                    out["LS"] = base["LS"] - delta
            elif gap_via == "anvil":
                out["L2"] = base["L2"] - delta
            else:
                out["L3"] = base["L3"] + delta
        else:
            out[name] = float(value)
    return out


@dataclass(frozen=True)
class PointSpec:
    """Everything needed to run one row of a grid, as plain (picklable) data.

    Parameters
    ----------
    settings
        The run settings every point of the grid shares.
    flows
        The flow rates of this row (gal/min), in the order they are run.
    values
        ``((axis name, value), ...)``: the design values of this row (see
        :func:`design_overrides`).
    continuation
        Each flow starts from the previous flow's final state.
    gap_via
        Which length realises a gap change.
    detail
        ``"full"`` or ``"map"`` (see :func:`sweep`).
    settle
        In continuation mode, the cycles a point started from the previous flow's state
        settles before its window (None: the settings' own).
    """

    settings: RunSettings
    flows: tuple[float, ...]
    values: tuple[tuple[str, float], ...] = ()
    continuation: bool = False
    gap_via: str = "spring"
    detail: str = "full"
    settle: float | None = None


DETAILS = {
    # record the window at 4096 Hz for the impact frequency; summary grid at 20 kHz (MODEL.md's
    # "full resolution" for peaks and J*)
    "full": ("window", 20000.0),
    # maps need regimes and J* only: no time series, J* on a 5 kHz grid (within 0.15 % of
    # 20 kHz at 200, 350 and 600 gal/min), about 25 % faster per run
    "map": ("none", 5000.0),
}


def _features(r, analyse_cycles: float) -> dict[str, Any]:
    z = r.z
    m1, s1 = r.peak_stats(1)
    m5, s5 = r.peak_stats(5)
    n_sec = int(math.floor(analyse_cycles + 1e-9))
    section = np.asarray(r.poincare)[-n_sec:]
    # Impact frequency from x1 on the recorded window (4096 Hz is enough for a count).
    x1 = np.asarray(r.a)[:, 0] / G
    try:
        impact_hz = impact_frequency(x1, _IMPACT_RATE_HZ) if x1.size > 16 else math.nan
    except ValueError:
        impact_hz = math.nan  # too few samples for a count
    try:
        period = poincare_period(section, scale=_SECTION_SCALE) or 0
        label = periodicity(section, scale=_SECTION_SCALE)
    except ValueError:
        period, label = 0, "unknown"
    row = {
        **{f"z_{s}": z[s] for s in SURFACES},
        "scenario": scenario(z["spring"], z["impact"]),
        "j_mean": r.impulse_mean,
        "j_pos": r.impulse_pos,
        "j_pos_kN": r.impulse_pos_kn,
        "x1_peak_mean_g": m1,
        "x1_peak_std_g": s1,
        "x5_peak_mean_g": m5,
        "x5_peak_std_g": s5,
        "x1_impact_hz": impact_hz,
        "period": int(period),
        "periodicity": label,
        "steps": int(r.stats["steps"]),
        "steady_period": int(r.steady_info.period) if r.steady_info is not None else 0,
        "error": "",
    }
    return row


def _failed_row(message: str) -> dict[str, Any]:
    row: dict[str, Any] = {k: math.nan for k in FEATURES}
    row.update(scenario=-1, period=0, periodicity="failed", steps=0, steady_period=0,
               error=message)
    return row


def run_point(spec: PointSpec) -> list[dict[str, Any]]:
    """Run one row of a grid (every flow of ``spec``) and return one feature dict per flow.

    In continuation mode each flow starts from the previous flow's final state, as in a field
    flow sweep, and settles ``spec.settle`` cycles before its window; otherwise every flow
    starts from the static state. A failed run gives a row
    with ``error`` set (and, in continuation mode, the next flow restarts from rest).
    """
    s = spec.settings
    base = {**s.preset.params, **s.overrides}
    settings = s.with_changes(overrides=design_overrides(base, dict(spec.values), spec.gap_via))
    record, summary_rate = DETAILS[spec.detail]
    warm = settings
    if spec.continuation and spec.settle is not None:
        warm = settings.with_changes(cycles=settings.analyse_cycles + spec.settle)
    rows: list[dict[str, Any]] = []
    state = None
    for q in spec.flows:
        try:
            r = (settings if state is None else warm).run(
                q, record=record, output_rate_hz=_IMPACT_RATE_HZ, summary_rate_hz=summary_rate,
                initial_state=state)
        except (SolverError, ValueError) as exc:
            rows.append(_failed_row(str(exc)))
            state = None
            continue
        rows.append(_features(r, settings.analyse_cycles))
        state = r.y_end if spec.continuation else None
    return rows


# --- the grid and its chunks ---------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Chunk:
    """A piece of one row of the grid: the unit that is computed, stored and claimed."""

    index: tuple[int, ...]
    start: int
    spec: PointSpec
    flow_idx: tuple[int, ...] | None = None
    """The flow indices of an adaptive map's chunk (None: ``start`` and the next ones)."""

    @property
    def key(self) -> str:
        key = "chunk-" + "-".join(str(i) for i in (*self.index, self.start))
        if self.flow_idx is not None:  # scattered points: the exact set names the file
            digest = hashlib.sha256(",".join(map(str, self.flow_idx)).encode()).hexdigest()
            key += f"-p{len(self.flow_idx)}-{digest[:10]}"
        return key

    @property
    def flow_index(self) -> list[int]:
        if self.flow_idx is not None:
            return list(self.flow_idx)
        return list(range(self.start, self.start + len(self.spec.flows)))

    def header(self, grid_hash: str) -> dict[str, Any]:
        """What a chunk file must say about itself (JSON form)."""
        return {"format": STORE_FORMAT, "grid": grid_hash, "key": self.key,
                "index": list(self.index), "values": [[n, v] for n, v in self.spec.values],
                "flow_index": self.flow_index, "flows": list(self.spec.flows)}


@dataclass(frozen=True, eq=False)
class _Grid:
    """The whole computation of a sweep, as data: settings, flows, design axes and mode."""

    settings: RunSettings
    flows: np.ndarray
    axes: dict[str, np.ndarray] = field(default_factory=dict)
    mode: str = "independent"
    gap_via: str = "spring"
    detail: str = "full"
    refine: Refinement | None = None
    settle: float | None = None

    @property
    def continuation(self) -> bool:
        return self.mode == "continuation"

    @property
    def piece(self) -> int:
        """Flows per chunk: a whole row in continuation mode (it is sequential); otherwise a
        few flows, so that every core stays busy to the end."""
        return len(self.flows) if self.continuation else max(1, min(len(self.flows),
                                                                    _CHUNK_FLOWS))

    @property
    def shape(self) -> tuple[int, ...]:
        return (*(len(v) for v in self.axes.values()), len(self.flows))

    def cells(self) -> list[tuple[tuple[int, ...], tuple[tuple[str, float], ...]]]:
        """Every row of the grid: its axis indices and design values."""
        names = list(self.axes)
        shapes = [len(v) for v in self.axes.values()]
        out = []
        for idx in np.ndindex(*shapes) if shapes else [()]:
            values = tuple((n, float(self.axes[n][i])) for n, i in zip(names, idx, strict=True))
            out.append((tuple(int(i) for i in idx), values))
        return out

    def chunks(self) -> list[_Chunk]:
        """The grid cut into chunks, in the order they are computed."""
        out = []
        for idx, values in self.cells():
            for start in range(0, len(self.flows), self.piece):
                sub = tuple(float(q) for q in self.flows[start:start + self.piece])
                out.append(_Chunk(idx, start, PointSpec(self.settings, sub, values,
                                                        self.continuation, self.gap_via,
                                                        self.detail, self.settle)))
        return out

    def point_chunks(self, points: Sequence[tuple[int, ...]]) -> list[_Chunk]:
        """Chunks that run exactly ``points`` (grid indices, flow last): per row, in flow
        order, ``piece`` flows at a time."""
        rows: dict[tuple[int, ...], list[int]] = {}
        for p in points:
            rows.setdefault(tuple(int(i) for i in p[:-1]), []).append(int(p[-1]))
        names = list(self.axes)
        out = []
        for idx in sorted(rows):
            values = tuple((n, float(self.axes[n][i])) for n, i in zip(names, idx, strict=True))
            flows = sorted(set(rows[idx]))
            for k in range(0, len(flows), self.piece):
                part = tuple(flows[k:k + self.piece])
                sub = tuple(float(self.flows[j]) for j in part)
                out.append(_Chunk(idx, part[0], PointSpec(self.settings, sub, values, False,
                                                          self.gap_via, self.detail), part))
        return out

    @cached_property
    def document(self) -> dict[str, Any]:
        """The grid as JSON data (``grid.json``); axes as ordered pairs (order is meaning)."""
        return {"format": STORE_FORMAT, "settings": self.settings.as_dict(),
                "preset_params": {k: float(v) for k, v in
                                  sorted(self.settings.preset.params.items())},
                "flows": self.flows.tolist(),
                "axes": [[k, v.tolist()] for k, v in self.axes.items()],
                "mode": self.mode, "gap_via": self.gap_via, "detail": self.detail,
                "chunk_flows": self.piece,
                **({"settle": self.settle} if self.settle is not None else {}),
                **({"refine": self.refine.as_dict()} if self.refine is not None else {})}

    @cached_property
    def text(self) -> str:
        return json.dumps(self.document, sort_keys=True)

    @cached_property
    def hash(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()


# --- the store: files that verify themselves, claims shared between processes ---------------


class _BadChunk(Exception):
    """A chunk file that does not verify (the message says why); it is recomputed."""


def _rows_text(rows: Any) -> str:
    return json.dumps(rows, sort_keys=True, default=float)


def _checksum(rows: Any) -> str:
    return "sha256:" + hashlib.sha256(_rows_text(rows).encode()).hexdigest()


def _row_problem(row: Any) -> str | None:
    """Why ``row`` is not a row of features (None: it is one)."""
    if not isinstance(row, dict):
        return f"is {type(row).__name__}, not a mapping"
    missing = [k for k in FEATURES if k not in row]
    if missing:
        return f"lacks {', '.join(missing)}"
    unknown = sorted(set(row) - set(FEATURES))
    if unknown:
        return f"has unknown keys {', '.join(unknown)}"
    for name, value in row.items():
        text = name in _TEXT_FEATURES
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if (text and not isinstance(value, str)) or (not text and not number):
            return f"has {name} = {value!r}"
    return None


def _verify_chunk(text: str, chunk: _Chunk, grid_hash: str, where: str) -> list[dict[str, Any]]:
    """The rows of a chunk file, or :class:`_BadChunk`; ValueError if it is another grid's."""
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise _BadChunk(f"is not readable JSON ({exc})") from None
    if not isinstance(doc, dict) or "grid" not in doc or "checksum" not in doc:
        raise _BadChunk("carries no grid hash or checksum (an older vadsim's chunk, or none)")
    if not (isinstance(doc["grid"], str) and len(doc["grid"]) == len(grid_hash)
            and all(c in "0123456789abcdef" for c in doc["grid"])):
        raise _BadChunk(f"carries a damaged grid hash {str(doc['grid'])[:20]!r}")
    if doc["grid"] != grid_hash:
        raise ValueError(
            f"{where}: {chunk.key}.json belongs to grid {str(doc['grid'])[:16]}, but grid.json "
            f"describes grid {grid_hash[:16]}: grid.json was replaced after chunks were "
            "written, so the store cannot be trusted; use another folder or delete it")
    rows = doc.get("rows")
    if not isinstance(rows, list) or doc["checksum"] != _checksum(rows):
        raise _BadChunk("does not match its checksum (changed or damaged after it was written)")
    for name, expected in chunk.header(grid_hash).items():
        if doc.get(name) != expected:
            raise _BadChunk(f"holds {name} {doc.get(name)!r}, expected {expected!r}")
    if len(rows) != len(chunk.spec.flows):
        raise _BadChunk(f"has {len(rows)} rows for {len(chunk.spec.flows)} flows")
    for j, row in enumerate(rows):
        problem = _row_problem(row)
        if problem:
            raise _BadChunk(f"row {j} {problem}")
    return rows


def _atomic_write_text(path: Path, text: str, *, replace: bool = True) -> None:
    """Write ``text`` to ``path`` all at once: to a temporary file, then renamed into place (or,
    with ``replace=False``, linked: FileExistsError if ``path`` exists)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        if replace:
            os.replace(tmp, path)
        else:
            os.link(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


def _read_json(path: Path) -> Any:
    """The JSON in ``path``; None if missing, unreadable or not JSON."""
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return None


def _owner_record(holder: Mapping[str, Any]) -> bool:
    """Whether a claim's content is an owner record: a positive PID, a host and a token (the
    start is optional: claims of vadsim before 0.2 have none)."""
    pid = holder.get("pid")
    return (isinstance(pid, int) and not isinstance(pid, bool) and pid > 0
            and isinstance(holder.get("host"), str) and isinstance(holder.get("token"), str)
            and isinstance(holder.get("start", ""), (str, type(None))))


def process_start(pid: int) -> str | None:
    """When process ``pid`` started, as ``"<boot id>:<start tick>"`` (Linux's /proc), or None
    where that cannot be read. Two processes with one PID on one host differ in it: a claim
    records it so that a reused PID is not taken for the claimant."""
    try:
        stat_text = Path(f"/proc/{pid}/stat").read_text()
        boot = Path("/proc/sys/kernel/random/boot_id").read_text().strip()
    except (OSError, ValueError):
        return None
    fields = stat_text.rsplit(")", 1)[-1].split()
    return f"{boot}:{fields[19]}" if len(fields) > 19 else None


def _pid_alive(pid: Any) -> bool:
    if not isinstance(pid, int) or isinstance(pid, bool) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: alive, someone else's
        return True
    return True


def _differences(old: Mapping[str, Any], new: Mapping[str, Any], prefix: str = "") -> list[str]:
    """The fields where two grid documents differ, e.g. ``settings.cycles 20.0 -> 30.0``."""
    out = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k), new.get(k)
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            out += _differences(a, b, f"{prefix}{k}.")
        elif a != b:
            short = not isinstance(a, list) and not isinstance(b, list)
            out.append(f"{prefix}{k} {a!r} -> {b!r}" if short else f"{prefix}{k} differ")
    return out


class _Store:
    """A folder of finished chunks of one grid (``grid.json``) that verifies what it reads and
    shares the work with other processes through claim files."""

    def __init__(self, path: Path, grid: _Grid) -> None:
        self.path = path
        self.grid = grid
        self.where = f"store {path}"
        self.host = socket.gethostname()
        self._held: dict[str, str] = {}  # chunk key -> token of this process's claim
        self._bad: dict[str, tuple[int, int]] = {}  # chunk key -> (mtime, size) found bad
        self._beat = time.monotonic()

    @classmethod
    def open(cls, path: str | os.PathLike[str], grid: _Grid) -> _Store:
        """The store at ``path`` for ``grid``; ValueError if it holds another or an unknown
        grid."""
        store = cls(Path(path), grid)
        store.path.mkdir(parents=True, exist_ok=True)
        store._check_grid_file()
        return store

    def _chunk_files(self) -> list[Path]:
        return sorted(self.path.glob("chunk-*.json"))

    def _check_grid_file(self) -> None:
        spec = self.path / "grid.json"
        if not spec.exists():
            if self._chunk_files() and not spec.exists():  # (re-checked: a racing creator)
                raise ValueError(
                    f"{self.where} has chunk files but no grid.json: nothing says which grid "
                    "they belong to, so they cannot be trusted; use another folder or delete it")
            with contextlib.suppress(FileExistsError):  # another process was first: compare
                _atomic_write_text(spec, self.grid.text, replace=False)
        try:
            current = spec.read_text()
        except (OSError, UnicodeDecodeError):
            current = None
        if current != self.grid.text:
            raise ValueError(self._grid_mismatch(current))

    def _grid_mismatch(self, current: str | None) -> str:
        fix = "use another folder or delete it"
        try:
            old = json.loads(current or "")
        except ValueError:
            old = None
        if not isinstance(old, dict):
            return f"{self.where}: grid.json is unreadable, so its chunks cannot be verified; {fix}"
        if old.get("format") != STORE_FORMAT:
            fmt = old.get("format", old.get("version"))
            return (f"{self.where} holds a different grid, in store format {fmt} (an older "
                    f"vadsim's, whose chunks carry no checksums); {fix}")
        diff = _differences(old, self.grid.document)
        what = "; ".join(diff[:6]) + (" ..." if len(diff) > 6 else "") or "same fields"
        return f"{self.where} holds a different grid ({what}); {fix}"

    def load(self, chunks: Sequence[_Chunk], *, strays_too: bool = True
             ) -> dict[str, list[dict[str, Any]]]:
        """The verified rows of every chunk the store holds (bad ones reported, left out);
        files of no chunk given are reported unless ``strays_too`` is False (an adaptive map
        loads one level at a time)."""
        known = {c.key for c in chunks}
        strays = ([f.name for f in self._chunk_files() if f.stem not in known]
                  if strays_too else [])
        if strays:
            warnings.warn(f"{self.where}: ignored {len(strays)} file(s) that are no chunk of "
                          f"this grid: {', '.join(strays[:3])}", StoreWarning, stacklevel=3)
        done = {}
        for chunk in chunks:
            rows = self.read(chunk)
            if rows is not None:
                done[chunk.key] = rows
                self.drop_stale_claim(chunk)
        return done

    def read(self, chunk: _Chunk) -> list[dict[str, Any]] | None:
        """The chunk's rows if its file exists and verifies, else None (a bad file is reported
        once, with a :class:`StoreWarning`)."""
        path = self.path / f"{chunk.key}.json"
        try:
            st = path.stat()
        except FileNotFoundError:
            return None
        stamp = (st.st_mtime_ns, st.st_size)
        if self._bad.get(chunk.key) == stamp:
            return None
        try:
            text = path.read_text()
        except FileNotFoundError:
            return None
        except (OSError, UnicodeDecodeError):
            text = ""
        try:
            return _verify_chunk(text, chunk, self.grid.hash, self.where)
        except _BadChunk as exc:
            self._bad[chunk.key] = stamp
            warnings.warn(f"{self.where}: {chunk.key}.json {exc}; recomputing it", StoreWarning,
                          stacklevel=4)
            return None

    def write(self, chunk: _Chunk, rows: list[dict[str, Any]]) -> None:
        doc = {**chunk.header(self.grid.hash), "rows": rows, "checksum": _checksum(rows)}
        _atomic_write_text(self.path / f"{chunk.key}.json", json.dumps(doc, default=float))
        self._bad.pop(chunk.key, None)

    # claims

    def _claim_path(self, key: str) -> Path:
        return self.path / f"{key}.claim"

    def claim(self, chunk: _Chunk) -> bool:
        """Claim ``chunk`` for this process (True), or find it held by a live one (False).

        The owner record is written to a private file first and hard-linked into place, so a
        claim never exists without its owner; and the claim is registered as held before it
        exists, so a Ctrl-C at any moment leaves none that :meth:`release_all` does not
        remove (under load, one landed between creating an empty claim and writing it)."""
        path = self._claim_path(chunk.key)
        for _ in range(2):
            token = uuid.uuid4().hex
            record = path.with_name(f"{path.name}.new-{token}")
            try:
                record.write_text(json.dumps({"pid": os.getpid(), "host": self.host,
                                              "start": process_start(os.getpid()),
                                              "time": time.time(), "token": token}))
                self._held[chunk.key] = token
                try:
                    os.link(record, path)
                except FileExistsError:
                    self._held.pop(chunk.key, None)
                    if not self._take_over_if_stale(path, chunk):
                        return False
                    continue
            finally:
                record.unlink(missing_ok=True)
            return True
        return False

    def _stale(self, path: Path) -> tuple[dict[str, Any], str] | None:
        """The holder of the claim at ``path`` and why it is stale; None if live or gone."""
        holder = _read_json(path)
        try:
            age = time.time() - path.stat().st_mtime
        except FileNotFoundError:
            return None
        holder = holder if isinstance(holder, dict) else {}
        if age > CLAIM_STALE_S:
            return holder, f"no sign of life for {age:.0f} s"
        if not _owner_record(holder):
            # a claim is linked into place only once its record is written: one without a
            # valid record was never a live claimant's (an older vadsim's claim left empty by
            # a kill, or garbage), whatever its age
            return holder, "holds no owner record (its process ended while writing it)"
        if holder.get("host") == self.host:
            pid = holder["pid"]
            if not _pid_alive(pid):
                return holder, f"process {pid} on this host has ended"
            start = holder.get("start")
            if start is not None and start != process_start(pid):
                return holder, (f"process {pid} on this host is another process than the "
                                f"claimant (its PID was reused: started {process_start(pid)}, "
                                f"the claimant {start})")
        return None

    @staticmethod
    def _remove(path: Path, holder: dict[str, Any]) -> bool:
        """Remove the claim at ``path`` if it still is ``holder``'s (a fresh claim that replaced
        it meanwhile is put back); True if removed."""
        aside = path.with_name(f"{path.name}.stale-{uuid.uuid4().hex}")
        try:
            os.rename(path, aside)
        except FileNotFoundError:
            return False
        moved = _read_json(aside)
        if (moved if isinstance(moved, dict) else {}) != holder:
            with contextlib.suppress(OSError):
                os.link(aside, path)
            aside.unlink(missing_ok=True)
            return False
        aside.unlink(missing_ok=True)
        return True

    def _take_over_if_stale(self, path: Path, chunk: _Chunk) -> bool:
        """Remove the claim at ``path`` if its holder is gone; True if it is gone now."""
        stale = self._stale(path)
        if stale is None or not self._remove(path, stale[0]):
            return not path.exists()
        warnings.warn(f"{self.where}: took over the claim of {chunk.key} ({stale[1]})",
                      StoreWarning, stacklevel=5)
        return True

    def drop_stale_claim(self, chunk: _Chunk) -> None:
        """Remove a dead holder's claim of a chunk that is finished (it was killed between
        writing the chunk and releasing the claim): nothing to take over, nothing to report."""
        path = self._claim_path(chunk.key)
        stale = self._stale(path) if path.exists() else None
        if stale is not None:
            self._remove(path, stale[0])

    def release(self, key: str) -> None:
        """Remove this process's claim of chunk ``key`` (if it still is this process's)."""
        token = self._held.pop(key, None)
        path = self._claim_path(key)
        holder = _read_json(path)
        if token is not None and isinstance(holder, dict) and holder.get("token") == token:
            path.unlink(missing_ok=True)

    def release_all(self) -> None:
        for key in list(self._held):
            self.release(key)

    def heartbeat(self) -> None:
        """Refresh this process's claims (so that they never look stale while it lives)."""
        now = time.monotonic()
        if now - self._beat < _HEARTBEAT_S:
            return
        self._beat = now
        for key in self._held:
            with contextlib.suppress(OSError):
                os.utime(self._claim_path(key))


# --- running the chunks ----------------------------------------------------------------------


def _make_executor(
    workers: int | None, scheduler: str | None
) -> tuple[Executor, Callable[[], None], int, Callable[[], AbstractContextManager[None]]]:
    """An executor, its closer, how many chunks to keep in flight on it, and the guard that
    stops its runs on Ctrl-C (:func:`vadsim.stop_on_interrupt`)."""
    pool = dask_pool(scheduler) if scheduler else local_threads(workers)
    return pool.executor, pool.close, pool.slots, pool.guard


@dataclass(eq=False)
class _Queue:
    """The chunks of one :func:`sweep` call still to be done, and where each stands."""

    pending: list[_Chunk]
    done: dict[str, list[dict[str, Any]]]
    store: _Store | None
    bar: Any
    running: dict[Future, _Chunk] = field(default_factory=dict)
    elsewhere: set[str] = field(default_factory=set)  # claimed by another live process

    def finish(self, chunk: _Chunk, rows: list[dict[str, Any]]) -> None:
        self.done[chunk.key] = rows
        if self.bar is not None:
            self.bar.update(len(rows))

    def collect_elsewhere(self) -> None:
        """Load the chunks other processes have finished since they were found claimed."""
        if self.store is None:
            return
        for chunk in [c for c in self.pending if c.key in self.elsewhere]:
            rows = self.store.read(chunk)
            if rows is not None:
                self.store.drop_stale_claim(chunk)
                self.pending.remove(chunk)
                self.finish(chunk, rows)

    def start(self, ex: Executor, slots: int) -> None:
        """Claim and submit pending chunks until ``slots`` are in flight."""
        for chunk in list(self.pending):
            if len(self.running) >= slots:
                return
            if self.store is not None:
                if not self.store.claim(chunk):
                    self.elsewhere.add(chunk.key)
                    continue
                rows = self.store.read(chunk)  # finished by another process since we looked?
                if rows is not None:
                    self.store.release(chunk.key)
                    self.pending.remove(chunk)
                    self.finish(chunk, rows)
                    continue
            self.pending.remove(chunk)
            self.elsewhere.discard(chunk.key)
            self.running[ex.submit(run_point, chunk.spec)] = chunk

    def harvest(self) -> None:
        """Wait briefly for chunks in flight; store and record those that finished."""
        finished, _ = wait(self.running, timeout=_POLL_S, return_when=FIRST_COMPLETED)
        self.save(finished)

    def save(self, finished: Iterable[Future]) -> None:
        """Store and record the chunks of ``finished`` futures; then raise the first failure."""
        failed = [f for f in finished if f.cancelled() or f.exception() is not None]
        for fut in finished:
            if fut in failed:
                continue
            chunk = self.running[fut]
            rows = fut.result()
            if self.store is not None:
                self.store.write(chunk, rows)
                self.store.release(chunk.key)
            self.finish(chunk, rows)
            del self.running[fut]  # only now: an interrupt before this saves it again
        if failed:
            failed[0].result()

    def save_finished(self) -> None:
        """On the way out (Ctrl-C, a failure): keep every chunk that finished meanwhile."""
        self.save([f for f in list(self.running) if f.done() and not f.cancelled()
                   and f.exception() is None])


def _run_chunks(todo: Sequence[_Chunk], done: dict[str, list[dict[str, Any]]],
                store: _Store | None, workers: int | None, scheduler: str | None,
                bar: Any) -> None:
    """Compute ``todo`` (adding to ``done`` and the store); with a store, share the work with
    any other process on it: skip the chunks it claimed, then wait for and load them.

    Interrupted (Ctrl-C) or failed, every chunk finished so far is already in the store, this
    process's claims are released and the exception propagates.
    """
    queue = _Queue(list(todo), done, store, bar)
    ex, close, slots, guard = _make_executor(workers, scheduler)
    try:
        with guard():
            while queue.pending or queue.running:
                if store is not None:
                    store.heartbeat()
                queue.collect_elsewhere()
                queue.start(ex, slots)
                if queue.running:
                    queue.harvest()
                elif queue.pending:  # everything left is being computed elsewhere
                    time.sleep(_POLL_S)
    finally:
        try:
            queue.save_finished()
        finally:
            close()
            if store is not None:
                store.release_all()


# --- the inputs --------------------------------------------------------------------------------


def _settings_from(preset: str | None, settings: RunSettings | None,
                   loose: dict[str, Any]) -> RunSettings:
    """The run settings of a sweep: ``settings``, or built from the loose keyword arguments."""
    given = {k: v for k, v in loose.items()
             if v is not None and not (k == "extras" and not isinstance(v, Mapping) and not v)}
    if "extras" in given:
        if isinstance(given["extras"], (Mapping, ExtraSpec, str)):
            raise ValueError(f"extras = {given['extras']!r} must be a sequence of extra forces")
        given["extras"] = tuple(given["extras"])
    if settings is None:
        return RunSettings(get_preset("7in-cde" if preset is None else preset), **given)
    if not isinstance(settings, RunSettings):
        raise ValueError(f"settings = {settings!r} must be a vadsim.RunSettings")
    if given:
        raise ValueError(f"give either settings or {', '.join(given)}, not both")
    if preset is not None and get_preset(preset).name != settings.preset.name:
        raise ValueError(f"preset {preset!r} differs from settings' {settings.preset.name!r}")
    return settings


def _check_options(mode: str, gap_via: str, detail: str, workers: int | None) -> None:
    if mode not in ("independent", "continuation"):
        raise ValueError(f"mode = {mode!r} must be 'independent' or 'continuation'")
    if gap_via not in GAP_REALISATIONS:
        raise ValueError(f"gap_via = {gap_via!r} must be one of {', '.join(GAP_REALISATIONS)}")
    if detail not in DETAILS:
        raise ValueError(f"detail = {detail!r} must be one of {', '.join(DETAILS)}")
    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise ValueError(f"workers = {workers!r} must be a positive integer")


def _flows_and_axes(flows: Sequence[float] | np.ndarray,
                    axes: Mapping[str, Sequence[float] | np.ndarray] | None
                    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    flows_arr = np.asarray(flows, dtype=float).ravel()
    if flows_arr.size == 0:
        raise ValueError("flows is empty")
    if not np.all(np.isfinite(flows_arr)) or np.any(flows_arr <= 0):
        bad = flows_arr[~(np.isfinite(flows_arr) & (flows_arr > 0))][0]
        raise ValueError(f"flows must be finite and > 0, got {bad}")
    axes_arr = {str(k): np.asarray(v, dtype=float).ravel() for k, v in (axes or {}).items()}
    for name, values in axes_arr.items():
        if values.size == 0:
            raise ValueError(f"axis {name!r} is empty")
        if name == "flow_gpm":
            raise ValueError("flow is the sweep's own axis: pass it as flows")
    return flows_arr, axes_arr


def _probe(settings: RunSettings, flows: np.ndarray, axes: dict[str, np.ndarray],
           gap_via: str) -> None:
    """Validate everything now, not in a worker an hour later (and before a store exists): the
    run options and parameters through a one-cycle run of the first point, then the ends of
    every axis. A solver failure of the probe is left to the real run to report."""
    for name in ("cycles", "analyse_cycles"):
        value = getattr(settings, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} = {value!r} must be a finite number > 0")
    if settings.analyse_cycles > settings.cycles:
        raise ValueError(f"analyse_cycles = {settings.analyse_cycles} must be <= cycles = "
                         f"{settings.cycles}")
    with contextlib.suppress(SolverError):
        settings.with_changes(cycles=1, analyse_cycles=1).run(float(flows[0]), record="none")
    base = {**settings.preset.params, **settings.overrides}
    for name, values in axes.items():
        for v in (values.min(), values.max()):
            make_params(settings.preset, {**settings.overrides,
                                          **design_overrides(base, {name: v}, gap_via)},
                        settings.law)


def _make_grid(settings: RunSettings, flows: Sequence[float] | np.ndarray,
               axes: Mapping[str, Sequence[float] | np.ndarray] | None, *, mode: str,
               gap_via: str, detail: str, workers: int | None, portable: bool,
               refine: Refinement | bool | None = None,
               settle_cycles: float | None = None) -> _Grid:
    """Step 1: check every input and describe the computation (ValueError naming a bad one)."""
    _check_options(mode, gap_via, detail, workers)
    settle = _settle(settings, mode, settle_cycles)
    if refine is True:
        refine = Refinement()
    elif refine is False:
        refine = None
    if refine is not None and not isinstance(refine, Refinement):
        raise ValueError(f"refine = {refine!r} must be a Refinement, True or None")
    if refine is not None and mode != "independent":
        raise ValueError("an adaptive map (refine) runs points out of flow order: it needs "
                         "mode = 'independent'")
    flows_arr, axes_arr = _flows_and_axes(flows, axes)
    if portable and not all(isinstance(e, ExtraSpec) for e in settings.extras):
        raise ValueError("extra forces given as core objects cannot be stored or sent to Dask: "
                         "pass them as ExtraSpec or mappings with 'kind'")
    _probe(settings, flows_arr, axes_arr, gap_via)
    return _Grid(settings, flows_arr, axes_arr, mode, gap_via, detail, refine, settle)


def _settle(settings: RunSettings, mode: str, settle_cycles: float | None) -> float | None:
    """The settling of a continued point (None: independent mode, or no shorter than the
    settings' own)."""
    if mode != "continuation":
        if settle_cycles is not None:
            raise ValueError("settle_cycles applies to mode = 'continuation' only")
        return None
    own = float(settings.cycles - settings.analyse_cycles)
    value = CONTINUATION_SETTLE_CYCLES if settle_cycles is None else settle_cycles
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or value < 0:
        raise ValueError(f"settle_cycles = {settle_cycles!r} must be a number >= 0 (cycles)")
    return float(value) if value < own else None


# --- the dataset -------------------------------------------------------------------------------


def _fill(grid: _Grid, chunks: Sequence[_Chunk], done: Mapping[str, list[dict[str, Any]]],
          partial: bool = False) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """One array per feature, every cell from its chunk, and which cells were run
    (RuntimeError if one is missing, unless ``partial``)."""
    data = {name: (np.full(grid.shape, "", dtype=object) if name in _TEXT_FEATURES
                   else np.full(grid.shape, np.nan)) for name in FEATURES}
    filled = np.zeros(grid.shape, dtype=bool)
    for chunk in chunks:
        rows = done[chunk.key]
        if len(rows) != len(chunk.spec.flows):
            raise RuntimeError(f"{chunk.key}: {len(rows)} rows for {len(chunk.spec.flows)} flows")
        for j, row in zip(chunk.flow_index, rows, strict=True):
            cell = (*chunk.index, j)
            for name in FEATURES:
                data[name][cell] = row[name]
            filled[cell] = True
    if not partial and not filled.all():
        raise RuntimeError(f"{int((~filled).sum())} cells of the grid were not computed")
    return data, filled


def _axis_attrs(name: str) -> dict[str, str]:
    if name in _DERIVED_ATTRS:
        return dict(_DERIVED_ATTRS[name])
    table = {row[0]: row for row in param_table()}
    _, unit, meaning, _ = table.get(name, (name, "", name, ""))
    return {"units": "1" if unit == "-" else unit, "long_name": meaning}


def _coords(grid: _Grid) -> dict[str, Any]:
    """Flow, the design axes and the excitation frequency (which varies along ``alpha``)."""
    s = grid.settings
    coords: dict[str, Any] = {"flow_gpm": ("flow_gpm", grid.flows, dict(_FLOW_ATTRS))}
    for name, values in grid.axes.items():
        coords[name] = (name, values, _axis_attrs(name))
    if "alpha" in grid.axes:
        f = np.stack([s.with_changes(overrides={"alpha": float(a)}).f_exc_hz(grid.flows)
                      for a in grid.axes["alpha"]])
        coords["f_exc_hz"] = (("alpha", "flow_gpm"), f, dict(_F_EXC_ATTRS))
    else:
        coords["f_exc_hz"] = ("flow_gpm", s.f_exc_hz(grid.flows), dict(_F_EXC_ATTRS))
    return coords


def _assemble(grid: _Grid, chunks: Sequence[_Chunk], done: Mapping[str, list[dict[str, Any]]]
              ) -> xr.Dataset:
    """Step 5: the dataset, one variable per feature, CF ``units``/``long_name`` everywhere
    (an adaptive map's points not run filled from their agreeing cell, and ``simulated``
    saying which were run)."""
    data, run = _fill(grid, chunks, done, partial=grid.refine is not None)
    if grid.refine is not None:
        fill(grid.shape, grid.refine, data, run)
    dims = (*grid.axes, "flow_gpm")
    ds = xr.Dataset(coords=_coords(grid))
    for name, desc in FEATURES.items():
        arr = data[name]
        if name in _INT_FEATURES:
            arr = arr.astype(np.int64)
        elif name in _TEXT_FEATURES:
            arr = arr.astype(str)
        units, long_name = _FEATURE_ATTRS[name]
        ds[name] = (dims, arr, {"description": desc, "units": units, "long_name": long_name})
    s = grid.settings.as_dict()
    ds.attrs.update(
        preset=s["preset"], mode=grid.mode, cycles=s["cycles"],
        analyse_cycles=s["analyse_cycles"], overrides=json.dumps(s["overrides"]), law=s["law"],
        gap_via=grid.gap_via, extras=json.dumps(s["extras"]), rtol=s["rtol"],
        method=s["method"], detail=grid.detail, wob_klbf=s["wob_klbf"],
        m_ref_kg=grid.settings.preset.m_ref_kg, vadsim_version=_version,
        grid_hash=grid.hash[:16], steady=s["steady"],
        **({"settle_cycles": grid.settle} if grid.settle is not None else {}),
    )
    if grid.refine is not None:
        ds["simulated"] = (dims, run, {"description": "the point was run (else filled from "
                                       "the agreeing cell around it)", "units": "1",
                                       "long_name": "simulated"})
        ds.attrs.update(refine=json.dumps(grid.refine.as_dict()),
                        simulated_fraction=float(run.mean()))
    return ds


def _progress_bar(grid: _Grid, todo: Sequence[_Chunk], progress: bool) -> Any:
    if not progress:
        return None
    from tqdm.auto import tqdm

    if grid.refine is not None:  # how many points an adaptive map runs is found as it goes
        return tqdm(total=None, unit="run", desc=f"{grid.settings.preset.name} adaptive map",
                    smoothing=0.05)
    total = int(np.prod(grid.shape))
    return tqdm(total=total, initial=total - sum(len(c.spec.flows) for c in todo), unit="run",
                desc=f"{grid.settings.preset.name} sweep", smoothing=0.05)


def _run_adaptive(grid: _Grid, store: _Store | None, workers: int | None,
                  scheduler: str | None, bar: Any
                  ) -> tuple[list[_Chunk], dict[str, list[dict[str, Any]]]]:
    """Steps 2-4 of an adaptive map, level by level: run the coarse lattice, then the points
    :func:`vadsim.studies.refine.next_points` chooses, until the stride is one or nothing is
    left to refine. Each level's chunks are loaded from the store first (the choices depend
    only on the results, so a resumed map makes the same ones)."""
    assert grid.refine is not None
    shape = grid.shape
    run = np.zeros(shape, dtype=bool)
    values = {"scenario": np.full(shape, np.nan), "j_pos": np.full(shape, np.nan)}
    stride = grid.refine.coarse
    points = [tuple(int(i) for i in p) for p in product(*(lattice(n, stride) for n in shape))]
    chunks: list[_Chunk] = []
    done: dict[str, list[dict[str, Any]]] = {}
    while points:
        level = grid.point_chunks(points)
        if store is not None:
            done.update(store.load(level, strays_too=False))
        todo = [c for c in level if c.key not in done]
        if bar is not None:
            bar.update(sum(len(c.spec.flows) for c in level) - sum(len(c.spec.flows)
                                                                  for c in todo))
        if todo:
            _run_chunks(todo, done, store, workers, scheduler, bar)
        chunks += level
        for c in level:
            for j, row in zip(c.flow_index, done[c.key], strict=True):
                cell = (*c.index, j)
                run[cell] = True
                values["scenario"][cell] = row["scenario"]
                values["j_pos"][cell] = row["j_pos"]
        stride, points = next_points(shape, stride, values, run, grid.refine)
    return chunks, done


# --- the public entry points -------------------------------------------------------------------


def sweep(
    preset: str | None = None,
    flows: Sequence[float] | np.ndarray = (200.0,),
    axes: Mapping[str, Sequence[float] | np.ndarray] | None = None,
    *,
    settings: RunSettings | None = None,
    overrides: Mapping[str, float] | None = None,
    law: str | None = None,
    extras: Sequence[ExtraSpec | Mapping[str, Any]] = (),
    wob_klbf: float | None = None,
    cycles: float | None = None,
    analyse_cycles: float | None = None,
    mode: str = "independent",
    gap_via: str = "spring",
    rtol: float | None = None,
    method: str | None = None,
    detail: str = "full",
    workers: int | None = None,
    scheduler: str | None = None,
    store: str | os.PathLike[str] | None = None,
    progress: bool = True,
    refine: Refinement | bool | None = None,
    settle_cycles: float | None = None,
) -> xr.Dataset:
    """Run the model over flow rates and (optionally) one or more parameter axes.

    Parameters
    ----------
    preset
        Tool preset name (default ``"7in-cde"``, or the preset of ``settings``).
    flows
        Flow rates (gal/min), in the order a continuation sweep visits them.
    axes
        ``{name: values}`` for each design axis: a Table 2.1 parameter or ``gap_ratio`` /
        ``gap`` (see :func:`design_overrides`). None: a plain flow sweep.
    settings
        Everything but the operating point, as one :class:`~vadsim.RunSettings`; instead of
        ``overrides``, ``law``, ``extras``, ``wob_klbf``, ``cycles``, ``analyse_cycles``,
        ``rtol`` and ``method`` (giving both is an error).
    overrides, law, extras, wob_klbf
        Applied to every point (``extras`` as :class:`~vadsim.model.settings.ExtraSpec` or
        mappings with ``kind``, the arguments of :func:`vadsim.extra_force`).
    cycles, analyse_cycles
        Run length and steady window, in excitation cycles (default 400 and 200).
    mode
        ``"independent"``: every point starts from the static state. ``"continuation"``:
        along each flow row, a point starts from the previous flow's final state and settles
        ``settle_cycles`` before its window (the row's first flow starts from rest).
    gap_via
        Which length realises a gap change.
    rtol, method
        CVODE relative tolerance and method (default 1e-6, ``"adams"``).
    detail
        ``"full"``: every label, peaks and J* on a 20 kHz grid, impact frequency from the
        recorded x1. ``"map"``: regimes, J* and periodicity only (J* and peaks on a 5 kHz
        grid, no impact frequency), about 25 % faster: for large maps.
    workers
        Local threads (default: all cores). Ignored with ``scheduler``.
    scheduler
        Address of a Dask scheduler (``"tcp://host:8786"``): the same grid runs there.
    store
        Folder for finished chunks. A sweep interrupted at any moment (Ctrl-C, kill -9) and
        called again with the same arguments and store resumes where it stopped; several
        processes given the same store share its chunks. Every chunk is verified when read (a
        bad one is recomputed, with a :class:`StoreWarning`); a store of a different grid, or
        whose grid cannot be verified, is refused (ValueError).
    progress
        Show a progress bar (tqdm) on stderr.
    refine
        An adaptive map (:class:`~vadsim.studies.refine.Refinement`; True: its defaults):
        run a coarse lattice, then refine only where regimes, the operating range's edge or
        J* change between neighbours, down to the grid's resolution; the other points are
        filled from the agreeing cell around them (labels from its nearest corner, J* and
        peaks interpolated, never across a boundary). The dataset gains ``simulated``
        (which points were run). Independent mode only; a store resumes it level by level.
    settle_cycles
        Continuation mode: the cycles a continued point settles before its analysed window
        (default :data:`CONTINUATION_SETTLE_CYCLES`; the settings' own ``cycles -
        analyse_cycles`` if that is shorter).

    Returns
    -------
    xarray.Dataset
        Dimensions ``(*axes, "flow_gpm")``; one variable per entry of :data:`FEATURES`, each
        with ``description``, ``units`` and ``long_name`` (coordinates too); attributes
        record the preset, mode, run length, overrides and the vadsim version.
    """
    run = _settings_from(preset, settings, dict(
        overrides=overrides, law=law, extras=extras, wob_klbf=wob_klbf, cycles=cycles,
        analyse_cycles=analyse_cycles, rtol=rtol, method=method))
    grid = _make_grid(run, flows, axes, mode=mode, gap_via=gap_via, detail=detail,
                      workers=workers, portable=store is not None or bool(scheduler),
                      refine=refine, settle_cycles=settle_cycles)
    if grid.refine is not None:
        opened = _Store.open(store, grid) if store is not None else None
        bar = _progress_bar(grid, [], progress)
        try:
            chunks, done = _run_adaptive(grid, opened, workers, scheduler, bar)
        finally:
            if bar is not None:
                bar.close()
        return _assemble(grid, chunks, done)
    chunks = grid.chunks()
    opened = _Store.open(store, grid) if store is not None else None
    done = opened.load(chunks) if opened is not None else {}
    todo = [c for c in chunks if c.key not in done]
    bar = _progress_bar(grid, todo, progress)
    try:
        if todo:
            _run_chunks(todo, done, opened, workers, scheduler, bar)
    finally:
        if bar is not None:
            bar.close()
    return _assemble(grid, chunks, done)


def flow_sweep(preset: str | None = None, flows: Sequence[float] | np.ndarray = (200.0,),
               **kwargs: Any) -> xr.Dataset:
    """A sweep over flow rates only (see :func:`sweep` for the options)."""
    return sweep(preset, flows, None, **kwargs)


def save_dataset(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write a sweep to NetCDF (written to a temporary file, then renamed into place)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # a temporary file of this writer's own: two processes saving to one path each write
    # theirs whole and the last rename wins (a shared OUT.nc.tmp made writes fail)
    tmp = path.with_name(f".{path.name}.{os.getpid()}-{uuid.uuid4().hex}.tmp")
    try:
        ds.to_netcdf(tmp, engine="netcdf4")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def load_dataset(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a sweep written by :func:`save_dataset` (fully loaded, file closed)."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()
