"""Features of one event's acceleration signals over its 200 ms windows, each with its
across-window spread.

Why this module exists: a model run and a field recording are compared feature by feature, and
these are the features of a record cut into the fixed 200 ms windows of
:func:`vadsim.signals.labels.window_peaks` -- the dissertation's three (mean and dispersion of
the window peaks, impact frequency, impacts per cycle), the amplitude spectrum in frequency
bands up to the Nyquist rate (:mod:`vadsim.signals.bands`), and the ratio of the peaks at two
sensors (x5 / x1). Each is a :class:`vadsim.signals.features.Feature` whose spread is the
across-window standard deviation of its per-window quantity, floored; why that spread and not
a standard error, and what the floors are, is told in :mod:`vadsim.signals.features`.

Clipping
--------
A window that holds a clipped sample (RECORDINGS.md: samples at the sensor rails are flagged,
never trusted) has a peak that is only a lower bound; such windows are left out of the peak
features, and the fraction left out is reported as ``clipped_windows``. Dropping the loudest
windows biases the peak mean low, so a large ``clipped_windows`` says the peak features are
not to be trusted much. If every window is clipped the peak features are NaN with ``n = 0``
and a :class:`RuntimeWarning` -- never a silent number. The impact rate and the band RMS use all
windows: a clipped spike is still one peak (``find_peaks`` takes a plateau as one), and the band
RMS is biased low by clipping but leaving windows out would bias it further.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import find_peaks

from vadsim._checks import finite_1d, finite_positive
from vadsim.signals.bands import band_edges_for, band_key, band_rms
from vadsim.signals.features import REL_SPREAD_FLOOR, SPREAD_FLOORS, Feature, spread_kind
from vadsim.signals.labels import (
    IMPACT_HEIGHT_FRAC,
    IMPACT_MIN_DISTANCE_S,
    PEAK_WINDOW_S,
    window_bounds,
)

__all__ = ["IMPACT_THRESHOLD_REL", "event_features", "phase_features", "sensor_features"]

_MIN_WINDOWS: int = 2
# A standard deviation across windows needs at least two of them.

_MIN_WINDOW_SAMPLES: int = 4
# A window of fewer samples has no spectrum worth the name (and no Hann window to speak of).


def _floored(raw: float, value: float, kind: str) -> float:
    if not (math.isfinite(value) and math.isfinite(raw)):
        return math.nan
    return max(raw, REL_SPREAD_FLOOR * abs(value), SPREAD_FLOORS[kind])


def _row_sd(per_window: np.ndarray) -> np.ndarray:
    """The across-window standard deviation (``ddof=1``, windows on axis 1) of each row
    (and band), as :func:`_feature` takes it of one (NaN for fewer than two windows)."""
    if per_window.shape[1] < _MIN_WINDOWS:
        return np.full(per_window.shape[:1] + per_window.shape[2:], math.nan)
    return np.asarray(per_window.std(axis=1, ddof=1))


def _feature(key: str, value: float, per_window: np.ndarray, raw: float | None = None) -> Feature:
    """Feature ``key`` with the floored across-window std of ``per_window`` (or ``raw``)."""
    n = int(per_window.size)
    if raw is None:
        raw = float(np.std(per_window, ddof=1)) if n >= _MIN_WINDOWS else math.nan
    return Feature(float(value), _floored(raw, float(value), spread_kind(key)), n)


_NAN_FEATURE = Feature(math.nan, math.nan, 0)


# --------------------------------------------------------------------------------------------
# One sensor
# --------------------------------------------------------------------------------------------


def _check_clipped(name: str, clipped: npt.ArrayLike | None, size: int) -> np.ndarray:
    if clipped is None:
        return np.zeros(size, dtype=bool)
    arr = np.asarray(clipped)
    if arr.ndim != 1 or arr.size != size:
        raise ValueError(f"{name} must be a 1-D mask of {size} samples, got shape {arr.shape}")
    if arr.dtype != bool:
        if not np.issubdtype(arr.dtype, np.number) or not np.all((arr == 0) | (arr == 1)):
            raise ValueError(f"{name} must be a boolean mask (or 0/1), got dtype {arr.dtype}")
        arr = arr.astype(bool)
    return arr


def _median(x: np.ndarray) -> float:
    """``np.median`` of a few window peaks (finite), the same bits without its overhead: a
    measurement takes one per sensor and sampling phase."""
    if x.size == 0:
        return math.nan
    s = np.sort(x)
    m = s.size // 2
    return float(s[m]) if s.size % 2 else float((s[m - 1] + s[m]) / 2.0)


IMPACT_THRESHOLD_REL: float = 0.1
"""Relative move of the impact threshold (``IMPACT_HEIGHT_FRAC`` x the median window peak)
over which an impact count's sensitivity to it is read (:func:`_impact_peaks`)."""


