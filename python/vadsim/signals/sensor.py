"""The accelerometer chain of RECORDINGS.md, applied to a simulated acceleration.

Why this module exists: a simulated acceleration on the integrator's fine grid holds impact
spikes a few samples wide that a 1024 Hz field sensor never sees (MODEL.md: 65 g at full
resolution, 45 g through the sensor at 200 gal/min). Simulation and recording are comparable
only after the simulated signal has gone through the same chain as the field signal:

1. the sensor's optional anti-alias low-pass, a 4th-order Butterworth applied *causally*
   (``scipy.signal.sosfilt``) like the analog filter in front of a real converter -- a
   zero-phase ``sosfiltfilt`` would move energy ahead of the impacts, which no sensor does;
2. sampling at ``rate_hz`` with a chosen phase, by linear interpolation of the fine grid;
3. optional Gaussian noise;
4. clipping at the sensor's range, with the clipped samples flagged (RECORDINGS.md: samples at
   +-range_g are never silently trusted).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy.signal import butter, sosfilt, sosfilt_zi

from vadsim._checks import finite_1d, finite_positive, number

__all__ = [
    "LOWPASS_ORDER",
    "FilteredSignal",
    "MIN_OVERSAMPLING",
    "SIMULATION_OVERSAMPLING",
    "analog_chain",
    "sample_count",
    "sensor_chain",
]

LOWPASS_ORDER: int = 4
"""Order of the Butterworth anti-alias low-pass."""

MIN_OVERSAMPLING: float = 4.0
"""Smallest accepted ratio of the fine-grid rate to the sensor rate.

Linear interpolation between fine samples is what stands in for the instantaneous sampling of
the converter; its error on a tone of frequency f is about ``(pi f dt)^2 / 2`` of the amplitude,
so the fine grid must be much faster than the sensor. Below 4x the interpolation itself would
low-pass the signal near the sensor's Nyquist frequency by more than the sensor does. Use 20x or
more (the reference solution is sampled at 20 kHz for a 1024 Hz sensor).
"""

SIMULATION_OVERSAMPLING: int = 20
"""Simulated signals are recorded at 20x the fastest sensor's rate before the chain samples
them (the chain needs at least :data:`MIN_OVERSAMPLING`; 20x keeps the interpolation error
of a 1 ms impact spike small)."""


_UNIFORM_RTOL: float = 1e-6
# As RECORDINGS.md for the recorded time column: steps equal to 1e-6 of the step.


def _fine_step(t: np.ndarray) -> float:
    if t.size < 2:
        raise ValueError(f"t needs at least 2 samples, got {t.size}")
    steps = np.diff(t)
    dt = (t[-1] - t[0]) / (t.size - 1)
    if dt <= 0.0 or np.any(steps <= 0.0):
        k = int(np.flatnonzero(steps <= 0.0)[0])
        raise ValueError(f"t must be strictly increasing; t[{k}]={t[k]!r}, t[{k + 1}]={t[k + 1]!r}")
    worst = int(np.argmax(np.abs(steps - dt)))
    if abs(steps[worst] - dt) > _UNIFORM_RTOL * dt:
        raise ValueError(
            f"t must be uniform (within {_UNIFORM_RTOL:g} of the step {dt!r}); "
            f"t[{worst + 1}] - t[{worst}] = {steps[worst]!r}"
        )
    return dt

MIN_LOWPASS_FRACTION = 1e-6
"""Lowest low-pass corner as a fraction of the fine grid's rate: a 4th-order Butterworth
filter much lower than that has no finite design in float64."""


def _lowpass(a: np.ndarray, fine_rate: float, lowpass_hz: float | None) -> np.ndarray:
    """The sensor's anti-alias filter on the fine grid (step 1 of the module docstring)."""
    if lowpass_hz is None:
        return a
    lowpass_hz = finite_positive("lowpass_hz", lowpass_hz)
    if lowpass_hz < MIN_LOWPASS_FRACTION * fine_rate:
        raise ValueError(
            f"lowpass_hz={lowpass_hz!r} is too low for the fine grid t ({fine_rate:.6g} Hz): "
            f"a filter below {MIN_LOWPASS_FRACTION:g} of its rate cannot be designed")
    if lowpass_hz >= 0.5 * fine_rate:
        raise ValueError(
            f"lowpass_hz={lowpass_hz!r} must be below the Nyquist frequency of the fine "
            f"grid t ({0.5 * fine_rate:.6g} Hz)"
        )
    sos = butter(LOWPASS_ORDER, lowpass_hz, btype="lowpass", fs=fine_rate, output="sos")
    out, _ = sosfilt(sos, a, zi=sosfilt_zi(sos) * a[0])
    return np.asarray(out, dtype=float)



def sample_count(t: np.ndarray, rate_hz: float, phase: float) -> int:
    """The number of samples a sensor at ``rate_hz`` takes at ``phase`` (of a sample period)
    over the fine grid ``t``: the first at ``t[0] + phase / rate_hz``, the last at or before
    ``t[-1]`` (up to rounding)."""
    return math.floor((t[-1] - t[0]) * rate_hz - phase + 1e-9) + 1


