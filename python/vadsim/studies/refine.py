"""Adaptive maps: where to run next, and what the points not run are.

Why this module exists: a thesis-resolution map is 8,245 runs, but the regimes are large flat
regions with a few boundaries between them. An adaptive map runs a coarse lattice of the grid
(every ``coarse``-th point of each axis, the last one included), then halves the stride only
inside the cells whose corners disagree -- another regime, a failed run, the edge of the
operating range (J* within 10 % of its row's best), optionally a J* difference above a
tolerance; any point already run inside the cell counts, not only its corners -- and, on the
coarse lattice, their neighbours (a boundary that passes between two corners is caught by the
cell next to it), down to every point. A point never run lies in a cell whose run points all
agree: it takes their labels (the nearest corner's), and its J* and peaks are interpolated
between the corners -- never across a boundary, since such a cell would have been refined.

The functions here are pure (arrays in, arrays out); :func:`vadsim.studies.sweep.sweep` with
``refine=`` runs the points they choose, with its store, threads or Dask.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from itertools import product

import numpy as np

__all__ = ["CONTINUOUS", "Refinement", "fill", "lattice", "next_points"]

CONTINUOUS = ("j_mean", "j_pos", "j_pos_kN", "x1_peak_mean_g", "x1_peak_std_g",
              "x5_peak_mean_g", "x5_peak_std_g", "x1_impact_hz")
"""Features interpolated inside an agreeing cell; every other one is its nearest corner's."""


@dataclass(frozen=True)
class Refinement:
    """How an adaptive map refines.

    Parameters
    ----------
    coarse
        Stride of the first lattice, a power of two (16: one point in 256 of a 2-D map).
    j_tol
        Refine a cell whose corners' J* differ by more than this fraction of the map's
        largest J* (None: J* differences alone never refine).
    range_edge
        Also refine where the operating range begins or ends: a point with J* within
        ``range_fraction`` of its row's best and another without (off by default: on the
        thesis map it costs a fifth more runs and moves no row's range less).
    range_fraction
        The operating range's definition (0.9: J* within 10 % of the maximum).
    halo, halo_stride
        Cells next to a refined one are refined too (``halo`` rings, at strides from
        ``halo_stride`` up; None: the coarse stride only): a boundary that crosses a large
        cell's edge between two agreeing corners is caught by its neighbour. Below that, a
        cell is refined when any point already run in it (not only its corners) disagrees.
    """

    coarse: int = 16
    j_tol: float | None = None
    range_edge: bool = False
    range_fraction: float = 0.9
    halo: int = 1
    halo_stride: int | None = None

    def __post_init__(self) -> None:
        c = self.coarse
        if isinstance(c, bool) or not isinstance(c, int) or c < 1 or c & (c - 1):
            raise ValueError(f"coarse = {c!r} must be a power of two >= 1")
        if self.j_tol is not None and not (self.j_tol > 0 and math.isfinite(self.j_tol)):
            raise ValueError(f"j_tol = {self.j_tol!r} must be a finite number > 0 or None")
        if not (0 < self.range_fraction < 1):
            raise ValueError(f"range_fraction = {self.range_fraction!r} must be in (0, 1)")
        if isinstance(self.halo, bool) or not isinstance(self.halo, int) or self.halo < 0:
            raise ValueError(f"halo = {self.halo!r} must be an integer >= 0")
        h = self.halo_stride
        if h is not None and (isinstance(h, bool) or not isinstance(h, int) or h < 2):
            raise ValueError(f"halo_stride = {h!r} must be an integer >= 2 or None")

    def as_dict(self) -> dict[str, object]:
        """JSON-ready (a store's grid document and the dataset's attributes)."""
        return {"coarse": self.coarse, "j_tol": self.j_tol, "range_edge": self.range_edge,
                "range_fraction": self.range_fraction, "halo": self.halo,
                "halo_stride": self.halo_stride}


def lattice(n: int, stride: int) -> np.ndarray:
    """Every ``stride``-th index of ``range(n)``, the last one included."""
    return np.unique(np.r_[np.arange(0, n, stride), n - 1]).astype(int)


