"""The excitation line of a record: the frequency at which the tool was actually driven.

Why this module exists: the excitation frequency is set by the flow (``f = alpha Q / 2
pi``), and every comparison runs the model at the *stated* flow. The folded evidence refines
the frequency on the record (+-0.2 %) and folds the record at its own, so a record driven a
few per cent faster than its stated flow still folds into a clean waveform, and the
calibrated WOB and phase at rest absorb what differs: the mismatch disappears from the
residuals. The record says its operating point directly, though. :func:`excitation_line`
finds the strongest spectral line within +-:data:`EXCITATION_SPAN` of the stated frequency
(a Hann window, zero-padded, the peak refined by a Gaussian through its neighbours), then
the frequency whose fold explains most within +-:data:`FOLD_SPAN` of it
(:func:`vadsim.signals.folding.fold`). Why both: at 1024 Hz the impact ringing's harmonics
near 1 kHz alias next to the fundamental (at 200 gal/min the 47th harmonic of 21.33 Hz lands
at 21.64 Hz), and the spectral peak alone was off by up to 0.34 % on the model's own 3 s
records; the fold uses every harmonic at once. A limit: a sampled record is periodic at an
aliased harmonic too, and where that line outgrows the fundamental within the search (a 1010
Hz ring at 30 Hz: 33 x 30 Hz aliases to 34 Hz) the line read is the alias; choosing among
several lines by their folds' explained variance picked aliases on the model's own records
(+10.9 % at 300 and 600 gal/min), so the strongest line is kept. On the blind benchmark's
425 recorded events, all written at their stated flows, the 278 records that repeat read
within 0.03 % of them (vadsim's and the independent generator's alike). The spread is the
standard deviation of the same fold frequency over the record's blocks of
:data:`vadsim.signals.folding.BLOCK_S` (the record's own variability on a fixed time scale,
as every spread here): small for a record that repeats, large for one that does not. Its
accuracy on a record of ``N`` samples is about ``2 / N`` relative: where the sampling is
nearly commensurate with the excitation (48.015 samples a cycle at 21.327 Hz) the fold can
settle next to the commensurate frequency (1024 / 48 = 21.333 Hz), within about a sample's
drift over the record. A diagnosis compares the line with the stated flow's frequency
(:mod:`vadsim.fit.diagnosis.operating_point`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vadsim._checks import finite_1d, finite_positive
from vadsim.signals.folding import BLOCK_S, PERIODIC_THRESHOLD, fold

__all__ = ["EXCITATION_SPAN", "FOLD_SPAN", "ExcitationLine", "excitation_line"]

EXCITATION_SPAN = 0.15
"""Half-width of the search around the stated frequency, relative: wide enough for a flow
reading 10 % off, narrow enough to leave out the subharmonic of a period-2 response and the
second harmonic."""

FOLD_SPAN = 0.025
"""Half-width of the fold's frequency scan around the spectral line, relative: more than the
spectral peak's error (1.0 % on a 3 s impact train at 21.33 Hz, an aliased harmonic 0.3 Hz
away)."""

_PAD = 8  # zero padding: the peak bin within an eighth of a record's bin before refining


class ExcitationLine(NamedTuple):
    """The excitation line of one record: ``hz`` from the whole record, ``spread_hz`` the
    standard deviation of the blocks' own (NaN with fewer than two blocks, or where the
    record does not repeat), ``blocks``, and whether the record repeats at ``hz`` (``periodic``:
    its fold explains at least :data:`vadsim.signals.folding.PERIODIC_THRESHOLD` of its
    variance): a record that does not repeat has no sharp line, and its ``hz`` says little
    about the flow."""

    hz: float
    spread_hz: float
    blocks: int
    periodic: bool


def _line(a: np.ndarray, rate_hz: float, f_hz: float, span: float) -> float:
    """The strongest spectral line within ``f_hz (1 +- span)`` (its strongest peak inside
    the search, else the largest bin), refined by a Gaussian through its neighbours; NaN
    where the search holds fewer than three bins."""
    n = a.size
    spectrum = np.abs(np.fft.rfft((a - a.mean()) * np.hanning(n), _PAD * n))
    freqs = np.fft.rfftfreq(_PAD * n, 1.0 / rate_hz)
    inside = np.flatnonzero((freqs >= f_hz * (1 - span)) & (freqs <= f_hz * (1 + span)))
    if inside.size < 3:
        return math.nan
    s = spectrum[inside]
    peaks = [i for i in range(1, s.size - 1) if s[i] >= s[i - 1] and s[i] > s[i + 1]]
    i = max(peaks, key=lambda j: s[j]) if peaks else int(np.argmax(s))
    k = int(inside[i])
    if i in (0, s.size - 1) or spectrum[k] <= 0:
        return float(freqs[k])  # at an end of the search: no neighbours
    lm, l0, lp = np.log(np.maximum(spectrum[k - 1:k + 2], 1e-300))
    curvature = lm - 2 * l0 + lp
    delta = 0.5 * (lm - lp) / curvature if curvature < 0 else 0.0
    return float(freqs[k] + delta * (freqs[1] - freqs[0]))


def excitation_line(a_g: npt.ArrayLike, rate_hz: float, f_hz: float, *,
                    span: float = EXCITATION_SPAN, block_s: float = BLOCK_S) -> ExcitationLine:
    """The strongest spectral line within ``f_hz (1 +- span)`` of a record.

    Parameters
    ----------
    a_g
        One sensor's samples, g (a record's reference sensor).
    rate_hz
        Its sampling rate.
    f_hz
        The stated flow's excitation frequency, Hz (the search's centre).
    span
        Relative half-width of the search (default :data:`EXCITATION_SPAN`).
    block_s
        Block length for the spread, s.

    Returns
    -------
    ExcitationLine
        The line's frequency (NaN where the spectral search holds fewer than three bins: a
        record too short to resolve it), the blocks' spread, how many blocks, and whether
        the record repeats (else no spread).
    """
    a = finite_1d("a_g", a_g)
    rate_hz = finite_positive("rate_hz", rate_hz)
    f_hz = finite_positive("f_hz", f_hz)
    if not 0 < span < 0.5:
        raise ValueError(f"span = {span!r} must lie in (0, 0.5)")
    line = _line(a, rate_hz, f_hz, span)
    if not math.isfinite(line):
        return ExcitationLine(math.nan, math.nan, 0, False)
    # period 2: the scan's own default, right for responses of period 1 and 2
    whole = fold(a, rate_hz, line, period=2, refine=FOLD_SPAN, block_s=block_s)
    hz = whole.f_hz
    # the fold's explained variance, not its periodic flag: sampling nearly commensurate with
    # the excitation mixes a fold's bins poorly, and the line is still read to 2 / N
    if not whole.explained >= PERIODIC_THRESHOLD:
        return ExcitationLine(hz, math.nan, 0, False)
    per_block = int(round(finite_positive("block_s", block_s) * rate_hz))
    blocks = a.size // per_block if per_block > 0 else 0
    own = [fold(a[b * per_block:(b + 1) * per_block], rate_hz, hz, period=2,
                refine=FOLD_SPAN, block_s=block_s).f_hz for b in range(blocks)]
    spread = float(np.std(own, ddof=1)) if len(own) >= 2 else math.nan
    return ExcitationLine(hz, spread, len(own), True)
