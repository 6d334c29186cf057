"""Evidence from folded records: the cycle waveform as features, or distributions where a
record does not repeat -- which of the two a recording gives, and a recording's features with
their spreads.

Why this module exists: :mod:`vadsim.signals.folding` recovers the waveform of an excitation
cycle from a 1024 Hz record at an effective rate far above 1024 Hz, impact spike included.
To weigh it against a model like any other evidence it has to become :class:`Feature` objects
(value, spread from the record, support), computed *the same way* from a recording and from a
simulation, so that :func:`vadsim.compare.standardised_residual` can compare them. The values
of a fold are read by :mod:`vadsim.signals.fold_waveform` (which also aligns it); a
simulation's features are made by :mod:`vadsim.signals.model_folds`.

Which kind of evidence: the recording decides
---------------------------------------------
A recording is folded on its reference sensor (``x1`` if present, else the first). If that fold
is periodic (:data:`vadsim.signals.folding.PERIODIC_THRESHOLD`) and fills at least
:data:`vadsim.signals.fold_waveform.MIN_COVERAGE` of its bins, every sensor is folded with its
frequency and period and gives **folded features**; otherwise (intermittent or aperiodic
regimes, or sampling commensurate with the excitation: no waveform to compare) every sensor
gives **distribution features**, which need no phase. A simulation computes *every* kind --
distributions and folds of period 1 to :data:`vadsim.signals.folding.MAX_PERIOD` -- and the
residuals take the keys the recording has, so the model side never needs to know what the
recording decided, and a model whose own fold is aperiodic where the recording's is periodic
still gives the folded keys (it just matches badly), never an error.

Features of a periodic record
-----------------------------
Each sensor's aligned fold gives the values of :mod:`vadsim.signals.fold_waveform` -- coarse
bins ``<sensor>_fold_<kk>_g``, spike height ``<sensor>_fold_peak_g`` and width
``<sensor>_fold_width_ms``, RMS ``<sensor>_fold_rms_g`` and, for every sensor but the
reference, ``<sensor>_fold_lag`` -- with the tag ``fold`` for period 1 and ``fold<n>`` for
period n (:func:`fold_tag`).

The recorded peak, width and lag of a sensor are left out when fewer than
:data:`vadsim.signals.fold_waveform.MIN_COVERAGE` of its fine bins are filled: the spike could
sit in a gap. When fewer than that of the reference's bins are filled (sampling commensurate
with the excitation, e.g. exactly 16 samples per cycle: the samples of every cycle fall on the
same 16 phases), the fold draws no waveform and the record gives distribution features as one
that does not repeat.

Features of a record that does not repeat
-----------------------------------------
``<sensor>_q50_g``, ``_q90_g``, ``_q99_g``: quantiles (:data:`QUANTILES`) of ``|a|`` over the
record. A simulation's are those of its fine-grid signal through the analog chain, with the
recordings' noise added (:func:`vadsim.signals.model_folds.noisy_quantiles`): the values a noisy
sensor sampling at a uniformly random phase would see.

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

import math
import re
from collections.abc import Iterable, Mapping

import numpy as np
import numpy.typing as npt

from vadsim._checks import finite_1d, finite_positive
from vadsim.signals.features import REL_SPREAD_FLOOR, SPREAD_FLOORS, Feature
from vadsim.signals.fold_waveform import COARSE_BINS, MIN_COVERAGE, sensor_values, spike_origin
from vadsim.signals.folding import (
    BLOCK_S,
    FOLD_BINS,
    REFINE,
    Fold,
    fold,
)

__all__ = [
    "LAG_FLOOR",
    "QUANTILES",
    "distribution_features",
    "noise_floor_g",
    "fold_tag",
    "has_quantiles",
    "recorded_fold_features",
    "reference_sensor",
]

QUANTILES: tuple[float, ...] = (50.0, 90.0, 99.0)
"""Percentiles of ``|a|`` of the distribution features."""

LAG_FLOOR: float = 0.02
"""Smallest spread of a lag, cycles: as the 0.02 floor of dimensionless features
(:data:`vadsim.signals.features.SPREAD_FLOORS`), one 1024 Hz sample at 20 Hz."""


def fold_tag(period: int) -> str:
    """Key tag of a fold of ``period`` cycles: ``fold`` for 1, ``fold2``... otherwise."""
    return "fold" if period == 1 else f"fold{period}"


_FOLD_KEY = re.compile(r"_fold(\d*)_")


def fold_periods(keys: Iterable[str]) -> set[int]:
    """The fold periods that feature ``keys`` use (``x1_fold_peak_g`` -> 1,
    ``x5_fold2_lag`` -> 2): a model measured for a recording's keys need fold no other."""
    return {int(m.group(1) or 1) for k in keys if (m := _FOLD_KEY.search(k))}


_QUANTILE_KEY = re.compile(r"_q\d+(?:\.\d+)?_g$")


def has_quantiles(keys: Iterable[str]) -> bool:
    """Whether feature ``keys`` hold a distribution feature (``x1_q90_g``): a model measured
    for a recording's keys takes no quantiles otherwise."""
    return any(_QUANTILE_KEY.search(k) for k in keys)


# --------------------------------------------------------------------------------------------
# Folds to features
# --------------------------------------------------------------------------------------------


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
    vals = sensor_values(folds, ref, {k: fo.mean for k, fo in folds.items()}, coarse)
    loo = {k: _leave_one_out(fo) for k, fo in folds.items()}
    n_blocks = folds[ref].block_mean.shape[0]
    pseudo = [sensor_values(folds, ref, {k: m[b] for k, m in loo.items()}, coarse)
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


def reference_sensor(signals: Mapping[str, object], reference: str | None) -> str:
    """The sensor that decides periodicity and alignment: ``reference``, or by default ``x1``
    if present, else the first.

    A recording and a simulation of one event must fold on the same sensor for their features
    to compare, so both sides choose it here.

    Parameters
    ----------
    signals : mapping of str to object
        Sensor name to its signal.
    reference : str or None
        The sensor asked for, or None for the default.

    Returns
    -------
    str
        The reference sensor's name.

    Raises
    ------
    ValueError
        For no signals, or a ``reference`` that is none of them.
    """
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

    Why so many parameters: the features of a recording depend on its conditions (rate, range,
    low-pass), on the fold (periods, bins) and on which evidence is wanted; the comparison
    engine passes each from the campaign.

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
    ref = reference_sensor(signals, reference)
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
    ref = reference_sensor(signals, reference)
    arrays = {name: finite_1d(f"signals[{name!r}]", sig) for name, sig in signals.items()}
    probe = fold(arrays[ref], rate_hz, f_hz, t0=t0, bins=bins, refine=refine)
    out = {ref: probe.within_sd}
    for name, a in arrays.items():
        if name != ref:
            out[name] = fold(a, rate_hz, probe.f_hz, t0=t0, period=probe.period, bins=bins,
                             refine=0.0).within_sd
    return out
