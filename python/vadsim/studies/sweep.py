"""Flow sweeps and 2-D maps over flow and design parameters, in parallel and resumable.

Why this module exists: the dissertation's chapter 4 and 5 results are maps of impact regime
and impulse per second J* over flow rate and a design parameter, each point one 400-cycle run.
This module runs such grids on all local cores (threads: the core releases the GIL) or on a
Dask cluster through the same ``concurrent.futures`` interface, writes every finished chunk to
disk atomically so that a map killed at any moment resumes without losing or repeating a
point, and returns an :class:`xarray.Dataset` with one variable per label.

A grid point is described by plain data (a :class:`~vadsim.model.settings.RunSettings`, the
flows and the design values), never by live C++ objects, so it can travel to a Dask worker.

:func:`sweep` goes through five named steps: check the inputs (:func:`make_grid`), cut the
grid into chunks (:meth:`Grid.chunks`), open and verify the store (:class:`Store`), run the
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

import json
import os
import time
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from vadsim._executors import dask_pool, local_threads
from vadsim._version import __version__ as _version
from vadsim.model.presets import param_table
from vadsim.model.settings import ExtraSpec, RunSettings
from vadsim.studies.grid import (
    CONTINUATION_SETTLE_CYCLES,
    DERIVED_PARAMETERS,
    GAP_REALISATIONS,
    Chunk,
    Grid,
    PointSpec,
    design_overrides,
    flows_from_hz,
    make_grid,
    run_point,
    settings_from,
)
from vadsim.studies.refine import Refinement, fill, lattice, next_points
from vadsim.studies.rows import FEATURE_ATTRS, FEATURES, INT_FEATURES, TEXT_FEATURES
from vadsim.studies.store import Store

__all__ = [
    "CONTINUATION_SETTLE_CYCLES",
    "DERIVED_PARAMETERS",
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


_FLOW_ATTRS = {"units": "gal/min", "long_name": "mud flow rate"}
_F_EXC_ATTRS = {"units": "Hz", "long_name": "excitation frequency"}
_DERIVED_ATTRS = {
    "gap_ratio": {"units": "1", "long_name": "anvil-spring gap / preset gap"},
    "gap": {"units": "l0", "long_name": "anvil-spring gap"},
}


_POLL_S = 0.2




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

    pending: list[Chunk]
    done: dict[str, list[dict[str, Any]]]
    store: Store | None
    bar: Any
    running: dict[Future, Chunk] = field(default_factory=dict)
    elsewhere: set[str] = field(default_factory=set)  # claimed by another live process

    def finish(self, chunk: Chunk, rows: list[dict[str, Any]]) -> None:
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


def _run_chunks(todo: Sequence[Chunk], done: dict[str, list[dict[str, Any]]],
                store: Store | None, workers: int | None, scheduler: str | None,
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


# --- the dataset -------------------------------------------------------------------------------


def _fill(grid: Grid, chunks: Sequence[Chunk], done: Mapping[str, list[dict[str, Any]]],
          partial: bool = False) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """One array per feature, every cell from its chunk, and which cells were run
    (RuntimeError if one is missing, unless ``partial``)."""
    data = {name: (np.full(grid.shape, "", dtype=object) if name in TEXT_FEATURES
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


def _coords(grid: Grid) -> dict[str, Any]:
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


def _assemble(grid: Grid, chunks: Sequence[Chunk], done: Mapping[str, list[dict[str, Any]]]
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
        if name in INT_FEATURES:
            arr = arr.astype(np.int64)
        elif name in TEXT_FEATURES:
            arr = arr.astype(str)
        units, long_name = FEATURE_ATTRS[name]
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


def _progress_bar(grid: Grid, todo: Sequence[Chunk], progress: bool) -> Any:
    if not progress:
        return None
    from tqdm.auto import tqdm

    if grid.refine is not None:  # how many points an adaptive map runs is found as it goes
        return tqdm(total=None, unit="run", desc=f"{grid.settings.preset.name} adaptive map",
                    smoothing=0.05)
    total = int(np.prod(grid.shape))
    return tqdm(total=total, initial=total - sum(len(c.spec.flows) for c in todo), unit="run",
                desc=f"{grid.settings.preset.name} sweep", smoothing=0.05)


def _run_adaptive(grid: Grid, store: Store | None, workers: int | None,
                  scheduler: str | None, bar: Any
                  ) -> tuple[list[Chunk], dict[str, list[dict[str, Any]]]]:
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
    chunks: list[Chunk] = []
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

    Why so many parameters: a map is the run settings of :func:`vadsim.simulate` plus where it
    runs (workers, scheduler, chunks) and how it resumes (store); all keyword-only with
    defaults.

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
    run = settings_from(preset, settings, dict(
        overrides=overrides, law=law, extras=extras, wob_klbf=wob_klbf, cycles=cycles,
        analyse_cycles=analyse_cycles, rtol=rtol, method=method))
    grid = make_grid(run, flows, axes, mode=mode, gap_via=gap_via, detail=detail,
                      workers=workers, portable=store is not None or bool(scheduler),
                      refine=refine, settle_cycles=settle_cycles)
    if grid.refine is not None:
        opened = Store.open(store, grid) if store is not None else None
        bar = _progress_bar(grid, [], progress)
        try:
            chunks, done = _run_adaptive(grid, opened, workers, scheduler, bar)
        finally:
            if bar is not None:
                bar.close()
        return _assemble(grid, chunks, done)
    chunks = grid.chunks()
    opened = Store.open(store, grid) if store is not None else None
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