def _impact_peaks(a_abs: np.ndarray, rate_hz: float, peaks_all: np.ndarray
                  ) -> tuple[np.ndarray, float]:
    """The impact peaks by the rule of :func:`vadsim.signals.labels.impact_frequency` (the
    tests check the two agree), and half the change of their rate, Hz, when the threshold
    moves from ``1 - IMPACT_THRESHOLD_REL`` to ``1 + IMPACT_THRESHOLD_REL`` times its value:
    a spread term of the impact features.

    Why the second: the threshold is half the median 200 ms window peak, and where a spike's
    sampled height beats with the 1024 Hz sampling through the threshold, the count jumps
    with a small change of that median, which a record's windows cannot show (they share
    one threshold). Measured on blind-05 of the own-classes benchmark at 200 gal/min (spikes
    of 23-73 g sampled, a 14 g rebound each cycle): the record counts 1.00 impacts per cycle
    at 0.50 of its median and 0.69 at 0.55, its truth model 0.72 at 0.50 and 0.82 at 0.45;
    with a window spread of 0.02 that one feature gave z = -11 at the truth.

    One search at the lowest threshold serves all three: ``find_peaks`` filters by height
    before distance, and its distance rule only lets a higher peak remove a lower one, so
    the peaks at a higher threshold are those at the lower one that reach it."""
    reference = _median(peaks_all)
    if reference == 0.0:
        return np.zeros(0, dtype=np.intp), 0.0
    threshold = IMPACT_HEIGHT_FRAC * reference
    distance = max(1, round(IMPACT_MIN_DISTANCE_S * rate_hz))
    low, _ = find_peaks(a_abs, height=(1.0 - IMPACT_THRESHOLD_REL) * threshold,
                        distance=distance)
    heights = a_abs[low]
    above = np.count_nonzero(heights >= (1.0 + IMPACT_THRESHOLD_REL) * threshold)
    return low[heights >= threshold], 0.5 * (low.size - above) * rate_hz / a_abs.size


def _window_rates(idx: np.ndarray, rate_hz: float, bounds: np.ndarray) -> np.ndarray:
    """Impact rate of each window, Hz, without the quantisation of a whole-peak count.

    A window of 200 ms holds a whole number of peaks, so a count per window jumps by 5 Hz: a
    perfectly periodic 21.3 Hz train gives windows of 20 and 25 Hz and a spread of 2.2 Hz that
    is all quantisation. Instead, the local rate at sample j is the reciprocal of the interval
    between the two peaks around j, and a window's rate is the mean of the local rate over its
    samples (a count in which the intervals cut by the window edges count in part). A periodic
    train gives its frequency in every window; an irregular one shows its irregularity. Before
    the first and after the last peak the interval is taken as the first (last) one, or the
    time elapsed since (until) that peak if longer, so that a signal falling silent shows a
    falling rate. With fewer than two peaks, plain counts per window are used.
    """
    lengths = np.diff(bounds)
    if idx.size < 2:
        counts = np.histogram(idx, bins=bounds)[0] if idx.size else np.zeros(lengths.size)
        return counts * rate_hz / lengths
    j = np.arange(bounds[-1])
    gaps = np.diff(idx).astype(float)
    # the last peak at or before each sample (idx: increasing, distinct): a running count
    starts = np.zeros(j.size, dtype=np.intp)
    starts[idx[idx < j.size]] = 1
    k = np.clip(np.cumsum(starts) - 1, 0, gaps.size - 1)
    interval = gaps[k]
    before, after = j < idx[0], j > idx[-1]
    interval[before] = np.maximum(gaps[0], idx[0] - j[before])
    interval[after] = np.maximum(gaps[-1], j[after] - idx[-1])
    local = rate_hz / interval
    return np.add.reduceat(local, bounds[:-1]) / lengths


