"""Equivalent-time sampling: the excitation cycle's waveform from a 1024 Hz record.

Why this module exists: a 1024 Hz accelerometer takes one or two samples on a 1 ms impact
spike, at a sampling phase nobody knows, so the raw 200 ms peak of a record varies by tens of
g and its shape is lost. In a steady regime the response repeats every excitation cycle (or
every ``n`` cycles) while the samples fall at a different phase of each cycle: sorted by their
excitation phase ``((t f) mod n) / n`` ("folded"), the samples of a few hundred cycles draw the
cycle's waveform at an effective rate far above 1024 Hz, spike included. /work/shared
FOLDING.md measured it on synthetic 7in records: the folded waveform matches the fold of the
noise-free 20 kHz signal to 0.19-0.25 g RMS in periodic regimes.

The method
----------
**Fold.** Each sample's phase ``((t f) mod n) / n`` in [0, 1) of an ``n``-cycle period is cut
into ``bins * n`` bins (``bins`` per excitation cycle, so the resolution does not depend on the
period); each bin holds the mean, count and spread of its samples. Empty bins (sampling nearly
commensurate with the excitation, e.g. exactly 16 samples per cycle at 64 Hz and 1024 Hz,
hits a few phases only) are NaN and counted (:attr:`Fold.filled`), never an error.

**Explained variance.** ``1 - (SS_within / (N - K)) / (SS_total / (N - 1))`` with ``K`` the
filled bins: the adjusted R^2 of the folded mean as a model of the record. Adjusted, because a
fold with more bins explains more of the noise by chance (about ``K / N`` of it); adjusted, a
period-2 fold of a period-1 signal explains the same as the period-1 fold, and the choice of
the period below is fair.

**Frequency refinement.** ``f = alpha Q / (2 pi)`` is known only as well as ``alpha`` and the
flow meter, and an error of 1e-4 drifts the phase by half a cycle over 8 s at 650 gal/min: the
fold smears. ``f`` is refined within ``+-refine`` (relative) by maximising the explained
variance of the full-resolution fold (FOLDING.md's method), in two stages: a grid whose step
drifts the phase by :data:`SCAN_DRIFT` cycles over the first :data:`SCAN_MAX_S` seconds of the
record, then a grid ten times finer over +-2 of those steps on the whole record. The scan
folds with period 2 (unless a period is given): a period-1 signal explains as much folded with
period 2, while a period-2 signal folded with period 1 explains little, and flatly (measured
at 500 gal/min: 0.46 at the right frequency and 0.47 at one 4e-4 off). 250-450 folds of an 8 s
record at 21-69 Hz, 9-23 ms of CPU; a recording is folded once per comparison.

**Mixing.** Near a frequency commensurate with the sampling (16.005 samples per cycle at
600 gal/min, 32.01 at 300, 48.01 at 200) the samples of each cycle fall close to those of the
cycle before, drifting slowly through it, and each bin may hold the samples of one short
stretch of the record only. They agree because the signal is smooth in time, at whatever
frequency: such a fold explains much and shows nothing (:func:`mixing`). On 8 s records every
bin of the right fold holds samples of both halves of the record; on 3 s records at 200, 300
and 600 gal/min (the record covering each cycle once or less) only 7-20 % do, and the scan
then locks onto frequencies up to 6e-4 off that explain more than the right one (x5's spike
came out 11 % narrow at 300 gal/min). A fold counts as periodic only if at least
:data:`MIN_MIXING` of its filled bins are so mixed. Tried and dropped: scanning a short
stretch first, or maximising how well one half of the record predicts the other -- both lock
onto wrong frequencies where the right one covers the cycle only partly in the stretch or
half, measured 4e-4 and 1e-4 off on 8 s records at 600 and 200 gal/min.

**Period.** The explained variance is computed for ``n = 1 .. MAX_PERIOD`` at the refined
frequency; the period is the smallest ``n`` within :data:`PERIOD_MARGIN` of the best.

**Periodic.** :data:`PERIODIC_THRESHOLD` = 0.9 on the explained variance, and
:data:`MIN_MIXING` on the mixing. FOLDING.md measured 0.97 and 0.96 in the periodic regimes 1
and 5 of the 7in tool and 0.14 in the intermittent regime 3; on 8 s synthetic records
(0.3 g noise) the clean regimes give 0.94-0.99 (200-300 and 550-650 gal/min) and 350-450
gal/min 0.10-0.13. In between, the period-2 regime at 500 gal/min gives 0.85-0.89: one impact
of its two is steady (30 g), the other erratic (3-30 g from cycle to cycle). Its fold is no
stable waveform: on 3 s records the frequency scan finds the frequency that best lines up
that record's erratic spikes, and the folded spike came out 29.5 g against 19.8 g for the
model that wrote the record (which is folded at its exact frequency), 4 spreads apart. Below
0.9 a record is compared by :mod:`vadsim.signals.fold_features`'s distributions instead,
which need no frequency and no phase.

**Block spread.** The record is cut into consecutive blocks of ``block_s`` seconds (trailing
partial block dropped) and each block is folded with the same frequency, period and phase
origin; the per-bin standard deviation (``ddof=1``) of the block means across blocks is the
spread. It is the counterpart of the 200 ms window spread of :mod:`vadsim.signals.features`
and, like it, deliberately not a standard error: blocks have a fixed duration, so the spread
does not shrink as a record gets longer (a fixed *number* of blocks would average ever more
noise into each block mean and shrink it as 1/sqrt(length)), and it is never divided by
sqrt(blocks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from vadsim._checks import finite_1d, finite_positive, number
from vadsim.signals.sensor import analog_chain

__all__ = [
    "BLOCK_S",
    "FOLD_BINS",
    "MAX_PERIOD",
    "MIN_MIXING",
    "PERIODIC_THRESHOLD",
    "PERIOD_MARGIN",
    "REFINE",
    "SCAN_DRIFT",
    "SCAN_MAX_S",
    "Fold",
    "explained_variance",
    "fold",
    "fold_fine",
    "fold_sums",
    "mixing",
]

FOLD_BINS: int = 240
"""Bins per excitation cycle: 0.2 ms at 21 Hz, 0.06 ms at 69 Hz, several per 1 ms spike, and
~34 samples per bin from 8 s at 1024 Hz (0.05 g of 0.3 g noise left in a bin mean). A
multiple of the 24 coarse bins of :mod:`vadsim.signals.fold_waveform`."""

MAX_PERIOD: int = 4
"""Longest period, in excitation cycles, a fold is tried with."""

PERIOD_MARGIN: float = 0.02
"""A longer period must explain this much more variance than a shorter one to be chosen:
adjusted R^2 removes the noise a fold of more bins explains by chance, not the part of an
erratic response it does (measured: period 4 chosen over 2 by 0.006 on a 3 s record of the
erratic period-2 regime at 500 gal/min)."""

PERIODIC_THRESHOLD: float = 0.9
"""Explained variance above which a record counts as periodic (module docstring)."""

MIN_MIXING: float = 0.5
"""Least :func:`mixing` of a fold that counts as periodic, and of a frequency the scan may
choose: half the filled bins must hold samples of both halves of the record."""

REFINE: float = 0.002
"""Default half-width of the frequency scan, relative (FOLDING.md's +-0.2 %)."""

BLOCK_S: float = 1.0
"""Block length of the spread, s: 21-69 excitation cycles of the 7in tool and ~4 samples per
bin per block at 1024 Hz -- long enough for a block fold, short enough for 8 blocks in 8 s."""

SCAN_DRIFT: float = 0.005
"""Step of the coarse frequency scan, in cycles of phase drift over the part of the record
scanned: the explained variance of a 1 ms spike's fold falls by a few per cent within
+-0.005 cycles of drift (measured on 8 s records at 200 and 600 gal/min)."""

SCAN_MAX_S: float = 16.0
"""The coarse scan uses at most this much of the record, s (its cost grows as the square of
the length scanned); the fine scan uses all of it."""

_SCAN_PERIOD = 2  # the scan's period when none is given: right for period 1 and 2 signals
_POLISH = 10  # the fine scan's step: SCAN_DRIFT / _POLISH cycles of drift over the record


@dataclass(frozen=True)
class Fold:
    """A folded record: its cycle waveform with counts and spreads.

    Attributes
    ----------
    f_hz : float
        Excitation frequency the samples were folded with (refined, for :func:`fold`), Hz.
    period : int
        Excitation cycles per fold period.
    origin : float
        Phase, in [0, 1) of the period, at the left edge of bin 0.
    phase : numpy.ndarray, shape (bins * period,)
        Bin centres as a fraction of the period, in [0, 1), measured from ``origin``.
    mean : numpy.ndarray
        Mean of the samples in each bin, g; NaN where a bin is empty.
    count : numpy.ndarray of int
        Samples in each bin.
    block_mean : numpy.ndarray, shape (blocks, bins * period)
        Bin means of each block (NaN where a block has no sample in a bin); no rows when the
        record holds fewer than two blocks (:func:`fold_fine` never has rows).
    block_count : numpy.ndarray of int, shape (blocks, bins * period)
        Samples of each block in each bin.
    block_sd : numpy.ndarray
        Standard deviation (``ddof=1``) of ``block_mean`` across blocks, per bin; NaN where
        fewer than two blocks have samples in a bin. Not divided by sqrt(blocks).
    within_sd : float
        Median over bins of two or more samples of the within-bin standard deviation, g: the
        noise plus whatever does not repeat (0.3 g for 0.3 g noise in a periodic regime).
    explained : float
        Explained variance (adjusted R^2) of the folded mean; NaN for a constant record.
    explained_by_period : dict of int to float
        The same for every period tried (only ``period`` when it was given).
    periodic : bool
        ``explained >= PERIODIC_THRESHOLD`` and ``mixed >= MIN_MIXING``.
    filled : float
        Fraction of bins holding at least one sample.
    mixed : float
        Fraction of the filled bins holding samples of both halves of the record
        (:func:`mixing`).
    """

    f_hz: float
    period: int
    origin: float
    phase: np.ndarray = field(repr=False)
    mean: np.ndarray = field(repr=False)
    count: np.ndarray = field(repr=False)
    block_mean: np.ndarray = field(repr=False)
    block_count: np.ndarray = field(repr=False)
    block_sd: np.ndarray = field(repr=False)
    within_sd: float
    explained: float
    explained_by_period: dict[int, float]
    periodic: bool
    filled: float
    mixed: float

    @property
    def bins(self) -> int:
        """Bins per excitation cycle."""
        return self.mean.size // self.period


# --------------------------------------------------------------------------------------------
# Binning
# --------------------------------------------------------------------------------------------


def _bin_index(cycles: np.ndarray, period: int, nbins: int, origin: float) -> np.ndarray:
    """Bin of each sample: its phase ``((cycles mod period) / period - origin) mod 1``."""
    x = cycles * (1.0 / period)  # in place from here on: this runs on 10^5-10^6 samples
    x -= origin
    x -= np.floor(x)
    x *= nbins
    idx = x.astype(np.intp)
    np.minimum(idx, nbins - 1, out=idx)  # x just below 1 may round up to nbins
    return idx


def explained_variance(count: npt.ArrayLike, total: npt.ArrayLike, a: npt.ArrayLike) -> float:
    """Adjusted R^2 of bin means: ``1 - (SS_within/(N-K)) / (SS_total/(N-1))``.

    Parameters
    ----------
    count, total : array_like
        Samples and their sum in each bin (empty bins allowed).
    a : array_like
        The samples themselves (for the total sum of squares).

    Returns
    -------
    float
        NaN for a constant record or one with no more samples than filled bins.
    """
    cnt = np.asarray(count, dtype=float)
    s = np.asarray(total, dtype=float)
    a = np.asarray(a, dtype=float)
    n, filled = a.size, cnt > 0
    k = int(np.count_nonzero(filled))
    grand = float(np.sum(a))
    ss_total = float(np.einsum("i,i->", a, a)) - grand * grand / n  # no BLAS thread spin-up
    ss_between = float(np.sum(s[filled] ** 2 / cnt[filled])) - grand * grand / n
    if not (ss_total > 0.0) or n - k <= 0:
        return math.nan
    return 1.0 - ((ss_total - ss_between) / (n - k)) / (ss_total / (n - 1))


def _halves(idx: np.ndarray, nbins: int) -> np.ndarray:
    """Samples of the first and of the second half of the record in each bin, (2, nbins)."""
    half = (np.arange(idx.size) >= idx.size // 2).astype(np.intp)
    return np.bincount(half * nbins + idx, minlength=2 * nbins).reshape(2, nbins)


def mixing(count_by_half: npt.ArrayLike) -> float:
    """Fraction of the filled bins that hold samples of both halves of the record.

    A fold shows that a signal repeats only where samples far apart in time share a bin. At
    a frequency nearly commensurate with the sampling, every bin may instead hold the samples
    of one short stretch of the record (a few residues of the sample index drifting slowly
    through the cycle), which agree because the signal is smooth in time, whatever the
    frequency: such a fold explains much and proves nothing (module docstring, "Mixing").

    Parameters
    ----------
    count_by_half : array_like, shape (2, bins)
        Samples of the first and of the second half of the record in each bin.

    Returns
    -------
    float
        0 when no bin is filled.
    """
    c = np.asarray(count_by_half)
    filled = np.count_nonzero(c.sum(axis=0))
    return float(np.count_nonzero(np.all(c > 0, axis=0)) / filled) if filled else 0.0


def _score(cycles: np.ndarray, a: np.ndarray, period: int, nbins: int) -> float:
    idx = _bin_index(cycles, period, nbins, 0.0)
    return explained_variance(np.bincount(idx, minlength=nbins),
                              np.bincount(idx, weights=a, minlength=nbins), a)


# --------------------------------------------------------------------------------------------
# Frequency and period
# --------------------------------------------------------------------------------------------


def _scan(tc: np.ndarray, a: np.ndarray, grid: np.ndarray, period: int, nbins: int) -> float:
    """The frequency of ``grid`` whose fold explains most (NaN scores lose)."""
    scores = np.array([_score(tc * f, a, period, nbins) for f in grid])
    if not np.any(np.isfinite(scores)):
        return float(grid[grid.size // 2])
    return float(grid[int(np.nanargmax(scores))])


def _refine(tc: np.ndarray, a: np.ndarray, f0: float, rel: float, period: int,
            bins: int) -> float:
    """Two-stage scan of ``f0 (1 +- rel)`` (module docstring); ``tc`` counts from 0."""
    span = float(tc[-1])
    if rel == 0.0 or span <= 0.0:
        return f0
    nb = bins * period
    m = int(np.searchsorted(tc, min(span, SCAN_MAX_S), side="right"))
    step = SCAN_DRIFT / float(tc[m - 1])
    k = max(1, math.ceil(f0 * rel / step))
    best = _scan(tc[:m], a[:m], f0 + step * np.arange(-k, k + 1), period, nb)
    fine = SCAN_DRIFT / _POLISH / span
    k = max(1, math.ceil(2.0 * step / fine))
    best = _scan(tc, a, best + fine * np.arange(-k, k + 1), period, nb)
    return float(np.clip(best, f0 * (1.0 - rel), f0 * (1.0 + rel)))


def _choose_period(tc: np.ndarray, a: np.ndarray, f: float,
                   bins: int) -> tuple[int, dict[int, float]]:
    scores = {n: _score(tc * f, a, n, bins * n) for n in range(1, MAX_PERIOD + 1)}
    finite = [v for v in scores.values() if math.isfinite(v)]
    if not finite:
        return 1, scores
    best = max(finite)
    return min(n for n, v in scores.items()
               if math.isfinite(v) and v >= best - PERIOD_MARGIN), scores


# --------------------------------------------------------------------------------------------
# The fold
# --------------------------------------------------------------------------------------------


def _check_common(f_hz: object, period: object, bins: object,
                  origin: object) -> tuple[float, int | None, int, float]:
    f = finite_positive("f_hz", f_hz)
    if period is not None and (isinstance(period, bool) or not isinstance(period, int | np.integer)
                               or not 1 <= int(period) <= MAX_PERIOD):
        raise ValueError(f"period must be None or an integer in 1..{MAX_PERIOD}, got {period!r}")
    if isinstance(bins, bool) or not isinstance(bins, int | np.integer) or int(bins) < 2:
        raise ValueError(f"bins must be an integer >= 2, got {bins!r}")
    o = number("origin", origin)
    if not 0.0 <= o < 1.0:
        raise ValueError(f"origin must be in [0, 1) of the fold's period, got {o!r}")
    return f, None if period is None else int(period), int(bins), o


def _build(cycles: np.ndarray, a: np.ndarray, f: float, period: int, bins: int, origin: float,
           scores: dict[int, float], block: np.ndarray | None, n_blocks: int) -> Fold:
    """The :class:`Fold` of samples at ``cycles`` (``t * f``); ``block`` numbers each sample's
    block (-1: in none) when there are ``n_blocks >= 2`` blocks."""
    nb = bins * period
    idx = _bin_index(cycles, period, nb, origin)
    cnt = np.bincount(idx, minlength=nb)
    tot = np.bincount(idx, weights=a, minlength=nb)
    sq = np.bincount(idx, weights=a * a, minlength=nb)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = tot / cnt
        var = (sq - cnt * mean * mean) / (cnt - 1)
    within = var[cnt >= 2]
    within_sd = float(np.median(np.sqrt(np.maximum(within, 0.0)))) if within.size else math.nan
    explained = explained_variance(cnt, tot, a)
    mixed = mixing(_halves(idx, nb))
    scores = {**scores, period: explained}
    block_mean = np.empty((0, nb))
    bc = np.zeros((0, nb), dtype=np.intp)
    block_sd = np.full(nb, math.nan)
    if block is not None and n_blocks >= 2:
        inside = block >= 0
        flat = block[inside] * nb + idx[inside]
        bc = np.bincount(flat, minlength=n_blocks * nb).reshape(n_blocks, nb)
        bs = np.bincount(flat, weights=a[inside], minlength=n_blocks * nb).reshape(n_blocks, nb)
        with np.errstate(invalid="ignore", divide="ignore"):
            block_mean = bs / bc
        block_sd = _nanstd(block_mean)
    return Fold(f_hz=f, period=period, origin=origin, phase=(np.arange(nb) + 0.5) / nb,
                mean=mean, count=cnt, block_mean=block_mean, block_count=bc, block_sd=block_sd,
                within_sd=within_sd, explained=explained, explained_by_period=scores,
                periodic=bool(explained >= PERIODIC_THRESHOLD and mixed >= MIN_MIXING),
                filled=float(np.mean(cnt > 0)), mixed=mixed)


def _nanstd(x: np.ndarray) -> np.ndarray:
    """Standard deviation (``ddof=1``) over axis 0 ignoring NaN; NaN with fewer than 2."""
    ok = np.isfinite(x)
    n = ok.sum(axis=0)
    z = np.where(ok, x, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = z.sum(axis=0) / n
        var = (np.where(ok, (x - m) ** 2, 0.0)).sum(axis=0) / (n - 1)
    return np.where(n >= 2, np.sqrt(np.maximum(var, 0.0)), math.nan)


def fold(
    a: npt.ArrayLike,
    rate_hz: float,
    f_hz: float,
    *,
    t0: float = 0.0,
    period: int | None = None,
    bins: int = FOLD_BINS,
    refine: float = REFINE,
    block_s: float = BLOCK_S,
    origin: float = 0.0,
) -> Fold:
    """Fold a uniformly sampled record by excitation phase (module docstring).

    Why so many parameters: a fold is one record plus how it is folded (frequency, search span,
    period, bins, blocks); each has a default that suits a 1024 Hz record.

    Parameters
    ----------
    a : array_like, shape (n,)
        Samples, g, taken at ``t0 + k / rate_hz``.
    rate_hz : float
        Sampling rate, Hz.
    f_hz : float
        Excitation frequency, Hz: the nominal ``alpha Q / (2 pi)``, refined here.
    t0 : float, optional
        Time of the first sample, s (a recording's ``time_s[0]``); it only moves the phase
        origin, which is arbitrary anyway.
    period : int or None, optional
        Excitation cycles per period, 1..:data:`MAX_PERIOD`; None (default) chooses it.
    bins : int, optional
        Bins per excitation cycle; default :data:`FOLD_BINS`.
    refine : float, optional
        Half-width of the frequency scan, relative; 0 keeps ``f_hz``. Default :data:`REFINE`.
    block_s : float, optional
        Block length of the spread, s; default :data:`BLOCK_S`.
    origin : float, optional
        Phase in [0, 1) of the period placed at the left edge of bin 0 (to align folds).

    Returns
    -------
    Fold

    Raises
    ------
    ValueError
        Naming the argument: ``a`` not 1-D and finite or shorter than 2 samples, a rate,
        frequency or block length that is not a finite number > 0, ``period`` outside
        1..MAX_PERIOD, ``bins`` < 2, ``refine`` outside [0, 0.1), ``origin`` outside [0, 1).
    """
    a = finite_1d("a", a)
    if a.size < 2:
        raise ValueError(f"a needs at least 2 samples, got {a.size}")
    rate = finite_positive("rate_hz", rate_hz)
    f, given, bins, origin = _check_common(f_hz, period, bins, origin)
    t0 = number("t0", t0)
    if not math.isfinite(t0):
        raise ValueError(f"t0 must be finite, got {t0!r}")
    rel = number("refine", refine)
    if not 0.0 <= rel < 0.1:
        raise ValueError(f"refine must be in [0, 0.1), got {rel!r}")
    block_len = max(1, round(finite_positive("block_s", block_s) * rate))

    tc = np.arange(a.size) / rate
    f = _refine(tc, a, f, rel, given or _SCAN_PERIOD, bins)
    if given is None:
        n, scores = _choose_period(tc, a, f, bins)
    else:
        n, scores = given, {}
    n_blocks = a.size // block_len
    block = np.arange(a.size) // block_len
    block[block >= n_blocks] = -1
    cycles = tc * f + (t0 * f) % n  # t0 f kept small: the phase is all that matters
    return _build(cycles, a, f, n, bins, origin, scores, block, n_blocks)


def fold_fine(
    t: npt.ArrayLike,
    a: npt.ArrayLike,
    f_hz: float,
    period: int = 1,
    bins: int = FOLD_BINS,
    *,
    lowpass_hz: float | None = None,
    range_g: float | None = None,
    origin: float = 0.0,
) -> Fold:
    """Fold a simulated signal on the solver's fine grid with its exact frequency.

    The model's side of the comparison: its signal on the fine grid
    (:data:`vadsim.signals.sensor.SIMULATION_OVERSAMPLING` times the sensor rate) goes
    through the analog part of the sensor chain (:func:`vadsim.signals.sensor.analog_chain`:
    the sensor's low-pass and its range) and is folded at the run's own excitation frequency,
    which needs no refinement. A recording's fold averages every sample that falls in a bin,
    so it is a bin average of the signal the sensor sees; this fold is the same bin average
    of the same signal, minus the noise. No blocks (the model's spread is not used).

    Parameters
    ----------
    t : array_like, shape (n,)
        Uniform fine-grid times, s.
    a : array_like, shape (n,)
        Acceleration on that grid, g (before the sensor).
    f_hz : float
        The run's excitation frequency, Hz.
    period : int, optional
        Excitation cycles per period (the recording's); default 1.
    bins : int, optional
        Bins per excitation cycle; default :data:`FOLD_BINS`.
    lowpass_hz, range_g : float or None, optional
        The sensor's anti-alias corner and range; None for none.
    origin : float, optional
        As :func:`fold`.

    Returns
    -------
    Fold

    Raises
    ------
    ValueError
        As :func:`vadsim.signals.sensor.analog_chain` for ``t``, ``a``, ``lowpass_hz`` and
        ``range_g``; as :func:`fold` for the others.
    """
    f, n, bins, origin = _check_common(f_hz, period, bins, origin)
    t_arr = finite_1d("t", t)
    if lowpass_hz is not None or range_g is not None:
        sig, _ = analog_chain(t_arr, a, lowpass_hz=lowpass_hz, range_g=range_g)
    else:
        sig = finite_1d("a", a)
        if sig.shape != t_arr.shape:
            raise ValueError(f"a must have the length of t ({t_arr.size}), got {sig.size}")
    assert n is not None  # period has a default
    return _build(t_arr * f, sig, f, n, bins, origin, {}, None, 0)


def fold_sums(t: npt.ArrayLike, signals: npt.ArrayLike, f_hz: float, period: int,
              nbins: int) -> tuple[np.ndarray, np.ndarray]:
    """Counts and sums of several signals on one grid, folded with one phase computation.

    The raw material of :func:`fold_fine` without its statistics, for a simulation whose
    sensors share the solver's grid and which is folded with several periods and alignments
    (:func:`vadsim.signals.model_folds.model_fold_features`): on 10^5-10^6 fine samples the
    phase of each sample is the expensive part, so it is computed once.

    Parameters
    ----------
    t : array_like, shape (n,)
        Sample times, s.
    signals : array_like, shape (k, n)
        The signals (already through their analog chain), g.
    f_hz : float
        Excitation frequency, Hz.
    period : int
        Excitation cycles per period.
    nbins : int
        Bins over the whole period (not per cycle), origin at phase 0.

    Returns
    -------
    count : numpy.ndarray of int, shape (nbins,)
    sums : numpy.ndarray, shape (k, nbins)
    """
    t_arr = finite_1d("t", t)
    sig = np.asarray(signals, dtype=float)
    if sig.ndim != 2 or sig.shape[1] != t_arr.size:
        raise ValueError(f"signals must have shape (k, {t_arr.size}), got {sig.shape}")
    f, n, nb, _ = _check_common(f_hz, period, nbins, 0.0)
    assert n is not None
    idx = _bin_index(t_arr * f, n, nb, 0.0)
    count = np.bincount(idx, minlength=nb)
    sums = np.empty((sig.shape[0], nb))
    for i, row in enumerate(sig):
        sums[i] = np.bincount(idx, weights=row, minlength=nb)
    return count, sums
