"""Evidence from folded records: the cycle waveform as features, or distributions where a
record does not repeat.

Why this module exists: :mod:`vadsim.signals.folding` recovers the waveform of an excitation
cycle from a 1024 Hz record at an effective rate far above 1024 Hz, impact spike included.
To weigh it against a model like any other evidence it has to become :class:`Feature` objects
(value, spread from the record, support), computed *the same way* from a recording and from a
simulation, so that :func:`vadsim.compare.standardised_residual` can compare them.

Which kind of evidence: the recording decides
---------------------------------------------
A recording is folded on its reference sensor (``x1`` if present, else the first). If that fold
is periodic (:data:`vadsim.signals.folding.PERIODIC_THRESHOLD`) and fills at least
:data:`MIN_COVERAGE` of its bins, every sensor is folded with its frequency and period and gives
**folded features**; otherwise (intermittent or aperiodic regimes, or sampling commensurate
with the excitation: no waveform to compare) every sensor gives **distribution features**,
which need no phase. A simulation computes *every* kind -- distributions and folds of period 1 to
:data:`vadsim.signals.folding.MAX_PERIOD` -- and the residuals take the keys the recording has,
so the model side never needs to know what the recording decided, and a model whose own fold
is aperiodic where the recording's is periodic still gives the folded keys (it just matches
badly), never an error.

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

In a fold of period n > 1 "the largest spike" is fragile: where two cycles of the period have
spikes of nearly the same height, noise or a small model error decides which is largest, and a
recording and a model aligned on different cycles disagree in every waveform bin although they
hold the same waveform (measured: a blind campaign's truth left one period-4 event at RMS
z 6.2, waveform bins up to 24 spreads off, all other events below 0.7). So a simulated fold
also gives its features aligned on the largest spike of each other cycle whose spike reaches
:data:`ALT_SPIKE_FRACTION` of the largest (keys ``<key>@cycle<c>``), and the comparison takes,
per event and period, the alignment that matches the recording best
(:func:`vadsim.compare.event_residuals`): the time origin of a recording is unknown, and so is
which cycle of its period it starts in. Under an alternative alignment the reference's spike
height, width and the other sensors' lags describe the spike the fold was aligned on.

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

The recorded peak, width and lag of a sensor are left out when fewer than
:data:`MIN_COVERAGE` of its fine bins are filled: the spike could sit in a gap. When fewer than
that of the reference's bins are filled (sampling commensurate with the excitation, e.g.
exactly 16 samples per cycle: the samples of every cycle fall on the same 16 phases), the fold
draws no waveform and the record gives distribution features as one that does not repeat.

Features of a record that does not repeat
-----------------------------------------
``<sensor>_q50_g``, ``_q90_g``, ``_q99_g``: quantiles (:data:`QUANTILES`) of ``|a|`` over the
record. A simulation's are those of its fine-grid signal through the analog chain, with the
recordings' noise added (:func:`noisy_quantiles`): the values a noisy sensor sampling at a
uniformly random phase would see.

Spreads and their floors
------------------------
The spread of a recorded feature is its block-to-block standard deviation for blocks of
:data:`vadsim.signals.folding.BLOCK_S` seconds: the record's own variability on a fixed time
scale, not a standard error, so it does not shrink with record length (the folds' blocks have a
fixed duration, and nothing is divided by sqrt(blocks)). For a quantile it is the standard
deviation (``ddof=1``) of the block quantiles. For a folded feature it is computed from the
record *without* each block in turn (delete-one-block jackknife, same frequency, period and
alignment) as ``sqrt((B - 1) sum_b (x_(-b) - mean)^2)``, which for a bin mean is exactly the
standard deviation of the block means (:attr:`vadsim.signals.folding.Fold.block_sd`). Why not
the features of each block's own fold: a block holds ~4 samples per fine bin, so a block's
spike height is the largest of several noisy bins and its half-height crossings wander from
bin to bin; measured at 200 gal/min (spike 0.5 ms wide, 2.4 fine bins) that gave 16 g on a
48 g peak and 0.8 ms on a 0.5 ms width, spreads of the estimator and not of the tool; the
jackknife gives 3 g and 0.2 ms (the floor).

A clean record would give almost nothing, so each spread is floored, as in
:mod:`vadsim.signals.features`:

* accelerations (``_g``): ``max(raw, REL_SPREAD_FLOOR |value|, SPREAD_FLOORS["g"])`` = 2 % of
  the value and 0.5 g -- a few LSB of a +-250 g 12-bit sensor plus its noise; a bin mean of a
  0.3 g-noise record is good to 0.05 g, well inside the floor;
* the width (``_ms``): 2 % of the value, one fine bin (the fold's resolution, 0.2 ms at
  21 Hz), and how far its half-height crossings move if the heights there are off by half the
  0.5 g floor (``0.25 g * (1/slope_right + 1/slope_left)``): a width is only as well known as
  the heights it is read at, and without this a low, broad spike (x5 at 650 gal/min: 1.3 g,
  2.4 ms) had its height compared to within 40 % and its width to within 3 %;
* the lag: :data:`LAG_FLOOR` cycles.

Fewer than two blocks (a record shorter than two blocks) give a NaN spread: the feature is
shown but never compared. A simulation's features have NaN spreads: the recording's spread
standardises the residual.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from vadsim._checks import finite_1d, finite_positive
from vadsim.signals.features import REL_SPREAD_FLOOR, SPREAD_FLOORS, Feature
from vadsim.signals.folding import (
    BLOCK_S,
    FOLD_BINS,
    MAX_PERIOD,
    REFINE,
    Fold,
    fold,
    fold_sums,
)

__all__ = [
    "ALT_MARK",
    "ALT_SPIKE_FRACTION",
    "COARSE_BINS",
    "LAG_FLOOR",
    "MIN_COVERAGE",
    "QUANTILES",
    "QUANTILE_NOISE_SEED",
    "aligned_spike_bin",
    "distribution_features",
    "noisy_quantiles",
    "noise_floor_g",
    "fold_tag",
    "model_fold_features",
    "recorded_fold_features",
    "spike_origin",
    "waveform_values",
]

COARSE_BINS: int = 24
"""Coarse bins per excitation cycle of the per-bin features (10 fine bins each)."""

MIN_COVERAGE: float = 0.5
"""Least fraction of filled fine bins for a recorded coarse bin, or for the spike features."""

QUANTILES: tuple[float, ...] = (50.0, 90.0, 99.0)
"""Percentiles of ``|a|`` of the distribution features."""

LAG_FLOOR: float = 0.02
"""Smallest spread of a lag, cycles: as the 0.02 floor of dimensionless features
(:data:`vadsim.signals.features.SPREAD_FLOORS`), one 1024 Hz sample at 20 Hz."""


_SUPER = 8
"""Super-fine bins per fine bin of a simulation's fold: the resolution of its alignment."""

