"""Labels of a steady vibro-impact response, computed from plain arrays.

Why this module exists: the dissertation's results are stated as labels -- impacts per cycle Z,
the impact scenario of Table 4.2, the impulse per second J*, the 200 ms acceleration peaks, the
impact frequency and the periodicity of the motion. Their definitions (MODEL.md, "Outputs and
labels") leave thresholds open; this module fixes them once, documents each choice, and keeps
them independent of the integrator so that simulated and recorded signals are labelled by the
same code. Everything here takes numpy arrays and returns numbers or strings; nothing imports
the C++ core.

Conventions
-----------
* Z is a number of contact onsets divided by a number of excitation cycles (dissertation
  Eq. 4.1). A surface is *regular* when Z is within :data:`Z_EQ_TOL` of a positive integer,
  *none* when Z is within :data:`Z_EQ_TOL` of 0 and *intermittent* otherwise.
* Accelerations are in g, forces per unit reference mass (N/kg), times in s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy.integrate import trapezoid
from scipy.signal import find_peaks
from scipy.spatial import ConvexHull, QhullError

from vadsim._checks import finite_1d, finite_positive
from vadsim.model.regimes import (
    SCENARIO_NONE,
    SCENARIO_SPRING_ONLY,
    Z_EQ_TOL,
    regime_name,
    scenario,
    surface_state,
)

__all__ = [
    "IMPACT_HEIGHT_FRAC",
    "IMPACT_MIN_DISTANCE_S",
    "PEAK_WINDOW_S",
    "POINCARE_RTOL",
    "QP_ORDER_FRACTION",
    "SCENARIO_NONE",
    "SCENARIO_SPRING_ONLY",
    "Z_EQ_TOL",
    "impact_frequency",
    "impacts_per_cycle",
    "impulse_per_second",
    "onset_times",
    "peak_stats",
    "periodicity",
    "poincare_period",
    "regime_name",
    "scenario",
    "surface_state",
    "window_bounds",
    "window_peaks",
]




PEAK_WINDOW_S: float = 0.2
"""Length of the windows for the axial vibration peaks (dissertation section 3.2), s."""

IMPACT_HEIGHT_FRAC: float = 0.5
"""A "major" acceleration peak reaches at least this fraction of the median 200 ms window peak."""

IMPACT_MIN_DISTANCE_S: float = 0.005
"""Minimum time between two major peaks, s.

Noise and the ringing right after an impact make many local maxima of ``|a|`` within a few ms of
each spike; 5 ms merges them into one while still resolving 200 peaks/s, above twice the highest
excitation frequency of both tools (2 x 69.3 Hz = 139 Hz, 7.2 ms apart).
"""

POINCARE_RTOL: float = 1e-3
"""Relative tolerance for two Poincare points to be "the same" (see :func:`poincare_period`).