@dataclass(frozen=True)
class _SensorResult:
    features: dict[str, Feature]
    peaks: np.ndarray  # window peaks of |a|, g, every full window
    usable: np.ndarray  # windows without a clipped sample


def _peak_features(name: str, p: np.ndarray, n_windows: int) -> dict[str, Feature]:
    """Mean and dispersion of the window peaks ``p`` (clipped windows already left out)."""
    out: dict[str, Feature] = {}
    if p.size == 0:
        warnings.warn(
            f"{name}: all {n_windows} windows hold clipped samples; the peak features are NaN",
            RuntimeWarning,
            stacklevel=4,
        )
        out["peak_mean_g"] = _NAN_FEATURE
        out["peak_std_g"] = _NAN_FEATURE
    else:
        if p.size < _MIN_WINDOWS:
            warnings.warn(
                f"{name}: only {p.size} of {n_windows} windows free of clipping; the spreads of "
                "the peak features are NaN",
                RuntimeWarning,
                stacklevel=4,
            )
        mean, std = float(np.mean(p)), float(np.std(p))
        out["peak_mean_g"] = _feature("peak_mean_g", mean, p)
        # Delta method: std = sqrt(mean of d), d = squared deviation of a window peak, so
        # sd(std estimate) = sd(d) / (2 std sqrt(n)); times sqrt(n) it is the one-window
        # equivalent, as the std of the peaks is for their mean.
        if p.size < _MIN_WINDOWS:
            raw = math.nan
        elif std == 0.0:
            raw = 0.0
        else:
            raw = float(np.std((p - mean) ** 2, ddof=1)) / (2.0 * std)
        out["peak_std_g"] = _feature("peak_std_g", std, p, raw)
    return out


def _sensor(
    name: str,
    a_g: npt.ArrayLike,
    rate_hz: float,
    f_exc_hz: float | None,
    window_s: float,
    bands: Sequence[tuple[float, float]] | None,
    clipped: npt.ArrayLike | None,
    arg: str = "a_g",
    clipped_arg: str = "clipped",
) -> _SensorResult:
    a = finite_1d(arg, a_g)
    rate_hz = finite_positive("rate_hz", rate_hz)
    window_s = finite_positive("window_s", window_s)
    if f_exc_hz is not None:
        f_exc_hz = finite_positive("f_exc_hz", f_exc_hz)
    band_list = band_edges_for(rate_hz, bands)
    clip = _check_clipped(clipped_arg, clipped, a.size)
    bounds = _bounds(arg, a.size, rate_hz, window_s)
    return _sensor_rows(name, a[np.newaxis], rate_hz, f_exc_hz, bounds, band_list,
                        clip[np.newaxis])[0]


def _bounds(arg: str, size: int, rate_hz: float, window_s: float) -> np.ndarray:
    """The full windows of ``size`` samples; ValueError (naming ``arg``) for fewer than two or
    a window too short for a spectrum."""
    bounds = window_bounds(size, rate_hz, window_s)
    n_windows = bounds.size - 1
    if n_windows < _MIN_WINDOWS:
        raise ValueError(
            f"{arg}: {size} samples at {rate_hz:g} Hz hold {max(n_windows, 0)} full window(s) "
            f"of {window_s:g} s; need at least {_MIN_WINDOWS} for a spread"
        )
    if np.min(np.diff(bounds)) < _MIN_WINDOW_SAMPLES:
        raise ValueError(
            f"window_s: {window_s:g} s at {rate_hz:g} Hz holds fewer than "
            f"{_MIN_WINDOW_SAMPLES} samples"
        )
    return bounds