class FilteredSignal:
    """A fine-grid acceleration, checked and through the sensor's anti-alias low-pass once.

    Why: a measurement samples the same run at several sampling phases and folds it too
    (:func:`vadsim.compare.measure_event`); the checks of the grid and the low-pass over
    every fine sample are the same each time and were most of the chain's cost. Each method
    does what :func:`sensor_chain` and :func:`analog_chain` do after their first step, with
    the same operations, so the results are the same to the bit.

    Parameters
    ----------
    t, a_g, lowpass_hz
        As :func:`sensor_chain`.

    Raises
    ------
    ValueError
        As :func:`sensor_chain` for ``t``, ``a_g`` and ``lowpass_hz``.
    """

    def __init__(self, t: npt.ArrayLike, a_g: npt.ArrayLike,
                 lowpass_hz: float | None = None) -> None:
        t_arr = finite_1d("t", t)
        a = finite_1d("a_g", a_g)
        if a.shape != t_arr.shape:
            raise ValueError(f"a_g must have the length of t ({t_arr.size}), got {a.size}")
        self.t: np.ndarray = t_arr
        self.fine_rate_hz: float = 1.0 / _fine_step(t_arr)
        self.a: np.ndarray = _lowpass(a, self.fine_rate_hz, lowpass_hz)

    def analog(self, range_g: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The filtered signal clipped at ``range_g``, and the clipped mask: what
        :func:`analog_chain` returns."""
        if range_g is None:
            return self.a, np.zeros(self.a.size, dtype=bool)
        range_g = finite_positive("range_g", range_g)
        clipped = np.abs(self.a) >= range_g
        return np.clip(self.a, -range_g, range_g), clipped

    def sample(self, rate_hz: float = 1024.0, range_g: float = 250.0, phase: float = 0.0,
               noise_g: float = 0.0, rng: np.random.Generator | int | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steps 2-4 of the chain (sampling, noise, clipping): what :func:`sensor_chain`
        returns for these arguments."""
        rate_hz, range_g = self._checked_rates(rate_hz, range_g)
        phase = self._checked_phase(phase)
        noise_g = number("noise_g", noise_g)
        if not math.isfinite(noise_g) or noise_g < 0.0:
            raise ValueError(f"noise_g must be a finite number >= 0, got {noise_g!r}")
        t_s = self.sample_times(rate_hz, phase)
        # The last sample time may exceed t[-1] by rounding only; np.interp holds the end value.
        a_s = np.interp(t_s, self.t, self.a)
        if noise_g > 0.0:
            a_s = a_s + np.random.default_rng(rng).normal(0.0, noise_g, size=a_s.size)
        clipped = np.abs(a_s) >= range_g
        a_s = np.clip(a_s, -range_g, range_g)
        return t_s, a_s, clipped

    def sample_times(self, rate_hz: float, phase: float) -> np.ndarray:
        """The times (s) :meth:`sample` takes its samples at (arguments checked there)."""
        n_samples = sample_count(self.t, rate_hz, phase)
        return np.asarray(self.t[0] + (np.arange(n_samples) + phase) / rate_hz)

    def sample_phases(self, rate_hz: float, range_g: float, phases: Sequence[float],
                      noise: Sequence[np.ndarray | None]
                      ) -> list[tuple[np.ndarray, np.ndarray]]:
        """:meth:`sample` at each of ``phases``, each with its own noise draw (``noise``: the
        standard-normal draws already scaled, one per phase, the size of
        :meth:`sample_times`; None for none): the samples and the clipped mask, the same to
        the bit as one :meth:`sample` per phase with those draws. One interpolation serves
        every phase: a measurement samples each run at eight."""
        rate_hz, range_g = self._checked_rates(rate_hz, range_g)
        times = [self.sample_times(rate_hz, self._checked_phase(p)) for p in phases]
        if len(noise) != len(times):
            raise ValueError(f"noise holds {len(noise)} draws for {len(times)} phases")
        values = np.interp(np.concatenate(times), self.t, self.a)
        out: list[tuple[np.ndarray, np.ndarray]] = []
        start = 0
        for t_s, draw in zip(times, noise, strict=True):
            a_s = values[start:start + t_s.size]
            start += t_s.size
            if draw is not None:
                if draw.shape != t_s.shape:
                    raise ValueError(f"a noise draw of shape {draw.shape} for {t_s.size} "
                                     "samples")
                a_s = a_s + draw
            clipped = np.abs(a_s) >= range_g
            out.append((np.clip(a_s, -range_g, range_g), clipped))
        return out

    def _checked_rates(self, rate_hz: float, range_g: float) -> tuple[float, float]:
        rate_hz = finite_positive("rate_hz", rate_hz)
        range_g = finite_positive("range_g", range_g)
        if self.fine_rate_hz < MIN_OVERSAMPLING * rate_hz:
            raise ValueError(
                f"rate_hz={rate_hz!r} is too fast for the fine grid t "
                f"({self.fine_rate_hz:.6g} Hz); the grid must be at least "
                f"{MIN_OVERSAMPLING:g} times faster than the sensor"
            )
        return rate_hz, range_g

    @staticmethod
    def _checked_phase(phase: float) -> float:
        phase = number("phase", phase)
        if not 0.0 <= phase < 1.0:
            raise ValueError(f"phase must be in [0, 1) of a sample period, got {phase!r}")
        return phase


def analog_chain(
    t: npt.ArrayLike,
    a_g: npt.ArrayLike,
    lowpass_hz: float | None = None,
    range_g: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The analog part of the sensor chain on the fine grid itself: low-pass, then clipping.

    Why: equivalent-time sampling (:mod:`vadsim.signals.folding`) recovers the waveform a
    sensor *sees* at every phase of the cycle, i.e. the signal after the sensor's anti-alias
    filter and range but before the sampling; a simulated signal is compared with it after
    exactly these two steps of :func:`sensor_chain` (the same filter, run the same causal
    way, and the same rails), without the sampling at ``rate_hz`` and without noise.
    Clipping is pointwise, so clipping the fine grid is what clipping the samples taken from
    it would give.

    Parameters
    ----------
    t : array_like, shape (n,)
        Uniform, strictly increasing fine-grid times, s.
    a_g : array_like, shape (n,)
        Acceleration on that grid, g.
    lowpass_hz : float or None, optional
        The sensor's anti-alias corner, Hz, as in :func:`sensor_chain`; None for no filter.
    range_g : float or None, optional
        The sensor's range, g; None for no clipping.

    Returns
    -------
    a_s : numpy.ndarray
        The filtered, clipped acceleration on the fine grid, g.
    clipped_mask : numpy.ndarray of bool
        True where ``|a_s| == range_g`` (all False without a range).

    Raises
    ------
    ValueError
        As :func:`sensor_chain` for ``t``, ``a_g``, ``lowpass_hz`` and ``range_g``.
    """
    return FilteredSignal(t, a_g, lowpass_hz).analog(range_g)


def sensor_chain(
    t: npt.ArrayLike,
    a_g: npt.ArrayLike,
    rate_hz: float = 1024.0,
    range_g: float = 250.0,
    lowpass_hz: float | None = None,
    phase: float = 0.0,
    noise_g: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pass a finely sampled acceleration through the sensor chain of RECORDINGS.md.

    Parameters
    ----------
    t : array_like, shape (n,)
        Uniform, strictly increasing fine-grid times, s (uniform to 1e-6 of the step). The grid
        rate ``1 / dt`` must be at least :data:`MIN_OVERSAMPLING` times ``rate_hz``.
    a_g : array_like, shape (n,)
        Acceleration on that grid, g.
    rate_hz : float, optional
        Sensor sampling rate, Hz; default 1024.
    range_g : float, optional
        Sensor range: the output saturates at +-range_g; default 250.
    lowpass_hz : float or None, optional
        Corner (-3 dB) of the sensor's anti-alias filter, Hz, below the fine grid's Nyquist
        frequency; None (default) for no filter. The filter is a 4th-order digital Butterworth
        on the fine grid (bilinear transform with the corner pre-warped, so it matches the analog
        filter closely when the grid is fast) run causally with ``sosfilt``: the output lags the
        input by the filter's group delay, as a real sensor's does. It starts in the steady
        state of a constant input equal to ``a_g[0]``, as a sensor that was already running;
        what is left of the start-up transient dies out within a few periods of the corner, so
        hand over a grid that starts a few excitation cycles before the window you analyse.
    phase : float, optional
        Sampling phase in [0, 1) of a sensor period: the first sample is taken at
        ``t[0] + phase / rate_hz`` (recordings start at any phase; sweeping it shows how much a
        feature depends on where the samples fall on the impact spikes). Default 0.
    noise_g : float, optional
        Standard deviation of white Gaussian noise added to each sample before clipping, g;
        default 0 (no noise, and ``rng`` is not used).
    rng : numpy.random.Generator or int or None, optional
        Noise generator or seed (``numpy.random.default_rng(rng)``); None for fresh entropy.

    Returns
    -------
    t_s : numpy.ndarray
        Sample times ``t[0] + (k + phase) / rate_hz`` for every k that falls within
        ``[t[0], t[-1]]``, s.
    a_s : numpy.ndarray
        Sensor output, g, within ``[-range_g, range_g]``.
    clipped_mask : numpy.ndarray of bool
        True where the output sits at a rail (``|a_s| == range_g``): the value there is only a
        bound. A sample exactly at the range is flagged too, since it cannot be told from a
        clipped one.

    Raises
    ------
    ValueError
        With the offending argument's name and value: ``t`` not 1-D, shorter than 2, not
        strictly increasing, not uniform, or too coarse for ``rate_hz``; ``a_g`` of a different
        length; NaN or infinity in ``t`` or ``a_g``; ``rate_hz``, ``range_g`` or ``lowpass_hz``
        not > 0; ``lowpass_hz`` at or above the fine grid's Nyquist frequency; ``phase``
        outside [0, 1); ``noise_g`` < 0.
    """
    return FilteredSignal(t, a_g, lowpass_hz).sample(rate_hz, range_g, phase, noise_g, rng)
