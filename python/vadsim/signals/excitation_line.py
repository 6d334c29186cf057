"""The excitation line of a record: the frequency at which the tool was actually driven.

Why this module exists: the excitation frequency is set by the flow (``f = alpha Q / 2 pi``),
and every comparison runs the model at the *stated* flow. The folded evidence refines the
frequency on the record (+-0.2 %) and folds the record at its own, so a record driven a few
per cent faster than its stated flow still folds into a clean waveform, and the calibrated
WOB and phase at rest absorb what differs: the mismatch disappears from the residuals. The
record says its operating point directly, though. :func:`excitation_line` finds the
strongest spectral line within +-:data:`EXCITATION_SPAN` of the stated frequency (a Hann
window, zero-padded, the peak refined by a Gaussian through its neighbours), then the
frequency whose fold explains most within +-:data:`FOLD_SPAN` of that line
(:func:`vadsim.signals.folding.fold`). Why both: at 1024 Hz the impact ringing's harmonics
near 1 kHz alias next to the fundamental (at 200 gal/min the 47th harmonic of 21.33 Hz lands
at 21.64 Hz), and the spectral peak alone was off by up to 0.34 % on the model's own 3 s
records; the fold uses every harmonic at once. The spread is the standard deviation of the
same fold frequency over the record's blocks of :data:`vadsim.signals.folding.BLOCK_S` (the
record's own variability on a fixed time scale, as every spread here): small for a record
that repeats, large for one that does not. Its accuracy on a record of ``N`` samples is about
``2 / N`` relative: where the sampling is nearly commensurate with the excitation (48.015
samples a cycle at 21.327 Hz) the fold can settle next to the commensurate frequency (1024 /
48 = 21.333 Hz), within about a sample's drift over the record. A diagnosis compares the
line with the stated flow's frequency (:mod:`vadsim.fit.diagnosis.operating_point`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vadsim._checks import finite_1d, finite_positive
from vadsim.signals.folding import BLOCK_S, fold

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
    standard deviation of the blocks' own (NaN with fewer than two blocks), ``blocks``."""

    hz: float
    spread_hz: float
    blocks: int


def _line(a: np.ndarray, rate_hz: float, f_hz: float, span: float) -> float:
    n = a.size
    spectrum = np.abs(np.fft.rfft((a - a.mean()) * np.hanning(n), _PAD * n))
    freqs = np.fft.rfftfreq(_PAD * n, 1.0 / rate_hz)
    inside = np.flatnonzero((freqs >= f_hz * (1 - span)) & (freqs <= f_hz * (1 + span)))
    if inside.size < 3:
        return math.nan
    k = int(inside[np.argmax(spectrum[inside])])
    if k in (inside[0], inside[-1]) or spectrum[k] <= 0:
        return float(freqs[k])  # at an end of the search: no neighbours to refine with
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
        record too short to resolve it), the blocks' spread and how many blocks.
    """
    a = finite_1d("a_g", a_g)
    rate_hz = finite_positive("rate_hz", rate_hz)
    f_hz = finite_positive("f_hz", f_hz)
    if not 0 < span < 0.5:
        raise ValueError(f"span = {span!r} must lie in (0, 0.5)")
    line = _line(a, rate_hz, f_hz, span)
    if not math.isfinite(line):
        return ExcitationLine(math.nan, math.nan, 0)
    # period 2: the scan's own default, right for responses of period 1 and 2
    hz = fold(a, rate_hz, line, period=2, refine=FOLD_SPAN, block_s=block_s).f_hz
    per_block = int(round(finite_positive("block_s", block_s) * rate_hz))
    blocks = a.size // per_block if per_block > 0 else 0
    own = [fold(a[b * per_block:(b + 1) * per_block], rate_hz, hz, period=2,
                refine=FOLD_SPAN, block_s=block_s).f_hz for b in range(blocks)]
    spread = float(np.std(own, ddof=1)) if len(own) >= 2 else math.nan
    return ExcitationLine(hz, spread, len(own))
