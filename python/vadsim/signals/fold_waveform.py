"""The values of one folded waveform -- coarse bins, spike height and width, RMS, lags -- and
where its spike is, by which every fold is aligned.

Why this module exists: a fold (:mod:`vadsim.signals.folding`) gives the mean waveform of an
excitation cycle on fine bins. A recorded fold (:mod:`vadsim.signals.fold_features`) and a
simulated one (:mod:`vadsim.signals.model_folds`) become features the same way: both are
aligned on the reference sensor's spike and read by the functions here, so that a difference
between them is one of the waveform and never of how it was read.

Alignment
---------
A recording's time origin is unknown, so the phase origin of a fold is arbitrary. Every fold,
recorded or simulated, is aligned the same way: the reference sensor's spike is put at the
centre of a fine bin in the middle of the first coarse bin, and *the same shift* is applied to
every sensor of the event. The spike's position is the midpoint of the two half-height
crossings of ``|mean|`` around its largest bin, interpolated linearly; the crossings lie on
the steep flanks, so they are located to a small fraction of a bin (a parabola through the
top three bins is kept only where a crossing is missing: measured at 200 gal/min, where the
spike is 2.4 fine bins wide, the parabola left recorded and simulated folds 0.74 g RMS and
10 g at the spike apart, the crossings 0.09 g and 0.7 g). A recording is folded again with
the aligning origin; a simulation's fold is shifted by whole bins of a fold 8 times finer
(within 1/16 of a fine bin). The sensors share a time base, so where the other sensors' spikes
fall relative to the reference's is evidence (``<sensor>_fold_lag``); aligning each sensor on
its own spike would throw that away. Aligning on the spike rather than on, e.g., the phase of
the excitation's fundamental keeps the spike and its neighbourhood in the same coarse bins
whatever the model gets wrong about *when* in the cycle it happens, so a small timing error
moves a few residuals a little instead of moving the spike into another bin.

Features of a periodic record (period ``n``; tag ``fold`` for n = 1, ``fold<n>`` otherwise)
--------------------------------------------------------------------------------------------
``<sensor>_fold_<kk>_g``
    The aligned folded mean on :data:`COARSE_BINS` coarse bins per cycle (``kk`` = 00, 01...;
    ``n * COARSE_BINS`` bins over the period), each the mean of the fine bins it holds: the
    shape of the cycle at 2.6 ms (21 Hz) to 0.6 ms (69 Hz) resolution. Coarse, because fine
    bins are many, strongly correlated and each noisy; the spike's own detail is in the next
    two features. A recorded coarse bin with fewer than :data:`MIN_COVERAGE` of its fine bins
    filled (sampling nearly commensurate with the excitation) is left out.
``<sensor>_fold_peak_g``
    The spike height: the largest ``|mean|`` over the fine bins, g (a bin average, like the
    model's).
``<sensor>_fold_width_ms``
    The spike's full width at half its height in ``|mean|``, ms, with linear interpolation
    between the fine bins at the half-height crossings.
``<sensor>_fold_rms_g``
    RMS of the folded mean about its own mean, g (offsets are not vibration).
``<sensor>_fold_lag`` (every sensor but the reference)
    Where its spike falls after the reference's, in excitation cycles, within ``[-1/2, 1/2)``
    whatever the period: in a period-n fold the largest spike of each sensor may fall in
    different cycles of the period (of two nearly equal spikes, either), and a lag of a whole
    cycle more says nothing about the timing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from vadsim.signals.features import SPREAD_FLOORS
from vadsim.signals.folding import Fold

__all__ = [
    "COARSE_BINS",
    "MIN_COVERAGE",
    "FoldShape",
    "aligned_spike_bin",
    "sensor_values",
    "spike_origin",
    "spike_position",
    "waveform_values",
]

COARSE_BINS: int = 24
"""Coarse bins per excitation cycle of the per-bin features (10 fine bins each)."""

MIN_COVERAGE: float = 0.5
"""Least fraction of filled fine bins for a recorded coarse bin, or for the spike features."""


@dataclass(frozen=True)
class FoldShape:
    """What :func:`sensor_values` needs of a fold besides its mean.

    A recording's fold is a :class:`vadsim.signals.folding.Fold`; a simulation's is summed
    from a finer fold (:func:`vadsim.signals.model_folds.model_fold_features`) and has no
    ``Fold`` object, so it passes its period and frequency in this record instead.

    Attributes
    ----------
    period : int
        Excitation cycles of the fold.
    f_hz : float
        Excitation frequency, Hz (for the spike width in ms).
    """

    period: int
    f_hz: float


# --------------------------------------------------------------------------------------------
# Values of one folded waveform
# --------------------------------------------------------------------------------------------


def _crossing(values: np.ndarray, peak: float, half: float) -> float:
    """Bins from the peak to where ``values`` (the bins walking away from it) first drop
    below ``half``, interpolated linearly; NaN bins are stepped over; NaN if never."""
    offsets = np.arange(1, values.size + 1, dtype=float)
    ok = np.isfinite(values)
    offsets, values = offsets[ok], values[ok]
    below = np.flatnonzero(values < half)
    if below.size == 0:
        return math.nan
    i = int(below[0])
    x0, y0 = (0.0, peak) if i == 0 else (offsets[i - 1], values[i - 1])
    return float(x0 + (y0 - half) / (y0 - values[i]) * (offsets[i] - x0))


def _top(m: np.ndarray, j: int, width: float) -> float:
    """Height of the spike's top: the vertex of a least-squares parabola through the bins
    within a quarter of the spike's width around its largest bin ``j``, if that is at least
    ``j +- 2``; else the largest bin itself.

    Why not the largest bin: a recorded fold holds noise (0.05-0.08 g per bin at 0.3 g noise
    and 8-3 s), and the largest of the many bins on a broad top is biased up by about two of
    their standard deviations; a simulation's fold has no noise. On x5's spike (2-3.6 ms wide,
    1.3-9 g) that made the recorded top 7 % high and, through its half height, the recorded
    width 0.17 ms narrow on average: a mean standardised residual of +1.7 for the model that
    wrote the record. The fit averages the top's bins instead of picking the largest. A narrow
    spike keeps its largest bin: through three bins a parabola only interpolates, and on an
    impact's near-vertical onset (x1 at 650 gal/min rises from 0.2 to 12 g within a bin) it
    overshoots by an amount that depends on where in its bin the onset falls (measured 19.4
    against 18.5 g for the largest bin)."""
    h = int(width / 4.0) if math.isfinite(width) else 0
    if h < 2:  # a 3-point parabola interpolates, it does not average (and overshoots a step)
        return float(m[j])
    offsets = np.arange(-h, h + 1)
    values = np.take(m, j + offsets, mode="wrap")
    ok = np.isfinite(values)
    if np.count_nonzero(ok) < 5:
        return float(m[j])
    c2, c1, c0 = np.polyfit(offsets[ok].astype(float), values[ok], 2)
    if not c2 < 0.0:
        return float(m[j])
    x = float(np.clip(-c1 / (2.0 * c2), -h, h))
    return float(c0 + c1 * x + c2 * x * x)


def _spike_shape(mean: np.ndarray, at: int | None = None) -> tuple[int, float, float, float]:
    """The spike of a folded mean: its largest bin of ``|mean|`` (or bin ``at``), the height
    of its top (:func:`_top`) and the distances, in bins from that bin's centre, to the
    crossings of half that height on the right and the left (NaN where none within half the
    fold); bin -1 and NaN if no bin is filled."""
    m = np.abs(mean)
    if not np.any(np.isfinite(m)):
        return -1, math.nan, math.nan, math.nan
    j, reach = int(np.nanargmax(m)) if at is None else at, m.size // 2
    if not m[j] > 0.0:
        return j, float(m[j]), math.nan, math.nan
    right = np.take(m, np.arange(j + 1, j + 1 + reach), mode="wrap")
    left = np.take(m, np.arange(j - 1, j - 1 - reach, -1), mode="wrap")
    width = _crossing(right, m[j], m[j] / 2.0) + _crossing(left, m[j], m[j] / 2.0)
    height = _top(m, j, width)
    start = min(float(m[j]), height)  # a parabola's vertex may stand above the largest bin
    return (j, height, _crossing(right, start, height / 2.0),
            _crossing(left, start, height / 2.0))


def spike_position(mean: np.ndarray, at: int | None = None) -> float:
    """Position of the spike (the largest ``|mean|``, or the one at bin ``at``), in bins from
    the fold's left edge (bin j's centre is j + 0.5): the midpoint of its half-height
    crossings, which lie on the steep flanks and so are located to a small fraction of a bin;
    where one is missing, the top bin to a fraction of a bin by a parabola; NaN if no bin is
    filled.

    Every fold, recorded or simulated, is aligned on this position (module docstring,
    "Alignment"): :func:`spike_origin` for a recording, a shift by whole super-fine bins for
    a simulation (:func:`vadsim.signals.model_folds.model_fold_features`).

    Parameters
    ----------
    mean : numpy.ndarray, shape (bins * period,)
        Folded mean, g; NaN in empty bins.
    at : int or None, optional
        Fine bin of the spike to locate; default the largest ``|mean|``.

    Returns
    -------
    float
        The spike's position, bins from the fold's left edge; NaN if no bin is filled.
    """
    j, _, right, left = _spike_shape(mean, at)
    if j < 0:
        return math.nan
    if math.isfinite(right) and math.isfinite(left):
        return j + 0.5 + 0.5 * (right - left)
    m = np.abs(mean)
    lo, hi = m[(j - 1) % m.size], m[(j + 1) % m.size]
    curv = lo - 2.0 * m[j] + hi
    shift = 0.5 * (lo - hi) / curv if math.isfinite(curv) and curv < 0.0 else 0.0
    return j + 0.5 + float(np.clip(shift, -0.5, 0.5))


def waveform_values(mean: npt.ArrayLike, period: int, f_hz: float,
                    coarse: int = COARSE_BINS, at: int | None = None) -> dict[str, float]:
    """The feature values of one aligned folded mean (module docstring), NaN where unknown.

    Parameters
    ----------
    mean : array_like, shape (bins * period,)
        Folded mean, g; NaN in empty bins.
    period : int
        Excitation cycles of the fold.
    f_hz : float
        Excitation frequency, Hz (for the width in ms).
    coarse : int, optional
        Coarse bins per cycle; must divide the bins per cycle.
    at : int or None, optional
        Fine bin of the spike the peak, width and spike phase describe (default: the largest
        ``|mean|``; the aligning spike of a reference sensor, :func:`aligned_spike_bin`).

    Returns
    -------
    dict of str to float
        ``"00_g"``... (coarse bins), ``"peak_g"``, ``"width_ms"``, ``"rms_g"``, and two that
        are no features: ``"_spike"`` (the spike's phase, cycles from the fold's origin) and
        ``"_width_floor_ms"`` (how far the width moves if the heights of its half-height
        crossings are off by the 0.5 g floor of an acceleration; NaN if unknown).
    """
    m = np.asarray(mean, dtype=float)
    bins = m.size // period
    if bins % coarse:
        raise ValueError(f"coarse={coarse} must divide the {bins} bins per cycle")
    per = bins // coarse
    ok = np.isfinite(m)
    with np.errstate(invalid="ignore", divide="ignore"):
        filled = ok.reshape(-1, per).sum(axis=1)
        coarse_mean = np.where(ok, m, 0.0).reshape(-1, per).sum(axis=1) / filled
    coarse_mean[filled < MIN_COVERAGE * per] = math.nan
    digits = max(2, len(str(coarse_mean.size - 1)))
    out = {f"{k:0{digits}d}_g": float(v) for k, v in enumerate(coarse_mean)}
    if not np.any(ok):
        return {**out, "peak_g": math.nan, "width_ms": math.nan, "rms_g": math.nan,
                "_spike": math.nan, "_width_floor_ms": math.nan}
    j, out["peak_g"], right, left = _spike_shape(m, at)
    ms_per_bin = 1e3 / (bins * f_hz)
    out["width_ms"] = (right + left) * ms_per_bin
    out["rms_g"] = float(np.sqrt(np.mean((m[ok] - np.mean(m[ok])) ** 2)))
    out["_spike"] = spike_position(m, at) / bins
    # how far the half-height crossings move if the heights are off by the floor of a g
    slopes = _slope(np.abs(m), j, right, 1), _slope(np.abs(m), j, left, -1)
    out["_width_floor_ms"] = (0.5 * SPREAD_FLOORS["g"] * sum(1.0 / x for x in slopes)
                              * ms_per_bin if min(slopes) > 0.0 else math.nan)
    return out


def _slope(m: np.ndarray, j: int, offset: float, direction: int) -> float:
    """``|d|mean|/d bin|`` across the crossing ``offset`` bins from bin ``j``; NaN if
    unknown."""
    if not math.isfinite(offset):
        return math.nan
    k = math.floor(offset)
    return float(abs(m[(j + direction * k) % m.size] - m[(j + direction * (k + 1)) % m.size]))


def _wrap(x: float) -> float:
    """``x`` cycles into ``[-1/2, 1/2)``."""
    return float((x + 0.5) % 1.0 - 0.5)


def spike_origin(probe: Fold, coarse: int = COARSE_BINS) -> float:
    """The phase origin that aligns a fold (module docstring, "Alignment").

    Folding again with ``origin=spike_origin(probe)`` puts the probe's spike (largest
    ``|mean|``, located to a fraction of a bin) at the centre of fine bin ``per // 2``, in
    the middle of coarse bin 0 (``per`` fine bins per coarse bin). The probe's own origin if it
    has no filled bin.
    """
    nb = probe.mean.size
    spike = spike_position(probe.mean)
    if not math.isfinite(spike):
        return probe.origin
    target = (probe.bins // coarse) // 2 + 0.5
    return float((probe.origin + (spike - target) / nb) % 1.0)


# --------------------------------------------------------------------------------------------
# Values of an event's folds
# --------------------------------------------------------------------------------------------


def aligned_spike_bin(mean: npt.ArrayLike, period: int, coarse: int = COARSE_BINS
                      ) -> int | None:
    """The fine bin of the aligning spike in an aligned fold: the largest ``|mean|`` within
    two fine bins of where alignment put it (the centre of fine bin ``per // 2``); None if
    none of those is filled."""
    m = np.abs(np.asarray(mean, dtype=float))
    j0 = (m.size // period // coarse) // 2
    near = np.take(m, np.arange(j0 - 2, j0 + 3), mode="wrap")
    if not np.any(np.isfinite(near)):
        return None
    return int((j0 - 2 + int(np.nanargmax(near))) % m.size)


def sensor_values(folds: Mapping[str, Fold | FoldShape], ref: str, means: Mapping[str, np.ndarray],
                  coarse: int, alternative: bool = False) -> dict[str, dict[str, float]]:
    """Values of every sensor's aligned mean (``means``), lags against ``ref`` included. Under
    an ``alternative`` alignment (a simulated fold aligned on another cycle's spike, see
    :mod:`vadsim.signals.model_folds`, "Alternative alignments") the reference's spike
    features describe the spike it was aligned on; else its largest, as always (measured:
    describing the aligned spike in every fold changed the recorded and simulated spike
    features of an erratic period-2 event, 500 gal/min, enough to make the diagnosis of the
    6-event hydraulic test campaign add a contact law).

    The one reading of an event's folds, for a recording
    (:func:`vadsim.signals.fold_features.recorded_fold_features`, also for each
    leave-one-block-out fold of its spreads) and for a simulation
    (:func:`vadsim.signals.model_folds.model_fold_features`).

    Parameters
    ----------
    folds : mapping of str to Fold or FoldShape
        Sensor name to its fold (only its period and frequency are read).
    ref : str
        The reference sensor, which the lags are measured against.
    means : mapping of str to numpy.ndarray
        Sensor name to its aligned folded mean, g; NaN in empty bins.
    coarse : int
        Coarse bins per cycle (:func:`waveform_values`).
    alternative : bool, optional
        Whether the folds are aligned on another cycle's spike than the largest.

    Returns
    -------
    dict of str to dict of str to float
        Sensor name to its :func:`waveform_values`, plus ``"lag"`` (cycles, in
        ``[-1/2, 1/2)``) for every sensor but ``ref``.
    """
    vals = {name: waveform_values(means[name], fo.period, fo.f_hz, coarse,
                                  aligned_spike_bin(means[name], fo.period, coarse)
                                  if alternative and name == ref else None)
            for name, fo in folds.items()}
    for name, v in vals.items():
        if name != ref:
            v["lag"] = _wrap(v["_spike"] - vals[ref]["_spike"])
    return vals
