"""Flow sweeps and 2-D maps over flow and design parameters, in parallel and resumable.

Why this module exists: the dissertation's chapter 4 and 5 results are maps of impact regime
and impulse per second J* over flow rate and a design parameter, each point one 400-cycle run.
This module runs such grids on all local cores (threads: the core releases the GIL) or on a
Dask cluster through the same ``concurrent.futures`` interface, writes every finished chunk to
disk atomically so that a map killed at any moment resumes without losing or repeating a
point, and returns an :class:`xarray.Dataset` with one variable per label.

A grid point is described by plain data (preset name, flow, parameter values, overrides), never
by live C++ objects, so it can travel to a Dask worker.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Executor, Future, ThreadPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from vadsim._version import __version__ as _version
from vadsim.model.presets import get_preset, make_params
from vadsim.model.simulate import SURFACES, G, SolverError, extra_force, simulate
from vadsim.signals.labels import impact_frequency, periodicity, poincare_period, scenario

__all__ = [
    "DERIVED_PARAMETERS",
    "FEATURES",
    "GAP_REALISATIONS",
    "PointSpec",
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
    "error": "empty, or why the run failed",
}

# Poincare section scales: 1 mm and 1 m/s, so that "same state" means within 1 um and 1 mm/s
# (POINCARE_RTOL = 1e-3). A periodic 7in run at rtol 1e-6 repeats to 0.2 um and 0.2 mm/s
# (the ~1 kHz sub-LWD mode keeps that much numerical noise), intermittent ones differ by mm.
_SECTION_SCALE = np.r_[np.full(7, 1e-3), np.full(7, 1.0)]
_IMPACT_RATE_HZ = 4096.0


def flows_from_hz(preset: str, hz: Iterable[float]) -> np.ndarray:
    """Flow rates (gal/min) that give excitation frequencies ``hz`` (f = alpha Q / 2 pi)."""
    alpha = get_preset(preset).params["alpha"]
    return np.asarray([2 * math.pi * f / alpha for f in hz], dtype=float)


def design_overrides(
    base: Mapping[str, float], values: Mapping[str, float], gap_via: str = "spring"
) -> dict[str, float]:
    """Translate axis values (Table 2.1 names or derived ones) into parameter overrides.

    Parameters
    ----------
    base
        The parameters the values apply to (a preset's ``params`` merged with overrides).
    values
        ``{name: value}``; ``gap_ratio`` scales the gap L3 - (L2 + LS + LI + LOn), ``gap``
        sets it (in l0); every other name is a Table 2.1 parameter.
    gap_via
        Which length realises a gap change (see :data:`GAP_REALISATIONS`).
    """
    if gap_via not in GAP_REALISATIONS:
        raise ValueError(f"gap_via = {gap_via!r} must be one of {', '.join(GAP_REALISATIONS)}")
    out: dict[str, float] = {}
    gap0 = base["L3"] - (base["L2"] + base["LS"] + base["LI"] + base["LOn"])
    for name, value in values.items():
        if name in DERIVED_PARAMETERS:
            target = gap0 * value if name == "gap_ratio" else value
            delta = target - gap0
            if gap_via == "spring":
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
    """Everything needed to run one row of a grid, as plain (picklable) data."""

    preset: str
    flows: tuple[float, ...]
    values: tuple[tuple[str, float], ...]
    overrides: tuple[tuple[str, float], ...] = ()
    law: str | None = None
    extras: tuple[tuple[tuple[str, Any], ...], ...] = ()
    wob_klbf: float | None = None
    cycles: float = 400
    analyse_cycles: float = 200
    continuation: bool = False
    gap_via: str = "spring"
    rtol: float = 1e-6
    method: str = "adams"
    detail: str = "full"


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
        "j_pos_kN": r.impulse_pos * r.m_ref_kg / 1000.0 if r.m_ref_kg else math.nan,
        "x1_peak_mean_g": m1,
        "x1_peak_std_g": s1,
        "x5_peak_mean_g": m5,
        "x5_peak_std_g": s5,
        "x1_impact_hz": impact_hz,
        "period": int(period),
        "periodicity": label,
        "steps": int(r.stats["steps"]),
        "error": "",
    }
    return row


def _failed_row(message: str) -> dict[str, Any]:
    row: dict[str, Any] = {k: math.nan for k in FEATURES}
    row.update(scenario=-1, period=0, periodicity="failed", steps=0, error=message)
    return row


def run_point(spec: PointSpec) -> list[dict[str, Any]]:
    """Run one row of a grid (every flow of ``spec``) and return one feature dict per flow.

    In continuation mode each flow starts from the previous flow's final state, as in a field
    flow sweep; otherwise every flow starts from the static state. A failed run gives a row
    with ``error`` set (and, in continuation mode, the next flow restarts from rest).
    """
    preset = get_preset(spec.preset)
    base = {**preset.params, **dict(spec.overrides)}
    overrides = {**dict(spec.overrides), **design_overrides(base, dict(spec.values), spec.gap_via)}
    extras = [extra_force(**dict(e)) for e in spec.extras]
    record, summary_rate = DETAILS[spec.detail]
    rows: list[dict[str, Any]] = []
    state = None
    for q in spec.flows:
        try:
            r = simulate(
                preset, q, cycles=spec.cycles, analyse_cycles=spec.analyse_cycles,
                overrides=overrides, law=spec.law, extras=extras, wob_klbf=spec.wob_klbf,
                rtol=spec.rtol, method=spec.method, record=record,
                output_rate_hz=_IMPACT_RATE_HZ, summary_rate_hz=summary_rate,
                initial_state=state,
            )
        except (SolverError, ValueError) as exc:
            rows.append(_failed_row(str(exc)))
            state = None
            continue
        rows.append(_features(r, spec.analyse_cycles))
        state = r.y_end if spec.continuation else None
    return rows


@dataclass
class _Grid:
    preset: str
    flows: np.ndarray
    axes: dict[str, np.ndarray]
    base: dict[str, Any] = field(default_factory=dict)

    def rows(self) -> list[tuple[tuple[int, ...], tuple[tuple[str, float], ...]]]:
        names = list(self.axes)
        shapes = [len(v) for v in self.axes.values()]
        out = []
        for idx in np.ndindex(*shapes) if shapes else [()]:
            values = tuple((n, float(self.axes[n][i])) for n, i in zip(names, idx, strict=True))
            out.append((tuple(int(i) for i in idx), values))
        return out


def _atomic_write_text(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _make_executor(
    workers: int | None, scheduler: str | None
) -> tuple[Executor, Callable[[], None]]:
    if scheduler:
        from dask.distributed import Client

        client = Client(scheduler)
        ex = client.get_executor()

        def close() -> None:
            ex.shutdown(wait=False)
            client.close()

        return ex, close
    ex = ThreadPoolExecutor(max_workers=workers or os.cpu_count() or 1)

    def close_threads() -> None:
        ex.shutdown(wait=False, cancel_futures=True)

    return ex, close_threads


def sweep(
    preset: str = "7in-cde",
    flows: Sequence[float] | np.ndarray = (200.0,),
    axes: Mapping[str, Sequence[float] | np.ndarray] | None = None,
    *,
    overrides: Mapping[str, float] | None = None,
    law: str | None = None,
    extras: Sequence[Mapping[str, Any]] = (),
    wob_klbf: float | None = None,
    cycles: float = 400,
    analyse_cycles: float = 200,
    mode: str = "independent",
    gap_via: str = "spring",
    rtol: float = 1e-6,
    method: str = "adams",
    detail: str = "full",
    workers: int | None = None,
    scheduler: str | None = None,
    store: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> xr.Dataset:
    """Run the model over flow rates and (optionally) one or more parameter axes.

    Parameters
    ----------
    preset
        Tool preset name.
    flows
        Flow rates (gal/min), in the order a continuation sweep visits them.
    axes
        ``{name: values}`` for each design axis: a Table 2.1 parameter or ``gap_ratio`` /
        ``gap`` (see :func:`design_overrides`). None: a plain flow sweep.
    overrides, law, extras, wob_klbf
        Applied to every point (``extras`` as dicts for :func:`vadsim.extra_force`).
    cycles, analyse_cycles
        Run length and steady window, in excitation cycles.
    mode
        ``"independent"``: every point starts from the static state. ``"continuation"``:
        along each flow row, a point starts from the previous flow's final state.
    gap_via
        Which length realises a gap change.
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
        called again with the same arguments and store resumes where it stopped. A store that
        belongs to a different grid is refused.
    progress
        Show a progress bar (tqdm) on stderr.

    Returns
    -------
    xarray.Dataset
        Dimensions ``(*axes, "flow_gpm")``; one variable per entry of :data:`FEATURES`;
        attributes record the preset, mode, run length, overrides and the vadsim version.
    """
    if mode not in ("independent", "continuation"):
        raise ValueError(f"mode = {mode!r} must be 'independent' or 'continuation'")
    if gap_via not in GAP_REALISATIONS:
        raise ValueError(f"gap_via = {gap_via!r} must be one of {', '.join(GAP_REALISATIONS)}")
    if detail not in DETAILS:
        raise ValueError(f"detail = {detail!r} must be one of {', '.join(DETAILS)}")
    if workers is not None and (isinstance(workers, bool) or int(workers) < 1):
        raise ValueError(f"workers = {workers!r} must be a positive integer")
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
    p = get_preset(preset)
    base = {**p.params, **(overrides or {})}
    # Validate everything now, not in a worker an hour later (and before a store exists):
    # the run options and parameters through a one-cycle probe of the first point, then the
    # ends of every axis. A solver failure of the probe is left to the real run to report.
    for name, value in (("cycles", cycles), ("analyse_cycles", analyse_cycles)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} = {value!r} must be a finite number > 0")
    if analyse_cycles > cycles:
        raise ValueError(f"analyse_cycles = {analyse_cycles} must be <= cycles = {cycles}")
    try:
        simulate(p, float(flows_arr[0]), cycles=1, analyse_cycles=1, overrides=overrides,
                 law=law, wob_klbf=wob_klbf, rtol=rtol, method=method, record="none",
                 extras=[extra_force(**dict(e)) for e in extras])
    except SolverError:
        pass
    for name, values in axes_arr.items():
        for v in (values.min(), values.max()):
            make_params(p, {**(overrides or {}), **design_overrides(base, {name: v}, gap_via)},
                        law)
    grid = _Grid(p.name, flows_arr, axes_arr)
    continuation = mode == "continuation"
    common = dict(
        preset=p.name, overrides=tuple(sorted((overrides or {}).items())), law=law,
        extras=tuple(tuple(sorted(e.items())) for e in extras), wob_klbf=wob_klbf,
        cycles=float(cycles), analyse_cycles=float(analyse_cycles), continuation=continuation,
        gap_via=gap_via, rtol=float(rtol), method=method, detail=detail,
    )
    # Chunks: a whole flow row in continuation mode (it is sequential); otherwise rows are cut
    # into pieces of a few flows so that both cores stay busy to the end.
    piece = len(flows_arr) if continuation else max(1, min(len(flows_arr), 8))
    chunks: list[tuple[tuple[int, ...], int, PointSpec]] = []
    for idx, values in grid.rows():
        for start in range(0, len(flows_arr), piece):
            sub = tuple(float(q) for q in flows_arr[start:start + piece])
            chunks.append((idx, start, PointSpec(flows=sub, values=values, **common)))

    spec_doc = {
        "version": 1,
        "flows": flows_arr.tolist(),
        "axes": {k: v.tolist() for k, v in axes_arr.items()},
        "common": {k: (list(v) if isinstance(v, tuple) else v) for k, v in common.items()},
    }
    spec_text = json.dumps(spec_doc, sort_keys=True, default=str)
    done: dict[str, list[dict[str, Any]]] = {}
    store_path = Path(store) if store is not None else None
    if store_path is not None:
        store_path.mkdir(parents=True, exist_ok=True)
        spec_file = store_path / "grid.json"
        if spec_file.exists():
            if spec_file.read_text() != spec_text:
                raise ValueError(
                    f"store {store_path} holds a different grid; use another folder or delete it"
                )
        else:
            _atomic_write_text(spec_file, spec_text)
        for f in store_path.glob("chunk-*.json"):
            try:
                done[f.stem] = json.loads(f.read_text())
            except (OSError, json.JSONDecodeError):
                f.unlink(missing_ok=True)  # cannot happen with atomic writes; recompute anyway

    def key(idx: tuple[int, ...], start: int) -> str:
        return "chunk-" + "-".join(str(i) for i in (*idx, start))

    todo = [(idx, start, spec) for idx, start, spec in chunks if key(idx, start) not in done]
    bar = None
    if progress:
        from tqdm.auto import tqdm

        total = len(flows_arr) * max(1, len(grid.rows()))
        bar = tqdm(total=total, initial=total - sum(len(s.flows) for *_, s in todo),
                   unit="run", desc=f"{p.name} sweep", smoothing=0.05)
    if todo:
        ex, close = _make_executor(workers, scheduler)
        futures: dict[Future, tuple[tuple[int, ...], int]] = {}
        try:
            for idx, start, spec in todo:
                futures[ex.submit(run_point, spec)] = (idx, start)
            for fut in as_completed(futures):
                idx, start = futures[fut]
                rows = fut.result()
                done[key(idx, start)] = rows
                if store_path is not None:
                    _atomic_write_text(store_path / f"{key(idx, start)}.json",
                                       json.dumps(rows, default=float))
                if bar is not None:
                    bar.update(len(rows))
        finally:
            close()
    if bar is not None:
        bar.close()

    shape = tuple(len(v) for v in axes_arr.values()) + (len(flows_arr),)
    data: dict[str, np.ndarray] = {}
    for name in FEATURES:
        kind = object if name in ("periodicity", "error") else float
        data[name] = np.empty(shape, dtype=kind)
    for idx, start, _spec in chunks:
        for j, row in enumerate(done[key(idx, start)]):
            for name in FEATURES:
                data[name][(*idx, start + j)] = row[name]
    dims = (*axes_arr, "flow_gpm")
    alpha = float((overrides or {}).get("alpha", p.params["alpha"]))
    coords: dict[str, Any] = {"flow_gpm": flows_arr}
    coords.update(axes_arr)
    if "alpha" in axes_arr:  # the excitation frequency then varies along that axis too
        coords["f_exc_hz"] = (("alpha", "flow_gpm"),
                              np.outer(axes_arr["alpha"], flows_arr) / (2 * math.pi))
    else:
        coords["f_exc_hz"] = ("flow_gpm", alpha * flows_arr / (2 * math.pi))
    ds = xr.Dataset(coords=coords)
    for name, desc in FEATURES.items():
        arr = data[name]
        if name in ("scenario", "period", "steps"):
            arr = arr.astype(np.int64)
        elif name in ("periodicity", "error"):
            arr = arr.astype(str)
        ds[name] = (dims, arr, {"description": desc})
    ds.attrs.update(
        preset=p.name, mode=mode, cycles=float(cycles), analyse_cycles=float(analyse_cycles),
        overrides=json.dumps(dict(overrides or {})), law=law or p.law, gap_via=gap_via,
        extras=json.dumps([dict(e) for e in extras]), rtol=float(rtol), method=method,
        detail=detail,
        wob_klbf=float(wob_klbf if wob_klbf is not None else p.wob_klbf),
        m_ref_kg=p.m_ref_kg, vadsim_version=_version,
        grid_hash=hashlib.sha256(spec_text.encode()).hexdigest()[:16],
    )
    return ds


def flow_sweep(preset: str = "7in-cde", flows: Sequence[float] | np.ndarray = (200.0,),
               **kwargs: Any) -> xr.Dataset:
    """A sweep over flow rates only (see :func:`sweep` for the options)."""
    return sweep(preset, flows, None, **kwargs)


def save_dataset(ds: xr.Dataset, path: str | os.PathLike[str]) -> Path:
    """Write a sweep to NetCDF (written to a temporary file, then renamed into place)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    ds.to_netcdf(tmp, engine="netcdf4")
    os.replace(tmp, path)
    return path


def load_dataset(path: str | os.PathLike[str]) -> xr.Dataset:
    """Read a sweep written by :func:`save_dataset` (fully loaded, file closed)."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()
