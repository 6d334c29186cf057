"""Frequency bands of the amplitude spectrum: their edges, their feature keys and the RMS of a
signal in each band, window by window.

Why this module exists: besides the window peaks and the impact rate, a record is compared by
its amplitude spectrum in a few frequency bands (keys ``<sensor>_band_<lo>_<hi>_g`` of
:func:`vadsim.signals.window_features.sensor_features`). The bands are laid out for the
1024 Hz field sensors (:data:`DEFAULT_BANDS`) and adapted to any other sampling rate up to its
Nyquist rate (:func:`band_edges_for`), so that a recording and a full-resolution simulation
share the bands they both have. :func:`band_rms` measures the RMS in each band of each 200 ms
window, scaled so that a sine of amplitude A inside a band gives A / sqrt(2) whether or not it
falls on a frequency bin; the feature is the mean over the windows, its spread their standard
deviation.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
from scipy.signal import get_window

from vadsim._checks import finite_positive, number

__all__ = [
    "DEFAULT_BANDS",
    "DEFAULT_BANDS_RATE_HZ",
    "band_edges_for",
    "band_key",
    "band_rms",
]

DEFAULT_BANDS_RATE_HZ: float = 1024.0
"""Sensor rate the :data:`DEFAULT_BANDS` are laid out for, Hz (RECORDINGS.md)."""

DEFAULT_BANDS: tuple[tuple[float, float], ...] = (
    (0.0, 50.0),
    (50.0, 100.0),
    (100.0, 200.0),
    (200.0, 350.0),
    (350.0, 512.0),
)
"""Frequency bands, Hz, of the amplitude spectrum for a 1024 Hz sensor (Nyquist 512 Hz).