def _cells(shape: tuple[int, ...], stride: int) -> Iterator[tuple[tuple[int, int], ...]]:
    """Every cell of the stride's lattice: per axis ``(lo, hi)`` consecutive lattice indices
    (an axis of one point gives ``(0, 0)``)."""
    per_axis = []
    for n in shape:
        lat = lattice(n, stride)
        per_axis.append([(int(a), int(b)) for a, b in zip(lat[:-1], lat[1:], strict=True)]
                        if lat.size > 1 else [(0, 0)])
    yield from product(*per_axis)


def _corners(cell: tuple[tuple[int, int], ...]) -> list[tuple[int, ...]]:
    return sorted(set(product(*cell)))


def _disagree(cell: tuple[tuple[int, int], ...], values: Mapping[str, np.ndarray],
              run: np.ndarray, rule: Refinement, j_scale: float, row_best: np.ndarray) -> bool:
    """Whether the points run in a cell (its corners, and any on its edges or inside that a
    neighbour's refinement ran) tell different stories: another regime, a failed run, the
    operating range's edge, or a J* jump above the tolerance. Looking past the corners
    catches an island whose corners agree by chance."""
    box = tuple(slice(lo, hi + 1) for lo, hi in cell)
    seen = run[box]
    scen = values["scenario"][box][seen]
    if np.any(scen != scen[0]) or np.any(scen == -1):
        return True
    j = values["j_pos"][box][seen]
    if not np.all(np.isfinite(j)):
        return True
    if rule.j_tol is not None and j.max() - j.min() > rule.j_tol * j_scale:
        return True
    if rule.range_edge:
        best = np.broadcast_to(row_best[box[:-1]][..., None], seen.shape)[seen]
        inside = j >= rule.range_fraction * best
        if np.any(inside != inside[0]):
            return True
    return False


def _row_best(values: Mapping[str, np.ndarray], run: np.ndarray) -> np.ndarray:
    """Each row's (design value's) largest J* among the points run so far."""
    j = np.where(run, values["j_pos"], -np.inf)
    j = np.where(np.isfinite(j), j, -np.inf)
    return j.max(axis=-1)