A converged periodic orbit of a fixed-step RK4 solution repeats to 1e-8 of its spread or better,
and sensitivity studies only resolve the labels to ~1e-3 anyway; genuinely distinct points of a
period-p orbit are separated by a sizable fraction of the spread. 1e-3 sits between the two.
"""

QP_ORDER_FRACTION: float = 0.9
"""Fraction of Poincare steps that must act as a rotation for "quasi-periodic" (see
:func:`periodicity`)."""

_SCALE_FLOOR: float = 1e-3
# A component that hardly moves on the section (e.g. every component of a period-1 orbit) has a
# spread made of integration error only; normalising by that spread would blow the error up to
# O(1). Flooring the scale at 1e-3 of the component's magnitude treats such a component as
# constant to rtol * 1e-3 = 1e-6 of its magnitude.

_QP_MIN_POINTS: int = 16
# Below this many points the rotation test cannot tell order from chance (with the +-2 rank
# window, a random sequence passes each step with probability >= 5/16).

_QP_MAX_LENGTH: float = 1.5
# A clean invariant circle gives 1.0 (1.02 for a peanut-shaped one), noise of 5 % of the spread
# about 1.25; a focus converging by 0.5 % per cycle already gives 3.

_QP_MAX_GAP: float = 0.15
# 16 points of an irrational rotation leave gaps of at most ~0.1 of the curve (three-gap
# theorem); an arc shorter than ~300 degrees has a closing chord above 0.15 of the polygon.

_QP_MAX_DRIFT: float = 0.1
# Two halves of >= 8 points of an irrational rotation have RMS radii within a few % (more for
# an eccentric curve and few points); a focus converging by 0.5 % per cycle differs by > 20 %
# between the halves of 100 points.





# --------------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------------








# --------------------------------------------------------------------------------------------
# Impacts per cycle and scenarios
# --------------------------------------------------------------------------------------------


def onset_times(t: npt.ArrayLike, indentation: npt.ArrayLike) -> np.ndarray:
    """Return the times at which a contact indentation crosses zero upwards (contact onsets).

    An impact is the onset of contact (MODEL.md): ``d[k-1] <= 0 < d[k]``. The crossing time is
    interpolated linearly between the two samples, so the onset count does not depend on the
    grid and the times are accurate to O(dt^2).

    Parameters
    ----------
    t : array_like, shape (n,)
        Strictly increasing sample times, s.
    indentation : array_like, shape (n,)
        Indentation d of one surface (positive in contact).

    Returns
    -------
    numpy.ndarray
        Onset times, increasing. A contact already open at ``t[0]`` is not an onset.

    Raises
    ------
    ValueError
        If the arrays differ in length, are not finite, or ``t`` is not strictly increasing.
    """
    t = finite_1d("t", t)
    d = finite_1d("indentation", indentation)
    if t.shape != d.shape:
        raise ValueError(f"t and indentation differ in length: {t.size} != {d.size}")
    if t.size > 1 and np.any(np.diff(t) <= 0.0):
        raise ValueError("t must be strictly increasing")
    k = np.flatnonzero((d[:-1] <= 0.0) & (d[1:] > 0.0))
    frac = -d[k] / (d[k + 1] - d[k])
    return t[k] + frac * (t[k + 1] - t[k])


def impacts_per_cycle(onset_times: npt.ArrayLike, t0: float, t1: float, f_exc_hz: float) -> float:
    """Impacts per excitation cycle Z (dissertation Eq. 4.1).

    Parameters
    ----------
    onset_times : array_like
        Contact onset times of one surface, s (any order).
    t0, t1 : float
        Analysed window ``[t0, t1)``, s.
    f_exc_hz : float
        Excitation frequency, Hz.

    Returns
    -------
    float
        Number of onsets in ``[t0, t1)`` divided by the number of cycles ``(t1 - t0) * f_exc_hz``.
        The half-open window makes consecutive windows count each onset once.

    Raises
    ------
    ValueError
        If ``t1 <= t0``, ``f_exc_hz <= 0`` or any value is not finite.
    """
    onsets = np.atleast_1d(np.asarray(onset_times, dtype=float))
    if onsets.ndim != 1:
        raise ValueError(f"onset_times must be one-dimensional, got shape {onsets.shape}")
    if not np.all(np.isfinite(onsets)):
        raise ValueError("onset_times has a non-finite value")
    t0, t1 = float(t0), float(t1)
    if not (math.isfinite(t0) and math.isfinite(t1)) or t1 <= t0:
        raise ValueError(f"need finite t0 < t1, got t0={t0!r}, t1={t1!r}")
    f = finite_positive("f_exc_hz", f_exc_hz)
    count = np.count_nonzero((onsets >= t0) & (onsets < t1))
    return count / ((t1 - t0) * f)








# --------------------------------------------------------------------------------------------
# Impulse and acceleration peaks
# --------------------------------------------------------------------------------------------


def impulse_per_second(t: npt.ArrayLike, force: npt.ArrayLike) -> tuple[float, float]:
    """Impulse per second J* of the impact-face force (dissertation Eq. 4.2), both forms.

    J* is the time average of F_I over the window ``[t[0], t[-1]]``, computed as the trapezoid
    integral divided by ``t[-1] - t[0]`` (exact for piecewise-linear forces, O(dt^2) otherwise;
    the grid need not be uniform). The plain mean keeps the negative Kelvin-Voigt force while the
    faces separate; the positive mean integrates ``max(F_I, 0)`` sampled on the same grid (the
    kink at a zero crossing costs O(dt^2) per contact). Pass a window spanning whole excitation
    cycles, as the analysed 200 cycles do, or the average depends on where the window cuts.

    Parameters
    ----------
    t : array_like, shape (n,)
        Strictly increasing times, s; n >= 2.
    force : array_like, shape (n,)
        Impact-face force F_I, N/kg (multiply the result by m* for N).

    Returns
    -------
    mean : float
        Time average of F_I.
    mean_positive : float
        Time average of max(F_I, 0).
    """
    t = finite_1d("t", t)
    f = finite_1d("force", force)
    if t.shape != f.shape:
        raise ValueError(f"t and force differ in length: {t.size} != {f.size}")
    if t.size < 2:
        raise ValueError(f"t needs at least 2 samples, got {t.size}")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("t must be strictly increasing")
    span = t[-1] - t[0]
    mean = float(trapezoid(f, t) / span)
    mean_positive = float(trapezoid(np.maximum(f, 0.0), t) / span)
    return mean, mean_positive


def window_bounds(n: int, rate_hz: float, window_s: float) -> np.ndarray:
    # Windows are time intervals [i W, (i + 1) W) from the first sample, so that at 1024 Hz the
    # 200 ms windows hold 204 or 205 samples and their edges do not drift by 0.8 sample per
    # window as a rounded sample count would.
    per_window = window_s * rate_hz
    n_full = math.floor(n / per_window + 1e-9)
    return np.ceil(np.arange(n_full + 1) * per_window - 1e-9).astype(np.intp)


def window_peaks(
    signal: npt.ArrayLike, rate_hz: float, window_s: float = PEAK_WINDOW_S
) -> np.ndarray:
    """Largest ``|a|`` in each consecutive full window (dissertation section 3.2).

    Window i holds the samples whose times, counted from the first sample, fall in
    ``[i * window_s, (i + 1) * window_s)``; sample k stands for ``[k, k + 1) / rate_hz``. The
    trailing partial window is dropped so that every peak is taken over the same duration.

    Parameters
    ----------
    signal : array_like, shape (n,)
        Uniformly sampled acceleration, g.
    rate_hz : float
        Sampling rate, Hz.
    window_s : float, optional
        Window length, s; default 0.2.

    Returns
    -------
    numpy.ndarray
        One peak per full window, g.

    Raises
    ------
    ValueError
        On bad arguments, or if the signal is shorter than one window.
    """
    a = finite_1d("signal", signal)
    rate_hz = finite_positive("rate_hz", rate_hz)
    window_s = finite_positive("window_s", window_s)
    bounds = window_bounds(a.size, rate_hz, window_s)
    if bounds.size < 2 or np.any(np.diff(bounds) < 1):
        raise ValueError(
            f"signal of {a.size} samples at {rate_hz} Hz is shorter than one window "
            f"(window_s={window_s}) or the window holds no sample"
        )
    return np.maximum.reduceat(np.abs(a[: bounds[-1]]), bounds[:-1])


def peak_stats(
    signal: npt.ArrayLike, rate_hz: float, window_s: float = PEAK_WINDOW_S
) -> tuple[float, float]:
    """Mean and standard deviation of the window peaks of :func:`window_peaks`, g.

    The standard deviation is the population one (``ddof=0``, numpy's default): it describes
    the spread of the peaks of this record rather than estimating that of an infinite one (the
    dissertation does not say which it used). The two differ by the factor
    ``sqrt(n / (n - 1))`` for n windows: 1.1 % for the 46 windows of 200 cycles at 21.3 Hz,
    3.5 % for the 15 windows of 200 cycles at 64 Hz.

    Returns
    -------
    mean : float
    std : float
    """
    peaks = window_peaks(signal, rate_hz, window_s)
    return float(np.mean(peaks)), float(np.std(peaks))


def impact_frequency(
    signal_g: npt.ArrayLike,
    rate_hz: float,
    window_s: float = PEAK_WINDOW_S,
    height_frac: float = IMPACT_HEIGHT_FRAC,
    min_distance_s: float = IMPACT_MIN_DISTANCE_S,
) -> float:
    """Impact frequency: major acceleration peaks per second (MODEL.md).

    A major peak is a local maximum of ``|a|`` (``scipy.signal.find_peaks``) that

    * reaches ``height_frac`` times the median of the window peaks (:func:`window_peaks`): the
      median window peak is the typical impact magnitude, robust to a few outlying windows, and
      half of it separates the impact spikes from the smaller rebound and structural peaks
      between them (the 7in field data count one peak per cycle although each cycle shows three);
    * is at least ``min_distance_s`` from a higher major peak, so noise and ringing on one spike
      count once.

    The count is divided by the record duration ``n / rate_hz``, so a periodic train is counted
    to within one peak, i.e. ``1 / duration`` Hz (0.5 % over 200 cycles).

    Parameters
    ----------
    signal_g : array_like, shape (n,)
        Uniformly sampled acceleration, g; at least one full window long.
    rate_hz : float
        Sampling rate, Hz.
    window_s : float, optional
        Window for the reference peak level, s; default 0.2.
    height_frac : float, optional
        Fraction of the median window peak a major peak must reach, in (0, 1]; default 0.5.
    min_distance_s : float, optional
        Minimum spacing of major peaks, s; default 0.005.

    Returns
    -------
    float
        Major peaks per second, Hz (0.0 for a silent signal).
    """
    a = np.abs(finite_1d("signal_g", signal_g))
    rate_hz = finite_positive("rate_hz", rate_hz)
    height_frac = float(height_frac)
    if not 0.0 < height_frac <= 1.0:
        raise ValueError(f"height_frac must be in (0, 1], got {height_frac!r}")
    min_distance_s = float(min_distance_s)
    if not math.isfinite(min_distance_s) or min_distance_s < 0.0:
        raise ValueError(f"min_distance_s must be a finite number >= 0, got {min_distance_s!r}")
    reference = float(np.median(window_peaks(a, rate_hz, window_s)))
    if reference == 0.0:
        return 0.0
    distance = max(1, round(min_distance_s * rate_hz))
    peaks, _ = find_peaks(a, height=height_frac * reference, distance=distance)
    return peaks.size * rate_hz / a.size


# --------------------------------------------------------------------------------------------
# Periodicity from a Poincare section
# --------------------------------------------------------------------------------------------


def _as_section(section: npt.ArrayLike) -> np.ndarray:
    s = np.asarray(section, dtype=float)
    if s.ndim == 1:
        s = s[:, np.newaxis]
    if s.ndim != 2 or s.shape[1] == 0:
        raise ValueError(f"section must have shape (n_cycles, n_state), got {s.shape}")
    if not np.all(np.isfinite(s)):
        raise ValueError("section has a non-finite value")
    return s


def _tail(s: np.ndarray, tail: float) -> np.ndarray:
    tail = float(tail)
    if not 0.0 < tail <= 1.0:
        raise ValueError(f"tail must be in (0, 1], got {tail!r}")
    n = max(1, round(tail * s.shape[0]))
    if n < 3:
        raise ValueError(
            f"section tail holds {n} points (section has {s.shape[0]} rows, tail={tail}); "
            "need at least 3"
        )
    return s[-n:]


def _scale(points: np.ndarray, scale: float | Sequence[float] | np.ndarray | None) -> np.ndarray:
    if scale is None:
        spread = np.ptp(points, axis=0)
        magnitude = np.max(np.abs(points), axis=0)
        out = np.maximum(spread, _SCALE_FLOOR * magnitude)
        # An identically zero component has zero differences too; any positive scale will do.
        out[out == 0.0] = 1.0
        return out
    out = np.broadcast_to(np.asarray(scale, dtype=float), (points.shape[1],)).copy()
    if not np.all(np.isfinite(out)) or np.any(out <= 0.0):
        raise ValueError(f"scale must be finite and > 0, got {scale!r}")
    return out


def poincare_period(
    section: npt.ArrayLike,
    rtol: float = POINCARE_RTOL,
    max_period: int = 8,
    scale: float | Sequence[float] | np.ndarray | None = None,
    tail: float = 0.5,
) -> int | None:
    """Smallest period, in excitation cycles, of a once-per-cycle Poincare section.

    Period p is accepted when every point of the tail repeats p cycles later::

        |section[k + p, j] - section[k, j]| <= rtol * scale[j]   for all k, j in the tail

    and at least two full repetitions are checked (``p <= n_tail / 3``).

    Parameters
    ----------
    section : array_like, shape (n_cycles, n_state) or (n_cycles,)
        State sampled once per excitation cycle at a fixed excitation phase, oldest first.
    rtol : float, optional
        Relative tolerance, default :data:`POINCARE_RTOL`.
    max_period : int, optional
        Largest period tried, default 8.
    scale : float or array_like of shape (n_state,), optional
        Scale of each state component. Default: the component's peak-to-peak over the tail,
        floored at 1e-3 of its largest magnitude there (a period-1 orbit has a spread made of
        integration error only, which must not become the yardstick). Pass the per-component
        amplitude of the full trajectory when it is at hand: it is the more meaningful scale,
        especially for components that sit near zero on the section.
    tail : float, optional
        Fraction of the rows, from the end, that are tested; default 0.5 so that transients left
        in the first analysed cycles do not count.

    Returns
    -------
    int or None
        The smallest period p in ``1..max_period``, or None if there is none.
    """
    s = _tail(_as_section(section), tail)
    rtol = finite_positive("rtol", rtol)
    if int(max_period) != max_period or max_period < 1:
        raise ValueError(f"max_period must be an integer >= 1, got {max_period!r}")
    sc = _scale(s, scale)
    n = s.shape[0]
    for p in range(1, int(max_period) + 1):
        if 3 * p > n:
            break
        if np.max(np.abs(s[p:] - s[:-p]) / sc) <= rtol:
            return p
    return None


def _on_invariant_circle(points: np.ndarray) -> bool:
    """Whether the orbit ``points`` (oldest first, normalised) lies on an invariant circle.

    Four checks on the points projected on the plane of their two leading principal
    components and ordered by angle around their centroid (a scalar orbit uses the delay pair
    ``(s_k, s_k+1)``, which is an ellipse for a quasi-periodic scalar):

    * rotation: on an invariant circle the return map is conjugate to a rotation and keeps the
      cyclic order of the orbit, so the rank of point k + 1 minus the rank of point k (mod n)
      is the same for all k, up to +-1 where the first point leaves the set and the last one
      enters. Chaotic maps fold, random data has no order: their rank steps spread over 0..n-1.
      At least :data:`QP_ORDER_FRACTION` of the steps must fall within +-2 % of n of one value.
    * smooth: the closed polygon through the ordered points is at most :data:`_QP_MAX_LENGTH`
      times the perimeter of their convex hull. A spiral (a focus still converging, which also
      rotates) zigzags between its turns and is much longer.
    * closed: no edge of that polygon exceeds :data:`_QP_MAX_GAP` of its length, so the window
      shows the whole curve and not an arc (a slow drift also keeps the order).
    * stationary: the RMS distance to the centroid differs by at most :data:`_QP_MAX_DRIFT`
      between the first and second halves of the orbit. Both halves of an invariant circle
      sample the same curve; a spiral that converges or diverges slowly enough to look smooth
      does not.
    """
    if points.shape[1] == 1:
        points = np.column_stack([points[:-1, 0], points[1:, 0]])
    n = points.shape[0]
    centred = points - points.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    if sv.size < 2 or sv[1] <= 1e-6 * sv[0]:
        return False
    plane = centred @ vt[:2].T
    order = np.argsort(np.arctan2(plane[:, 1], plane[:, 0]))

    rank = np.empty(n, dtype=np.intp)
    rank[order] = np.arange(n)
    steps = np.mod(np.diff(rank), n)
    # +-2 % rank jitter: noise and a slightly non-convex projection swap near neighbours without
    # breaking the rotation.
    w = max(2, math.ceil(0.02 * n))
    counts = np.bincount(steps, minlength=n).astype(float)
    ext = np.concatenate([counts[-w:], counts, counts[:w]])
    csum = np.concatenate([[0.0], np.cumsum(ext)])
    windowed = csum[2 * w + 1 :] - csum[: -(2 * w + 1)]
    if windowed.max() < QP_ORDER_FRACTION * steps.size:
        return False

    radius = np.linalg.norm(plane, axis=1)
    half = n // 2
    rms_early = np.sqrt(np.mean(radius[:half] ** 2))
    rms_late = np.sqrt(np.mean(radius[half:] ** 2))
    if abs(rms_late - rms_early) > _QP_MAX_DRIFT * max(rms_early, rms_late):
        return False

    ring = plane[order]
    edges = np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)
    length = edges.sum()
    try:
        hull_perimeter = ConvexHull(plane).area  # in 2-D, "area" is the perimeter
    except QhullError:
        return False
    return bool(length <= _QP_MAX_LENGTH * hull_perimeter and edges.max() <= _QP_MAX_GAP * length)


def periodicity(
    section: npt.ArrayLike,
    rtol: float = POINCARE_RTOL,
    max_period: int = 8,
    scale: float | Sequence[float] | np.ndarray | None = None,
    tail: float = 0.5,
) -> str:
    """Periodicity of a steady response from its once-per-cycle Poincare section.

    1. ``"period-p"`` if :func:`poincare_period` finds a period p.
    2. ``"quasi-periodic"`` if the tail lies on an invariant circle (or, for some q <=
       ``max_period``, each of the q sub-orbits ``section[r::q]`` does: a chain of q circles).
       Test (details in ``_on_invariant_circle``): normalise each component by ``scale``,
       project on the plane of the two leading principal components (a scalar section uses the
       delay pair ``(s_k, s_k+1)``), order the points by angle around their centroid; then the
       return map must act as a rotation on that order (at least :data:`QP_ORDER_FRACTION` of
       the steps advance the rank by the same amount, +-2 % of the points), and the ordered
       points must form a smooth closed polygon (not much longer than their convex hull, no
       gap above 15 % of its length), and both halves of the orbit must have the same RMS
       radius to 10 %. Only a quasi-periodic orbit on a closed curve passes all of these;
       chaos folds (fails the rotation), a converging focus spirals (fails smoothness or
       stationarity), a slow drift or a near-resonant rotation not resolved by the window
       leaves a gap.
       Limits: needs 16 points per sub-orbit and a curve star-shaped around its centroid in
       that plane (true of the near-elliptic circles born at a Neimark-Sacker bifurcation); a
       strongly folded curve is reported as aperiodic.
    3. ``"aperiodic"`` otherwise (chaos, or a response not yet settled, or noise above
       ``rtol``).

    Parameters are those of :func:`poincare_period`.

    Returns
    -------
    str
        ``"period-1"``, ``"period-2"``, ..., ``"quasi-periodic"`` or ``"aperiodic"``.
    """
    p = poincare_period(section, rtol=rtol, max_period=max_period, scale=scale, tail=tail)
    if p is not None:
        return f"period-{p}"
    s = _tail(_as_section(section), tail)
    normalised = s / _scale(s, scale)
    for q in range(1, int(max_period) + 1):
        if s.shape[0] // q < _QP_MIN_POINTS:
            break
        if all(_on_invariant_circle(normalised[r::q]) for r in range(q)):
            return "quasi-periodic"
    return "aperiodic"