def _sensor_rows(
    name: str,
    a: np.ndarray,
    rate_hz: float,
    f_exc_hz: float | None,
    bounds: np.ndarray,
    band_list: Sequence[tuple[float, float]],
    clip: np.ndarray,
    sizes: Sequence[int] | None = None,
) -> list[_SensorResult]:
    """The features of each row of ``a`` (shape (rows, n), checked; ``clip`` likewise), one
    record each: the window reductions and the spectra of all rows at once.

    Why rows: a measurement samples one run at several phases (:func:`vadsim.compare.
    measure_event`), and a row at a time the per-call overhead of the reductions and the
    FFT was most of a diagnosis' feature time. A row's result is the same to the bit as
    that row alone (every reduction runs along its own row or window). Rows shorter than
    ``a`` (``sizes``, default all of it) are padded at the end: only their full windows are
    reduced, and their impact peaks are found in their own samples."""
    n_windows = bounds.size - 1
    a_abs = np.abs(a)
    starts = bounds[:-1]
    peaks = np.maximum.reduceat(a_abs[:, : bounds[-1]], starts, axis=1)
    usable = ~np.logical_or.reduceat(clip[:, : bounds[-1]], starts, axis=1)
    # Band RMS: every band's mean and spread in one reduction each (as _feature forms them).
    rms = band_rms(a, rate_hz, bounds, band_list)
    means = rms.mean(axis=1)
    sds = _row_sd(rms)
    band_keys = [band_key(lo, hi) for lo, hi in band_list]
    # Impact rate: value as vadsim.signals.labels.impact_frequency, spread from unquantised
    # window rates; the per-window spreads of every row in one reduction each (a row's own
    # reduction gives the same bits).
    # Its spread: the window rates' and the count's sensitivity to the threshold together.
    impact_hz = np.zeros(a.shape[0])
    threshold_sd = np.zeros(a.shape[0])
    rates = np.zeros((a.shape[0], n_windows))
    for row in range(a.shape[0]):
        size = a.shape[1] if sizes is None else int(sizes[row])
        idx, threshold_sd[row] = _impact_peaks(a_abs[row, :size], rate_hz, peaks[row])
        impact_hz[row] = idx.size * rate_hz / size
        rates[row] = _window_rates(idx, rate_hz, bounds)
    excluded = (~usable).astype(float)
    spreads = {"clipped_windows": _row_sd(excluded),
               "impact_hz": np.hypot(_row_sd(rates), threshold_sd)}
    if f_exc_hz is not None:
        spreads["impacts_per_cycle"] = spreads["impact_hz"] / f_exc_hz
    clipped_share = excluded.mean(axis=1)
    results: list[_SensorResult] = []
    for row in range(a.shape[0]):
        out: dict[str, Feature] = {}
        out.update(_peak_features(name, peaks[row][usable[row]], n_windows))
        out["clipped_windows"] = _feature("clipped_windows", float(clipped_share[row]),
                                          excluded[row], spreads["clipped_windows"][row])
        out["impact_hz"] = _feature("impact_hz", float(impact_hz[row]), rates[row],
                                    spreads["impact_hz"][row])
        if f_exc_hz is not None:
            out["impacts_per_cycle"] = _feature(
                "impacts_per_cycle", float(impact_hz[row]) / f_exc_hz, rates[row],
                spreads["impacts_per_cycle"][row])
        for j, key in enumerate(band_keys):
            value = float(means[row, j])
            out[key] = Feature(value, _floored(float(sds[row, j]), value, "g"), n_windows)
        results.append(_SensorResult(out, peaks[row], usable[row]))
    return results