ALT_SPIKE_FRACTION: float = 0.6
"""In a simulated fold of period n > 1, every cycle whose largest spike reaches this fraction
of the period's largest gives an alternative alignment (module docstring, "Alignment")."""

ALT_MARK = "@cycle"
"""Key suffix of a simulated feature under an alternative alignment: ``<key>@cycle<c>``."""


@dataclass(frozen=True)
class _Shape:
    """What :func:`_sensor_values` needs of a fold besides its mean."""

    period: int
    f_hz: float


def fold_tag(period: int) -> str:
    """Key tag of a fold of ``period`` cycles: ``fold`` for 1, ``fold2``... otherwise."""
    return "fold" if period == 1 else f"fold{period}"


_FOLD_KEY = re.compile(r"_fold(\d*)_")


def fold_periods(keys: Iterable[str]) -> set[int]:
    """The fold periods that feature ``keys`` use (``x1_fold_peak_g`` -> 1,
    ``x5_fold2_lag`` -> 2): a model measured for a recording's keys need fold no other."""
    return {int(m.group(1) or 1) for k in keys if (m := _FOLD_KEY.search(k))}


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


def _spike(mean: np.ndarray, at: int | None = None) -> float:
    """Position of the spike (the largest ``|mean|``, or the one at bin ``at``), in bins from
    the fold's left edge (bin j's centre is j + 0.5): the midpoint of its half-height
    crossings, which lie on the steep flanks and so are located to a small fraction of a bin;
    where one is missing, the top bin to a fraction of a bin by a parabola; NaN if no bin is
    filled."""
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
    out["_spike"] = _spike(m, at) / bins
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
    spike = _spike(probe.mean)
    if not math.isfinite(spike):
        return probe.origin
    target = (probe.bins // coarse) // 2 + 0.5
    return float((probe.origin + (spike - target) / nb) % 1.0)


# --------------------------------------------------------------------------------------------
# Folds to features
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


def _sensor_values(folds: Mapping[str, Fold | _Shape], ref: str, means: Mapping[str, np.ndarray],
                   coarse: int, alternative: bool = False) -> dict[str, dict[str, float]]:
    """Values of every sensor's aligned mean (``means``), lags against ``ref`` included. Under
    an ``alternative`` alignment (a simulated fold aligned on another cycle's spike, see
    "Alignment") the reference's spike features describe the spike it was aligned on; else its
    largest, as always (measured: describing the aligned spike in every fold changed the
    recorded and simulated spike features of an erratic period-2 event, 500 gal/min, enough to
    make the diagnosis of the 6-event hydraulic test campaign add a contact law)."""
    vals = {name: waveform_values(means[name], fo.period, fo.f_hz, coarse,
                                  aligned_spike_bin(means[name], fo.period, coarse)
                                  if alternative and name == ref else None)
            for name, fo in folds.items()}
    for name, v in vals.items():
        if name != ref:
            v["lag"] = _wrap(v["_spike"] - vals[ref]["_spike"])
    return vals


def _floor(suffix: str, value: float, raw: float, width_floor: float) -> float:
    if not (math.isfinite(value) and math.isfinite(raw)):
        return math.nan
    if suffix == "lag":
        return max(raw, LAG_FLOOR)
    floor = width_floor if suffix == "width_ms" else SPREAD_FLOORS["g"]
    return max(raw, REL_SPREAD_FLOOR * abs(value), floor)


def _jackknife_sd(suffix: str, value: float, loo: list[float]) -> float:
    """One-block spread from leave-one-block-out values: ``sqrt((B-1) sum (x_b - mean)^2)``,
    which for a bin mean is exactly the standard deviation (``ddof=1``) of the block means."""
    x = np.array(loo, dtype=float)
    if suffix == "lag":  # deviations from the lag, wrapped like it
        x = value + (((x - value) + 0.5) % 1.0 - 0.5)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return math.nan
    return float(np.sqrt((x.size - 1) * np.sum((x - np.mean(x)) ** 2)))


def _leave_one_out(fo: Fold) -> np.ndarray:
    """Bin means of the record without each block in turn, shape (blocks, bins)."""
    total = np.where(fo.count > 0, fo.mean, 0.0) * fo.count
    block_total = np.where(fo.block_count > 0, fo.block_mean, 0.0) * fo.block_count
    with np.errstate(invalid="ignore", divide="ignore"):
        return (total - block_total) / (fo.count - fo.block_count)


_SPIKE_KEYS = ("peak_g", "width_ms", "lag")


def _recorded_set(folds: Mapping[str, Fold], ref: str, coarse: int) -> dict[str, Feature]:
    """Recorded folded features: values from the whole record, spreads from the record
    without each block in turn (module docstring)."""
    vals = _sensor_values(folds, ref, {k: fo.mean for k, fo in folds.items()}, coarse)
    loo = {k: _leave_one_out(fo) for k, fo in folds.items()}
    n_blocks = folds[ref].block_mean.shape[0]
    pseudo = [_sensor_values(folds, ref, {k: m[b] for k, m in loo.items()}, coarse)
              for b in range(n_blocks)]
    fo_ref = folds[ref]
    tag, fine_ms = fold_tag(fo_ref.period), 1e3 / (fo_ref.bins * fo_ref.f_hz)
    out: dict[str, Feature] = {}
    for name, v in vals.items():
        sparse = folds[name].filled < MIN_COVERAGE or fo_ref.filled < MIN_COVERAGE
        width_floor = max(fine_ms, v["_width_floor_ms"]) if math.isfinite(
            v["_width_floor_ms"]) else fine_ms
        for suffix, value in v.items():
            if suffix.startswith("_") or not math.isfinite(value) or (
                    sparse and suffix in _SPIKE_KEYS):
                continue
            raw = _jackknife_sd(suffix, value, [p[name][suffix] for p in pseudo])
            out[f"{name}_{tag}_{suffix}"] = Feature(value, _floor(suffix, value, raw, width_floor),
                                                    n_blocks)
    return out


def _reference(signals: Mapping[str, object], reference: str | None) -> str:
    if not isinstance(signals, Mapping) or not signals:
        raise ValueError(f"signals must be a non-empty mapping of sensor to array, got {signals!r}")
    if reference is None:
        return "x1" if "x1" in signals else next(iter(signals))
    if reference not in signals:
        raise ValueError(f"reference={reference!r} is none of the sensors {list(signals)}")
    return reference


def distribution_features(signals: Mapping[str, npt.ArrayLike], rate_hz: float, *,
                          block_s: float = BLOCK_S) -> dict[str, Feature]:
    """Quantiles of ``|a|`` of each sensor (``<sensor>_q50_g``...), spreads across blocks.

    What a record that does not repeat is compared by (module docstring): no phase, no
    alignment. Spread: the standard deviation (``ddof=1``) of the same quantile in each block
    of ``block_s`` seconds, floored at 2 % of the value and 0.5 g; NaN with fewer than two
    blocks.

    Raises
    ------
    ValueError
        For a signal that is not 1-D and finite or a rate or block length that is not a finite
        number > 0.
    """
    rate = finite_positive("rate_hz", rate_hz)
    length = max(1, round(finite_positive("block_s", block_s) * rate))
    out: dict[str, Feature] = {}
    for name, sig in signals.items():
        x = np.abs(finite_1d(f"signals[{name!r}]", sig))
        values = np.percentile(x, QUANTILES)
        n_blocks = x.size // length
        per_block = (np.percentile(x[: n_blocks * length].reshape(n_blocks, length), QUANTILES,
                                   axis=1) if n_blocks >= 2 else None)
        for i, q in enumerate(QUANTILES):
            v = float(values[i])
            raw = float(np.std(per_block[i], ddof=1)) if per_block is not None else math.nan
            out[f"{name}_q{q:g}_g"] = Feature(v, _floor("g", v, raw, 0.0), n_blocks)
    return out


def recorded_fold_features(
    signals: Mapping[str, npt.ArrayLike],
    rate_hz: float,
    f_hz: float,
    *,
    t0: float = 0.0,
    reference: str | None = None,
    bins: int = FOLD_BINS,
    coarse: int = COARSE_BINS,
    refine: float = REFINE,
    block_s: float = BLOCK_S,
) -> dict[str, Feature]:
    """Folded features of a recorded event, or its distribution features where it does not
    repeat (module docstring).

    Parameters
    ----------
    signals : mapping of str to array_like
        Sensor name to its samples, g, all of one length, taken at ``t0 + k / rate_hz``.
    rate_hz : float
        Sampling rate, Hz.
    f_hz : float
        Nominal excitation frequency, Hz (refined on the reference sensor).
    t0 : float, optional
        Time of the first sample, s.
    reference : str or None, optional
        The sensor that decides periodicity and alignment; default ``x1``, else the first.
    bins, coarse, refine, block_s
        Fine bins per cycle, coarse bins per cycle, frequency scan half-width and block length
        (:func:`vadsim.signals.folding.fold`).

    Returns
    -------
    dict of str to Feature

    Raises
    ------
    ValueError
        As :func:`vadsim.signals.folding.fold`; for no signals, an unknown reference or
        signals of different lengths.
    """
    ref = _reference(signals, reference)
    arrays = {name: finite_1d(f"signals[{name!r}]", sig) for name, sig in signals.items()}
    if len({a.size for a in arrays.values()}) > 1:
        raise ValueError(f"signals must all have the same length, got "
                         f"{ {k: a.size for k, a in arrays.items()} }")
    probe = fold(arrays[ref], rate_hz, f_hz, t0=t0, bins=bins, refine=refine, block_s=block_s)
    if not probe.periodic or probe.filled < MIN_COVERAGE:
        return distribution_features(arrays, rate_hz, block_s=block_s)
    origin = spike_origin(probe, coarse)
    folds = {name: fold(a, rate_hz, probe.f_hz, t0=t0, period=probe.period, bins=bins,
                        refine=0.0, block_s=block_s, origin=origin)
             for name, a in arrays.items()}
    return _recorded_set(folds, ref, coarse)


def noise_floor_g(signals: Mapping[str, npt.ArrayLike], rate_hz: float, f_hz: float, *,
                  t0: float = 0.0, reference: str | None = None, bins: int = FOLD_BINS,
                  refine: float = REFINE) -> dict[str, float]:
    """Each sensor's noise, g: the median within-bin standard deviation of its fold.

    Folded at the reference's refined frequency and period, a repeating response leaves in
    each bin only what does not repeat: the sensor's noise (FOLDING.md: the within-bin spread
    equals the 0.3 g noise). Measured on written campaigns of 0.3 g and 1 g noise: 0.29-0.33 g
    and 0.99-1.02 g, also where the fold is not called periodic because the noise is large. A
    response that does not repeat adds its own variation (4 g on a chaotic 0.3 g event), so
    a campaign takes the smallest value over its events
    (:func:`vadsim.compare.recorded_noise_g`).

    Parameters
    ----------
    signals, rate_hz, f_hz, t0, reference, bins, refine
        As :func:`recorded_fold_features`.

    Returns
    -------
    dict of str to float
        Sensor name to its noise estimate (NaN where no bin holds two samples).
    """
    ref = _reference(signals, reference)
    arrays = {name: finite_1d(f"signals[{name!r}]", sig) for name, sig in signals.items()}
    probe = fold(arrays[ref], rate_hz, f_hz, t0=t0, bins=bins, refine=refine)
    out = {ref: probe.within_sd}
    for name, a in arrays.items():
        if name != ref:
            out[name] = fold(a, rate_hz, probe.f_hz, t0=t0, period=probe.period, bins=bins,
                             refine=0.0).within_sd
    return out


def _fine_probe(count: np.ndarray, sums: np.ndarray, ref: int) -> np.ndarray:
    """The reference sensor's fine-bin means of a super-fine fold."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(sums[ref].reshape(-1, _SUPER).sum(axis=1)
                          / count.reshape(-1, _SUPER).sum(axis=1))


def _alternative_spikes(probe: np.ndarray, period: int) -> dict[int, int]:
    """Per cycle of a period-``period`` fold other than the largest spike's, the fine bin of
    its own largest spike, where that reaches :data:`ALT_SPIKE_FRACTION` of the largest.
    Cycles are counted from the largest spike (cycle c: within half a cycle of ``c`` cycles
    after it), so that a spike on the fold's edge is not found again in the next cycle."""
    m = np.abs(probe)
    if period < 2 or not np.any(np.isfinite(m)):
        return {}
    top, per = int(np.nanargmax(m)), m.size // period
    out = {}
    for c in range(1, period):
        idx = (top + c * per + np.arange(-(per // 2), per - per // 2)) % m.size
        row = m[idx]
        if not np.any(np.isfinite(row)):
            continue
        j = int(np.nanargmax(row))
        if row[j] >= ALT_SPIKE_FRACTION * m[top]:
            out[c] = int(idx[j])
    return out


def _aligned_means(count: np.ndarray, sums: np.ndarray, probe: np.ndarray, bins: int,
                   coarse: int, at: int | None = None) -> np.ndarray:
    """Fine-bin means of a super-fine fold, aligned as :func:`spike_origin` aligns a recording:
    the reference's spike (located on its fine-bin means ``probe``, :func:`_fine_probe`; the
    largest, or the one at fine bin ``at``) moved to the centre of fine bin ``per // 2`` by a
    whole number of super-fine bins (within 1/16 of a fine bin)."""
    spike = _spike(probe, at)
    target = (bins // coarse) // 2 + 0.5
    shift = round((spike - target) * _SUPER) if math.isfinite(spike) else 0
    c = np.roll(count, -shift).reshape(-1, _SUPER).sum(axis=1)
    s = np.roll(sums, -shift, axis=1).reshape(sums.shape[0], -1, _SUPER).sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(s / c)


QUANTILE_NOISE_SEED = 20_480
"""Seed of the noise a simulation's quantiles get (:func:`noisy_quantiles`): the same draw for
every run, so that a fit's cost does not jitter from one model change to the next."""


@functools.lru_cache(maxsize=64)
def _unit_noise(size: int, stream: int) -> np.ndarray:
    """The fixed standard-normal draw :func:`noisy_quantiles` scales: drawn once per grid
    length and sensor, not on every evaluation of a fit (the same numbers; read-only, as the
    cache shares it)."""
    out = np.random.default_rng([QUANTILE_NOISE_SEED, stream]).normal(0.0, 1.0, size=size)
    out.flags.writeable = False
    return out


def noisy_quantiles(a: np.ndarray, noise_g: float, range_g: float | None = None,
                    stream: int = 0) -> np.ndarray:
    """The quantiles (:data:`QUANTILES`) of ``|a + noise|``, clipped at ``range_g``: what a
    recording of ``a`` with that sensor noise shows.

    Why: a record's ``|a|`` quantiles hold its noise (a 1 g noise moves the median of a
    quiet stretch by most of a g), the simulation's fine-grid signal does not; compared
    noise-free, the 1 g-noise null of the blind benchmark (blind-23) fitted its WOB at the
    lower end of its range (0.85 [0.85, 0.856] for a true 1.0) to raise the model's quantiles.
    The noise is drawn once per sample of the fine grid from a fixed seed (``stream``
    separates sensors); its marginal distribution is what the quantiles see, whatever the
    sampling rate."""
    x = np.asarray(a, dtype=float)
    # One buffer, worked in place (the same operations and values as out-of-place ones): a
    # diagnosis takes these quantiles of every fine sample of every run it measures.
    buf = np.multiply(_unit_noise(x.size, stream), noise_g) if noise_g > 0.0 else x.copy()
    if noise_g > 0.0:
        buf += x
        if range_g is not None:
            np.clip(buf, -range_g, range_g, out=buf)
    np.abs(buf, out=buf)
    return np.asarray(np.percentile(buf, QUANTILES, overwrite_input=True), dtype=float)


def model_fold_features(
    t: npt.ArrayLike,
    signals: Mapping[str, npt.ArrayLike],
    f_hz: float,
    *,
    periods: Iterable[int] = range(1, MAX_PERIOD + 1),
    reference: str | None = None,
    bins: int = FOLD_BINS,
    coarse: int = COARSE_BINS,
    noise_g: Mapping[str, float] | None = None,
    range_g: Mapping[str, float] | None = None,
) -> dict[str, Feature]:
    """Every kind of folded and distribution feature of a simulated event (module docstring).

    The fold is :func:`vadsim.signals.folding.fold_fine`'s (same bins, exact frequency, no
    refinement), computed for speed as one fold at :data:`_SUPER` times finer bins per
    longest period (:func:`vadsim.signals.folding.fold_sums`; the folds of the periods that
    divide it are sums of its cycles), aligned by whole super-fine bins.

    Parameters
    ----------
    t : array_like, shape (n,)
        The solver's uniform fine grid, s.
    signals : mapping of str to array_like
        Sensor name to its acceleration on that grid *after* the analog part of its chain
        (:func:`vadsim.signals.sensor.analog_chain`), g.
    f_hz : float
        The run's exact excitation frequency, Hz.
    periods : iterable of int, optional
        Fold periods to give features for; default 1..MAX_PERIOD (whatever a recording chose).
    reference, bins, coarse
        As :func:`recorded_fold_features`.
    noise_g : mapping of str to float, optional
        Each sensor's noise standard deviation, g, as its recordings carry it: added to the
        signal (then clipped at ``range_g``) for the quantiles only (:func:`noisy_quantiles`);
        a fold's mean averages noise out.
    range_g : mapping of str to float, optional
        Each sensor's range, g, for that clipping.

    Returns
    -------
    dict of str to Feature
        Spreads NaN (a simulation's spread is not used); ``n`` = cycles folded for folds,
        samples for distributions.
    """
    ref = _reference(signals, reference)
    names = list(signals)
    t_arr = finite_1d("t", t)
    stacked = np.stack([finite_1d(f"signals[{k!r}]", signals[k]) for k in names])
    noise, rails = dict(noise_g or {}), dict(range_g or {})
    out = {f"{name}_q{q:g}_g": Feature(float(v), math.nan, t_arr.size)
           for i, (name, a) in enumerate(zip(names, stacked, strict=True))
           for q, v in zip(QUANTILES, noisy_quantiles(a, noise.get(name, 0.0),
                                                      rails.get(name), i), strict=True)}
    wanted = sorted(set(periods))
    cycles = max(1, round((t_arr[-1] - t_arr[0]) * f_hz))
    for base in [m for m in wanted if not any(o != m and o % m == 0 for o in wanted)]:
        count, sums = fold_sums(t_arr, stacked, f_hz, base, base * bins * _SUPER)
        for n in (m for m in wanted if base % m == 0):
            c = count.reshape(base // n, -1).sum(axis=0)
            s = sums.reshape(len(names), base // n, -1).sum(axis=1)
            folds = {k: _Shape(n, f_hz) for k in names}
            probe = _fine_probe(c, s, names.index(ref))
            for alt, at in [(None, None), *_alternative_spikes(probe, n).items()]:
                means = _aligned_means(c, s, probe, bins, coarse, at)
                vals = _sensor_values(folds, ref, dict(zip(names, means, strict=True)), coarse,
                                      alternative=alt is not None)
                mark = "" if alt is None else f"{ALT_MARK}{alt}"
                out.update({f"{k}_{fold_tag(n)}_{x}{mark}": Feature(y, math.nan, cycles)
                            for k, v in vals.items() for x, y in v.items()
                            if not x.startswith("_")})
    return out