The first two bands separate the excitation (21-69 Hz for both tools) from its first
harmonics; the wider bands above hold the impact ringing, up to the 400 Hz anti-alias corner of
the field sensors and the Nyquist rate. :func:`band_edges_for` adapts them to other rates.
"""


def _fmt_edge(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}".replace(".", "p")


def band_key(lo: float, hi: float) -> str:
    """Feature key of the band ``[lo, hi)`` Hz: ``band_<lo>_<hi>_g`` (``.`` written ``p``)."""
    return f"band_{_fmt_edge(lo)}_{_fmt_edge(hi)}_g"


def _check_bands(bands: object) -> list[tuple[float, float]]:
    try:
        pairs = [tuple(b) for b in bands]  # type: ignore[attr-defined]
    except TypeError:
        raise ValueError(f"bands must be a sequence of (lo, hi) pairs, got {bands!r}") from None
    if not pairs:
        raise ValueError("bands must hold at least one (lo, hi) pair")
    out = []
    for i, pair in enumerate(pairs):
        if len(pair) != 2:
            raise ValueError(f"bands[{i}] must be a (lo, hi) pair, got {pair!r}")
        lo, hi = number(f"bands[{i}][0]", pair[0]), number(f"bands[{i}][1]", pair[1])
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo < 0.0 or hi <= lo:
            raise ValueError(f"bands[{i}] must satisfy 0 <= lo < hi (finite), got {pair!r}")
        out.append((lo, hi))
    return out


def band_edges_for(
    rate_hz: float, bands: Sequence[tuple[float, float]] | None = None
) -> tuple[tuple[float, float], ...]:
    """Frequency bands, Hz, usable for a signal sampled at ``rate_hz``.

    Bands that start at or above the Nyquist rate ``rate_hz / 2`` are dropped; a band that
    straddles it is cut at the Nyquist rate (so its key, :func:`band_key`, names the cut edge).
    With the default bands and a rate above 1024 Hz, one more band from 512 Hz to the Nyquist
    rate is appended, so that the bands always cover the spectrum up to the Nyquist rate (a
    full-resolution simulation then has a band a 1024 Hz recording lacks; residuals simply
    leave it out).

    Parameters
    ----------
    rate_hz : float
        Sampling rate, Hz.
    bands : sequence of (lo, hi), optional
        Bands to adapt, Hz; default :data:`DEFAULT_BANDS`.

    Returns
    -------
    tuple of (lo, hi)
        The usable bands, in the given order.

    Raises
    ------
    ValueError
        If ``rate_hz`` is not a finite number > 0, a band is not ``0 <= lo < hi``, or no band
        is left below the Nyquist rate.
    """
    rate_hz = finite_positive("rate_hz", rate_hz)
    nyquist = rate_hz / 2.0
    default = bands is None
    pairs = _check_bands(DEFAULT_BANDS if bands is None else bands)
    out = [(lo, min(hi, nyquist)) for lo, hi in pairs if lo < nyquist]
    top = max(hi for _, hi in pairs)
    if default and nyquist > top:
        out.append((top, nyquist))
    if not out:
        raise ValueError(f"bands: no band starts below the Nyquist rate {nyquist:g} Hz")
    return tuple(out)


def band_rms(
    a: np.ndarray, rate_hz: float, bounds: np.ndarray, bands: Sequence[tuple[float, float]]
) -> np.ndarray:
    """RMS (g) of each window in each band, shape (n_windows, n_bands).

    Per window: remove the Hann-weighted mean ``sum(w x) / sum(w)`` (an offset such as a
    sensor bias or gravity is no vibration; the plain mean would leave an offset of about
    A / (2 pi cycles) for a tone of A that is not a whole number of cycles, and the Hann window
    would turn it into a spurious 0-10 Hz line of about 1 % of A, whereas the weighted mean of
    such a tone is ~1e-4 of A); Hann window (periodic); one-sided periodogram with "density"
    scaling (``scipy.signal.periodogram``); band power = sum of the PSD over the bins in the
    band times the bin width ``rate / N``; RMS = sqrt(power). The density scaling divides by
    ``sum(w**2)`` (the window's equivalent noise bandwidth), so by Parseval a sine of amplitude
    A whose Hann main lobe (+-2 bins, i.e. +-10 Hz for 200 ms windows) lies inside a band gives
    power A^2/2 there, i.e. A / sqrt(2) RMS, whether or not it falls on a bin. Bins count in
    ``[lo, hi)``; a band ending at the Nyquist rate includes the Nyquist bin.

    Parameters
    ----------
    a : numpy.ndarray, shape (n,) or (records, n)
        Uniformly sampled acceleration, g, finite; each row of a 2-D array is a record of its
        own (the same windows and bands, one FFT for all).
    rate_hz : float
        Sampling rate, Hz.
    bounds : numpy.ndarray of int
        Window edges, samples (:func:`vadsim.signals.labels.window_bounds`): window ``i`` is
        ``a[bounds[i]:bounds[i + 1]]``.
    bands : sequence of (lo, hi)
        Frequency bands, Hz, already checked and below the Nyquist rate
        (:func:`band_edges_for`).

    Returns
    -------
    numpy.ndarray, shape (n_windows, n_bands) or (records, n_windows, n_bands)
        RMS of each window in each band, g.

    Raises
    ------
    ValueError
        If a band holds no frequency bin of a window.
    """
    lengths = np.diff(bounds)
    lead = a.shape[:-1]
    out = np.empty((*lead, lengths.size, len(bands)))
    for length in np.unique(lengths):
        rows = np.flatnonzero(lengths == length)
        n = int(length)
        if rows.size > 1 and np.all(np.diff(bounds[rows]) == n):  # back to back: a view
            start = int(bounds[rows[0]])
            segments = a[..., start : start + rows.size * n].reshape(*lead, rows.size, n)
        else:
            segments = np.stack([a[..., bounds[i] : bounds[i] + n] for i in rows], axis=-2)
        w, w_mean, scale, bins_of = _band_plan(n, float(rate_hz), tuple(bands))
        offset = segments @ w_mean
        # scipy.signal.periodogram's one-sided density, without its per-call overhead
        # (it was a tenth of a diagnosis' feature time)
        spec = np.fft.rfft((segments - offset[..., np.newaxis]) * w, axis=-1)
        psd = (spec.real ** 2 + spec.imag ** 2) * scale
        out[..., rows, :] = np.sqrt(psd @ bins_of)
    return out


@functools.lru_cache(maxsize=64)
def _band_plan(length: int, rate_hz: float, bands: tuple[tuple[float, float], ...]
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What :func:`band_rms` needs for windows of ``length`` samples, made once: the Hann
    window, its weights for the weighted mean, each bin's density scale (one-sided, times
    the bin width) and the bins-by-bands matrix whose product with a periodogram sums each
    band. ValueError for a band that holds no bin."""
    nyquist = rate_hz / 2.0
    w = get_window("hann", length)
    scale = np.full(length // 2 + 1, 1.0 / (rate_hz * np.sum(w * w)))
    scale[1 : scale.size - (1 if length % 2 == 0 else 0)] *= 2.0
    scale *= rate_hz / length
    freqs = np.fft.rfftfreq(length, 1.0 / rate_hz)
    bins_of = np.zeros((freqs.size, len(bands)))
    for j, (lo, hi) in enumerate(bands):
        mask = (freqs >= lo) & ((freqs < hi) | ((hi >= nyquist) & (freqs <= hi)))
        if not np.any(mask):
            raise ValueError(
                f"bands: band ({lo:g}, {hi:g}) Hz holds no frequency bin of a "
                f"{length}-sample window (bin width {rate_hz / length:.3g} Hz); widen it or "
                "the window"
            )
        bins_of[mask, j] = 1.0
    for arr in (w, scale, bins_of):
        arr.flags.writeable = False
    return w, w / np.sum(w), scale, bins_of
