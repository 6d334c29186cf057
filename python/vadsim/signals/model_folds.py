"""The model side of the folded evidence: every folded and distribution feature of a simulated
event.

Why this module exists: a recording decides which kind of evidence it gives, folded features
or distributions; a simulation gives *every* kind, so that the model side never needs to know
what the recording decided (:mod:`vadsim.signals.fold_features`, "Which kind of evidence").
Its folds are read by :mod:`vadsim.signals.fold_waveform` exactly as a recording's are; they
are computed for speed as one fold of bins 8 times finer, aligned by whole bins of it
(:func:`model_fold_features`), and its quantiles hold the recordings' noise
(:func:`noisy_quantiles`). Its features have NaN spreads: the recording's spread standardises
the residual.

Alternative alignments
----------------------
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
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping

import numpy as np
import numpy.typing as npt

from vadsim._checks import finite_1d
from vadsim.signals.features import Feature
from vadsim.signals.fold_features import QUANTILES, fold_tag, reference_sensor
from vadsim.signals.fold_waveform import COARSE_BINS, FoldShape, sensor_values, spike_position
from vadsim.signals.folding import FOLD_BINS, MAX_PERIOD, fold_sums

__all__ = [
    "ALT_MARK",
    "ALT_SPIKE_FRACTION",
    "QUANTILE_NOISE_SEED",
    "model_fold_features",
    "noisy_quantiles",
]

_SUPER = 8
"""Super-fine bins per fine bin of a simulation's fold: the resolution of its alignment."""

ALT_SPIKE_FRACTION: float = 0.6
"""In a simulated fold of period n > 1, every cycle whose largest spike reaches this fraction
of the period's largest gives an alternative alignment (module docstring, "Alternative
alignments")."""

ALT_MARK = "@cycle"
"""Key suffix of a simulated feature under an alternative alignment: ``<key>@cycle<c>``."""


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
    """Fine-bin means of a super-fine fold, aligned as
    :func:`vadsim.signals.fold_waveform.spike_origin` aligns a recording: the reference's spike
    (located on its fine-bin means ``probe``, :func:`_fine_probe`; the largest, or the one at
    fine bin ``at``) moved to the centre of fine bin ``per // 2`` by a whole number of
    super-fine bins (within 1/16 of a fine bin)."""
    spike = spike_position(probe, at)
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
    """The quantiles (:data:`vadsim.signals.fold_features.QUANTILES`) of ``|a + noise|``,
    clipped at ``range_g``: what a recording of ``a`` with that sensor noise shows.

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
    quantiles: bool = True,
) -> dict[str, Feature]:
    """Every kind of folded and distribution feature of a simulated event (module docstring).

    Why so many parameters: the model's folds are measured under every condition of the
    recording they are compared with (rate, low-pass, range, noise, phases, periods); the
    comparison engine passes each from the campaign.

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
        As :func:`vadsim.signals.fold_features.recorded_fold_features`.
    noise_g : mapping of str to float, optional
        Each sensor's noise standard deviation, g, as its recordings carry it: added to the
        signal (then clipped at ``range_g``) for the quantiles only (:func:`noisy_quantiles`);
        a fold's mean averages noise out.
    range_g : mapping of str to float, optional
        Each sensor's range, g, for that clipping.
    quantiles : bool, optional
        Give the distribution features; False skips them (a comparison with a recording
        that folded compares none, and their selection over every fine sample was a seventh
        of a diagnosis' measurement).

    Returns
    -------
    dict of str to Feature
        Spreads NaN (a simulation's spread is not used); ``n`` = cycles folded for folds,
        samples for distributions.
    """
    ref = reference_sensor(signals, reference)
    names = list(signals)
    t_arr = finite_1d("t", t)
    stacked = np.stack([finite_1d(f"signals[{k!r}]", signals[k]) for k in names])
    noise, rails = dict(noise_g or {}), dict(range_g or {})
    out = {f"{name}_q{q:g}_g": Feature(float(v), math.nan, t_arr.size)
           for i, (name, a) in enumerate(zip(names, stacked, strict=True)) if quantiles
           for q, v in zip(QUANTILES, noisy_quantiles(a, noise.get(name, 0.0),
                                                      rails.get(name), i), strict=True)}
    wanted = sorted(set(periods))
    cycles = max(1, round((t_arr[-1] - t_arr[0]) * f_hz))
    for base in [m for m in wanted if not any(o != m and o % m == 0 for o in wanted)]:
        count, sums = fold_sums(t_arr, stacked, f_hz, base, base * bins * _SUPER)
        for n in (m for m in wanted if base % m == 0):
            c = count.reshape(base // n, -1).sum(axis=0)
            s = sums.reshape(len(names), base // n, -1).sum(axis=1)
            folds = {k: FoldShape(n, f_hz) for k in names}
            probe = _fine_probe(c, s, names.index(ref))
            for alt, at in [(None, None), *_alternative_spikes(probe, n).items()]:
                means = _aligned_means(c, s, probe, bins, coarse, at)
                vals = sensor_values(folds, ref, dict(zip(names, means, strict=True)), coarse,
                                      alternative=alt is not None)
                mark = "" if alt is None else f"{ALT_MARK}{alt}"
                out.update({f"{k}_{fold_tag(n)}_{x}{mark}": Feature(y, math.nan, cycles)
                            for k, v in vals.items() for x, y in v.items()
                            if not x.startswith("_")})
    return out
