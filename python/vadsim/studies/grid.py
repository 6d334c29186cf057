"""What a sweep computes, as data: its grid of design values and flows, cut into chunks, and
the run of one row of it.

:func:`make_grid` checks every input of :func:`vadsim.studies.sweep.sweep` and describes the
computation (:class:`Grid`); :class:`Chunk` is the unit that is computed, stored and claimed;
:func:`run_point` runs one row (every flow of a chunk) and returns its features.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from vadsim.model.presets import get_preset, make_params
from vadsim.model.result import SURFACES, G
from vadsim.model.settings import ExtraSpec, RunSettings
from vadsim.model.simulation import SolverError
from vadsim.signals.labels import impact_frequency, periodicity, poincare_period, scenario
from vadsim.studies.refine import Refinement
from vadsim.studies.rows import FEATURES, STORE_FORMAT

__all__ = ["CONTINUATION_SETTLE_CYCLES", "DERIVED_PARAMETERS", "DETAILS", "GAP_REALISATIONS",
           "Chunk", "Grid", "PointSpec", "design_overrides", "flows_from_hz", "make_grid",
           "run_point", "settings_from"]


GAP_REALISATIONS = ("spring", "anvil", "housing")
"""How a change of the anvil-spring gap (MODEL.md Eq. 5.1) is built: moving the spring's end
(``LS``), changing the anvil length above its face (``L2``) or the housing length (``L3``)."""

DERIVED_PARAMETERS = ("gap_ratio", "gap")
"""Axes that are not Table 2.1 names: the gap as a ratio of the preset's gap, or in l0."""


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


def run_features(r, analyse_cycles: float) -> dict[str, Any]:
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
        rows.append(run_features(r, settings.analyse_cycles))
        state = r.y_end if spec.continuation else None
    return rows


# --- the grid and its chunks ---------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Chunk:
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
class Grid:
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

    def chunks(self) -> list[Chunk]:
        """The grid cut into chunks, in the order they are computed."""
        out = []
        for idx, values in self.cells():
            for start in range(0, len(self.flows), self.piece):
                sub = tuple(float(q) for q in self.flows[start:start + self.piece])
                out.append(Chunk(idx, start, PointSpec(self.settings, sub, values,
                                                        self.continuation, self.gap_via,
                                                        self.detail, self.settle)))
        return out

    def point_chunks(self, points: Sequence[tuple[int, ...]]) -> list[Chunk]:
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
                out.append(Chunk(idx, part[0], PointSpec(self.settings, sub, values, False,
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


def settings_from(preset: str | None, settings: RunSettings | None,
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


def make_grid(settings: RunSettings, flows: Sequence[float] | np.ndarray,
               axes: Mapping[str, Sequence[float] | np.ndarray] | None, *, mode: str,
               gap_via: str, detail: str, workers: int | None, portable: bool,
               refine: Refinement | bool | None = None,
               settle_cycles: float | None = None) -> Grid:
    """Step 1: check every input and describe the computation (ValueError naming a bad one).

    Why so many parameters: a grid is the map's axes plus the run settings every point shares;
    :func:`vadsim.studies.sweep.sweep` passes its own.
    """
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
    return Grid(settings, flows_arr, axes_arr, mode, gap_via, detail, refine, settle)


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