def sensor_features(
    a_g: npt.ArrayLike,
    rate_hz: float,
    f_exc_hz: float | None = None,
    window_s: float = PEAK_WINDOW_S,
    bands: Sequence[tuple[float, float]] | None = None,
    clipped: npt.ArrayLike | None = None,
) -> dict[str, Feature]:
    """Features of one sensor's acceleration, each with its across-window spread.

    The signal is cut into the full windows of :func:`vadsim.signals.labels.window_peaks` (trailing
    partial window dropped). Keys:

    ``peak_mean_g``
        Mean of the window peaks of ``|a|``, g (:func:`vadsim.signals.labels.peak_stats`);
        spread = the standard deviation (``ddof=1``) of the window peaks. Windows with a
        clipped sample are left out; ``n`` = windows used.
    ``peak_std_g``
        Standard deviation of the same window peaks (``ddof=0``, as
        :func:`vadsim.signals.labels.peak_stats`), g. Spread: with ``d_i = (p_i - mean)**2`` the
        squared deviations, ``std(d, ddof=1) / (2 * peak_std)`` -- the delta-method sampling
        standard deviation of a standard deviation (no normality assumed) times sqrt(n), i.e.
        for one window, consistent with ``peak_mean_g`` (about ``peak_std / sqrt(2)`` for
        normally distributed peaks). Equal peaks give 0 before the floor.
    ``clipped_windows``
        Fraction of windows left out of the peak features for holding a clipped sample;
        ``n`` = all windows, so ``round(value * n)`` windows were left out. Spread = std of
        the 0/1 per-window indicator.
    ``impact_hz``
        Major acceleration peaks per second, by the rule of
        :func:`vadsim.signals.labels.impact_frequency` (same value). Spread: the std of per-window
        impact rates that count the intervals cut by a window edge in part, so that a periodic
        train does not show the 5 Hz quantisation of whole counts in 200 ms (details in
        ``_window_rates``), combined in quadrature with half the change of the rate when the
        threshold moves by +-:data:`IMPACT_THRESHOLD_REL` of itself (a count whose
        threshold sits among the spikes' sampled heights is uncertain by that much; 0 where
        the heights leave a gap around it). ``n`` = all windows.
    ``impacts_per_cycle``
        Only if ``f_exc_hz`` is given: ``impact_hz / f_exc_hz``, spread likewise divided.
        (MODEL.md's Z counts contact onsets per surface in a simulation; this is its
        counterpart from an acceleration, where the surfaces cannot be told apart.)
    ``band_<lo>_<hi>_g``
        RMS of the signal in the band ``[lo, hi)`` Hz, g, per window: Hann-weighted window
        mean removed (offsets are not vibration), Hann window, the periodogram
        with density scaling summed over the band times the bin width, so that a sine of
        amplitude A inside the band gives A / sqrt(2) (for 200 ms windows the band should
        extend 10 Hz beyond the tone on each side, the Hann main lobe). Value = mean over
        all windows, spread = their std.

    Every spread is floored (:mod:`vadsim.signals.features`): ``max(raw, 2 % of |value|,
    0.5 g / 0.5 Hz / 0.02)``.

    Parameters
    ----------
    a_g : array_like, shape (n,)
        Uniformly sampled acceleration, g; at least two full windows.
    rate_hz : float
        Sampling rate, Hz.
    f_exc_hz : float, optional
        Excitation frequency, Hz; adds ``impacts_per_cycle``.
    window_s : float, optional
        Window length, s; default 0.2 (dissertation section 3.2).
    bands : sequence of (lo, hi), optional
        Frequency bands, Hz; default :data:`vadsim.signals.bands.DEFAULT_BANDS`. Adapted to the
        Nyquist rate by :func:`vadsim.signals.bands.band_edges_for`.
    clipped : array_like of bool, shape (n,), optional
        True at samples at the sensor rails (e.g. from :func:`vadsim.signals.sensor.sensor_chain` or
        the recording's flags).

    Returns
    -------
    dict of str to Feature
        In the order listed above.

    Raises
    ------
    ValueError
        Naming the argument: a non-finite or non-1-D ``a_g``, a rate, frequency or window that
        is not a finite number > 0, fewer than two full windows, a window of fewer than four
        samples, a malformed band or one without a frequency bin, a ``clipped`` mask of the
        wrong length or type.

    Warns
    -----
    RuntimeWarning
        If fewer than two windows are free of clipping (spreads NaN); if none is, the peak
        features are ``Feature(nan, nan, 0)``.
    """
    return _sensor("a_g", a_g, rate_hz, f_exc_hz, window_s, bands, clipped).features