def next_points(shape: tuple[int, ...], stride: int, values: Mapping[str, np.ndarray],
                run: np.ndarray, rule: Refinement) -> tuple[int, list[tuple[int, ...]]]:
    """The next stride and the points to run at it.

    At this stride: the finer lattice's points in every cell whose corners are all run and
    disagree, and in ``rule.halo`` rings of cells around them (at strides above 2). At every
    coarser stride too, for cells whose corners were all run only since (by a neighbour's
    refinement): a point is then always inside a run-cornered cell that agrees, or is run.
    Called again at stride 1 it returns what such late cells still need, until nothing.
    ``values`` holds at least ``scenario`` and ``j_pos`` (valid where ``run``); the grid's
    last axis is flow, the others are rows.
    """
    points: set[tuple[int, ...]] = set()
    j_scale, best = _scales(values, run)
    t = rule.coarse
    while t >= max(stride, 2):
        halo_from = rule.halo_stride if rule.halo_stride is not None else rule.coarse
        points |= _refine_at(shape, t, values, run, rule, j_scale, best,
                             halo=rule.halo if t == stride and t >= halo_from else 0)
        t //= 2
    return max(stride // 2, 1), sorted(points)


def _scales(values: Mapping[str, np.ndarray], run: np.ndarray) -> tuple[float, np.ndarray]:
    finite_j = values["j_pos"][run & np.isfinite(values["j_pos"])]
    return (float(finite_j.max()) if finite_j.size else 0.0), _row_best(values, run)


def _refine_at(shape: tuple[int, ...], stride: int, values: Mapping[str, np.ndarray],
               run: np.ndarray, rule: Refinement, j_scale: float, best: np.ndarray,
               halo: int) -> set[tuple[int, ...]]:
    """The points not run of the half-stride lattice in this stride's disagreeing cells
    (corners all run) and in ``halo`` rings of cells around them."""
    cells = list(_cells(shape, stride))
    index = {cell: k for k, cell in enumerate(cells)}
    lats = [lattice(n, stride) for n in shape]
    fine_lats = [lattice(n, max(stride // 2, 1)) for n in shape]
    lat_index = [{int(v): i for i, v in enumerate(lat)} for lat in lats]
    flagged: set[int] = set()
    for k, cell in enumerate(cells):
        corners = _corners(cell)
        if all(run[c] for c in corners) and _disagree(cell, values, run, rule, j_scale, best):
            flagged.add(k)
    # the halo guards the large cells a boundary can cross between agreeing corners
    for _ in range(halo):
        grown = set(flagged)
        for k in flagged:
            pos = [lat_index[a][lo] for a, (lo, _) in enumerate(cells[k])]
            for step in product((-1, 0, 1), repeat=len(shape)):
                nb = []
                for a, (p, d) in enumerate(zip(pos, step, strict=True)):
                    lat = lats[a]
                    q = p + d
                    if lat.size == 1:
                        nb.append((0, 0))
                    elif 0 <= q < lat.size - 1:
                        nb.append((int(lat[q]), int(lat[q + 1])))
                    else:
                        break
                else:
                    grown.add(index[tuple(nb)])
        flagged = grown
    points: set[tuple[int, ...]] = set()
    for k in flagged:
        axes = [lat[(lat >= lo) & (lat <= hi)]
                for lat, (lo, hi) in zip(fine_lats, cells[k], strict=True)]
        points.update(p for p in product(*(map(int, a) for a in axes)) if not run[p])
    return points


def fill(shape: tuple[int, ...], rule: Refinement, values: dict[str, np.ndarray],
         run: np.ndarray) -> None:
    """Give every point not run the values of the smallest cell around it whose corners are
    all run, in place: labels from the nearest corner, :data:`CONTINUOUS` features
    interpolated (multilinear) between the corners. That cell must agree (after
    :func:`next_points` has run dry it always does: a disagreeing one was refined); a point
    whose smallest cell disagrees, or that has none, is an error, never a guess."""
    decided = run.copy()
    j_scale, best = _scales(values, run)
    stride = 2
    while stride <= rule.coarse:
        for cell in _cells(shape, stride):
            corners = _corners(cell)
            if not all(run[c] for c in corners):
                continue
            inner = [np.arange(lo, hi + 1) for lo, hi in cell]
            todo = [p for p in product(*(map(int, a) for a in inner)) if not decided[p]]
            if not todo:
                continue
            if _disagree(cell, values, run, rule, j_scale, best):
                raise RuntimeError(f"adaptive map: the cell {cell} around {todo[0]} "
                                   "disagrees but was not refined")
            for p in todo:
                _fill_point(p, cell, corners, values)
                decided[p] = True
        stride *= 2
    if not decided.all():
        raise RuntimeError(f"{int((~decided).sum())} points of the adaptive map have no cell "
                           "with run corners around them")


def _fill_point(p: tuple[int, ...], cell: tuple[tuple[int, int], ...],
                corners: list[tuple[int, ...]], values: dict[str, np.ndarray]) -> None:
    frac = [(x - lo) / (hi - lo) if hi > lo else 0.0 for x, (lo, hi) in zip(p, cell, strict=True)]
    weights = []
    for c in corners:
        w = 1.0
        for a, (x, (lo, hi)) in enumerate(zip(c, cell, strict=True)):
            if hi > lo:
                w *= frac[a] if x == hi else 1.0 - frac[a]
        weights.append(w)
    nearest = min(corners, key=lambda c: sum((ci - pi) ** 2 for ci, pi in zip(c, p, strict=True)))
    for name, arr in values.items():
        if name in CONTINUOUS:
            arr[p] = sum(w * float(arr[c]) for w, c in zip(weights, corners, strict=True)
                         if w > 0)
        else:
            arr[p] = arr[nearest]