# --------------------------------------------------------------------------------------------
# One event
# --------------------------------------------------------------------------------------------


def event_features(
    signals: Mapping[str, npt.ArrayLike],
    rate_hz: float,
    f_exc_hz: float | None = None,
    clipped: Mapping[str, npt.ArrayLike] | None = None,
    *,
    window_s: float = PEAK_WINDOW_S,
    bands: Sequence[tuple[float, float]] | None = None,
) -> dict[str, Feature]:
    """Features of every sensor of one event, keys prefixed ``<sensor>_``, plus the x5/x1 ratio.

    Each sensor goes through :func:`sensor_features` (``x1_peak_mean_g``,
    ``x5_band_50_100_g``, ...). When both ``x1`` and ``x5`` are present, ``x5_x1_peak_ratio``
    is added: the mean x5 window peak over the mean x1 window peak, both over the windows free
    of clipping in *both* sensors (so that the two means cover the same time); spread = std of
    the per-window ratios ``p5_i / p1_i`` over those windows (windows with ``p1_i = 0`` left
    out), floored at ``max(2 % of the value, 0.02)``. NaN with ``n = 0`` if no window is usable.

    Parameters
    ----------
    signals : mapping of str to array_like
        Sensor name (``x1``, ``x5``, ...) to its acceleration, g, all of one length and rate.
    rate_hz : float
        Sampling rate, Hz.
    f_exc_hz : float, optional
        Excitation frequency, Hz; adds ``<sensor>_impacts_per_cycle``.
    clipped : mapping of str to array_like of bool, optional
        Clipped-sample masks of some or all sensors.
    window_s, bands
        As :func:`sensor_features`.

    Returns
    -------
    dict of str to Feature

    Raises
    ------
    ValueError
        As :func:`sensor_features`, naming ``signals[<sensor>]`` or ``clipped[<sensor>]``; also
        for no signals, a non-string sensor name, signals of different lengths or a mask for a
        sensor without a signal.
    """
    if not isinstance(signals, Mapping) or not signals:
        raise ValueError(f"signals must be a non-empty mapping of sensor to array, got {signals!r}")
    clipped = {} if clipped is None else clipped
    if not isinstance(clipped, Mapping):
        raise ValueError(f"clipped must be a mapping of sensor to mask, got {clipped!r}")
    for name in signals:
        if not isinstance(name, str) or not name:
            raise ValueError(f"signals: sensor names must be non-empty strings, got {name!r}")
    extra = [k for k in clipped if k not in signals]
    if extra:
        raise ValueError(f"clipped[{extra[0]!r}] has no signal in signals ({list(signals)})")
    sizes = {name: np.size(sig) for name, sig in signals.items()}
    if len(set(sizes.values())) > 1:
        raise ValueError(f"signals must all have the same length, got {sizes}")

    results: dict[str, _SensorResult] = {}
    for name, sig in signals.items():
        results[name] = _sensor(
            name,
            sig,
            rate_hz,
            f_exc_hz,
            window_s,
            bands,
            clipped.get(name),
            arg=f"signals[{name!r}]",
            clipped_arg=f"clipped[{name!r}]",
        )
    return _joined(results)


def _joined(results: Mapping[str, _SensorResult]) -> dict[str, Feature]:
    """Every sensor's features under ``<sensor>_``, plus the x5/x1 peak ratio."""
    out: dict[str, Feature] = {}
    for name, res in results.items():
        out.update({f"{name}_{key}": f for key, f in res.features.items()})
    if "x1" in results and "x5" in results:
        r1, r5 = results["x1"], results["x5"]
        both = r1.usable & r5.usable
        p1, p5 = r1.peaks[both], r5.peaks[both]
        if p1.size == 0 or np.mean(p1) == 0.0:
            out["x5_x1_peak_ratio"] = _NAN_FEATURE
        else:
            value = float(np.mean(p5) / np.mean(p1))
            ratios = p5[p1 > 0.0] / p1[p1 > 0.0]
            f = _feature("x5_x1_peak_ratio", value, ratios)
            out["x5_x1_peak_ratio"] = Feature(f.value, f.spread, int(p1.size))
    return out


def phase_features(
    signals: Mapping[str, Sequence[np.ndarray]],
    rate_hz: float,
    f_exc_hz: float | None = None,
    clipped: Mapping[str, Sequence[np.ndarray]] | None = None,
) -> list[dict[str, Feature]]:
    """:func:`event_features` of several records of one event at once: item ``k`` of every
    sensor's sequence is one record (e.g. one sampling phase of a model run), and item ``k``
    of the result is that record's :func:`event_features` (default windows and bands), the
    same to the bit.

    Why: a measurement samples each run at several phases; taken together, the window
    reductions and the spectra of all phases cost one call each instead of one per phase.
    Records may differ in length (sampling phases of one window differ by a sample at its
    end); those with the same full windows go together.

    Parameters
    ----------
    signals : mapping of str to sequence of numpy.ndarray
        Each sensor's records, g, 1-D and finite (as the sensor chain returns them); the
        sensors' k-th records of one length.
    rate_hz : float
        Sampling rate, Hz.
    f_exc_hz : float, optional
        Excitation frequency, Hz.
    clipped : mapping of str to sequence of numpy.ndarray of bool, optional
        Clipped-sample masks, as ``signals``.

    Returns
    -------
    list of dict of str to Feature
        One per record.

    Raises
    ------
    ValueError
        For sensors with different numbers of records, a k-th record of different lengths
        across sensors, a record that is not 1-D or holds non-finite values (naming the sensor
        and record), or a mask of another length; otherwise as :func:`event_features`.
    """
    if not isinstance(signals, Mapping) or not signals:
        raise ValueError(f"signals must be a non-empty mapping of sensor to records, "
                         f"got {signals!r}")
    masks = {} if clipped is None else clipped
    names = list(signals)
    counts = {name: len(signals[name]) for name in names}
    if len(set(counts.values())) > 1:
        raise ValueError(f"signals: every sensor needs the same number of records, got {counts}")
    records = counts[names[0]]
    arrays: dict[str, list[np.ndarray]] = {}
    clips: dict[str, list[np.ndarray]] = {}
    for name in names:
        arrays[name] = [finite_1d(f"signals[{name!r}][{k}]", a) for k, a in
                        enumerate(signals[name])]
        clips[name] = [_check_clipped(f"clipped[{name!r}][{k}]", masks[name][k] if name in
                                      masks else None, arrays[name][k].size)
                       for k in range(records)]
    sizes = [arrays[names[0]][k].size for k in range(records)]
    for name in names:
        for k in range(records):
            if arrays[name][k].size != sizes[k]:
                raise ValueError(f"signals[{name!r}][{k}] has {arrays[name][k].size} samples, "
                                 f"signals[{names[0]!r}][{k}] {sizes[k]}")
    rate_hz = finite_positive("rate_hz", rate_hz)
    if f_exc_hz is not None:
        f_exc_hz = finite_positive("f_exc_hz", f_exc_hz)
    band_list = band_edges_for(rate_hz, None)
    groups: dict[tuple[int, ...], list[int]] = {}
    for k in range(records):
        bounds = _bounds(f"signals[...][{k}]", sizes[k], rate_hz, PEAK_WINDOW_S)
        groups.setdefault(tuple(bounds.tolist()), []).append(k)
    out: list[dict[str, Feature]] = [{} for _ in range(records)]
    for edges, members in groups.items():
        bounds = np.asarray(edges, dtype=np.intp)
        width = max(sizes[k] for k in members)
        per_sensor = {}
        for name in names:
            a = np.zeros((len(members), width))
            c = np.zeros((len(members), width), dtype=bool)
            for row, k in enumerate(members):
                a[row, : sizes[k]] = arrays[name][k]
                c[row, : sizes[k]] = clips[name][k]
            per_sensor[name] = _sensor_rows(name, a, rate_hz, f_exc_hz, bounds, band_list, c,
                                            [sizes[k] for k in members])
        for row, k in enumerate(members):
            out[k] = _joined({name: per_sensor[name][row] for name in names})
    return out
