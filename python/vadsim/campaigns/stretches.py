"""Aligning a surface log with a downhole record, and finding the steady stretches in it.

Why this module exists: a memory sub records for hours while the rig steps the flow; only the
stretches where flow and WOB held steady are events of a campaign (RECORDINGS.md: "the
recording holds steady operation only"). The rig's log runs on its own clock, so the two
clocks are aligned first: by an offset the user knows, or from the one moment both files
see -- the pumps coming on, when the downhole vibration starts (:func:`estimate_offset`).
:func:`find_stretches` then cuts the log into levels and says, for each, whether it becomes
an event and, when not, why.

Conventions: ``offset_s`` is surface time minus record time for the same instant, so a
record time is ``surface time - offset_s``. Times are seconds on each file's clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vadsim.campaigns.format import CampaignError

__all__ = [
    "ClockAlignment",
    "Level",
    "Stretch",
    "StretchRules",
    "estimate_offset",
    "find_levels",
    "find_stretches",
    "vibration_onset",
    "pumps_on_time",
]

#: Samples a deviation must last to count as a change of level rather than an excursion.
SUSTAIN_SAMPLES = 3

#: How loud the downhole record must get, in multiples of its quiet first second's RMS, for a
#: sample to start the vibration (and the next 0.1 s to stay above a third of that).
ONSET_FACTOR = 8.0


@dataclass(frozen=True)
class StretchRules:
    """What counts as steady.

    Parameters
    ----------
    flow_tol_gpm, wob_tol_klbf
        Flow and WOB must stay within these of their level throughout a stretch.
    min_duration_s
        Shortest event kept, after ``settle_s`` is dropped.
    settle_s
        Seconds dropped after each change (the tool settles into its new response).
    min_flow_gpm
        Below this the pumps are off: no event.
    max_duration_s
        Longest event written (a longer stretch is cut to its first ``max_duration_s``); None
        for no limit.
    """

    flow_tol_gpm: float = 10.0
    wob_tol_klbf: float = 1.0
    min_duration_s: float = 8.0
    settle_s: float = 2.0
    min_flow_gpm: float = 50.0
    max_duration_s: float | None = None

    def describe(self) -> str:
        """One line for a summary."""
        cut = (f", cut to {self.max_duration_s:g} s" if self.max_duration_s is not None
               else "")
        return (f"flow within +-{self.flow_tol_gpm:g} gal/min and WOB within "
                f"+-{self.wob_tol_klbf:g} klbf of their level, at least "
                f"{self.min_duration_s:g} s after the first {self.settle_s:g} s of each level "
                f"are dropped{cut}; pumps off below {self.min_flow_gpm:g} gal/min")


@dataclass(frozen=True)
class ClockAlignment:
    """How the surface clock maps onto the record's: ``surface = record + offset_s``.

    ``estimated`` says whether the offset was measured (from ``record_onset_s`` and
    ``surface_onset_s``, good to about ``uncertainty_s``) or given.
    """

    offset_s: float
    estimated: bool
    record_onset_s: float | None = None
    surface_onset_s: float | None = None
    uncertainty_s: float = 0.0
    threshold_gpm: float | None = None

    def describe(self) -> str:
        """What the offset is and where it came from, for a summary."""
        head = f"clock offset {self.offset_s:+.3f} s (surface time = record time + offset)"
        if not self.estimated:
            return head + ", as given"
        return (f"{head}, estimated: the downhole vibration starts at "
                f"{self.record_onset_s:.3f} s of the record and the pumps come on at "
                f"{self.surface_onset_s:.3f} s of the surface log (the flow crosses "
                f"{self.threshold_gpm:.0f} gal/min, half its first level); good to about one "
                f"surface sample ({self.uncertainty_s:g} s)")


@dataclass
class Level:
    """A run of surface samples at one flow and WOB: indices ``first..last`` (inclusive),
    the level, and the brief excursions from it inside ``(index, samples)``."""

    first: int
    last: int
    flow_gpm: float
    wob_klbf: float
    excursions: list[tuple[int, int]] = field(default_factory=list)


@dataclass
class Stretch:
    """One level of the surface log and what became of it.

    ``start_s``/``end_s`` are its first and last samples (surface clock); ``kept_s`` the part
    written as an event (record clock), or None; ``reason`` why it was refused ("" when it
    became ``event_id``).
    """

    start_s: float
    end_s: float
    flow_gpm: float
    wob_klbf: float
    kept_s: tuple[float, float] | None = None
    event_id: str | None = None
    reason: str = ""

    @property
    def accepted(self) -> bool:
        """Whether this stretch became an event."""
        return self.event_id is not None


def pumps_on_time(t: np.ndarray, flow: np.ndarray, min_flow_gpm: float,
                  where: str) -> tuple[float, float]:
    """When the flow first comes on (surface clock) and the threshold used.

    The first level above ``min_flow_gpm`` that holds for 3 samples; the time is where the
    flow crosses half that level, interpolated between the two samples around it (a log of
    1 s averages puts it within a fraction of a second of the step).
    """
    on = flow > min_flow_gpm
    runs = np.flatnonzero(on[:-2] & on[1:-1] & on[2:]) if flow.size >= 3 else np.array([])
    if runs.size == 0:
        raise CampaignError(f"{where}: the flow never exceeds {min_flow_gpm:g} gal/min for "
                            f"3 samples: no moment the pumps come on to align the clocks by")
    k = int(runs[0])
    level = float(np.median(flow[k:k + 5]))
    half = 0.5 * level
    i1 = k + int(np.argmax(flow[k:] >= half))
    while i1 > 0 and flow[i1 - 1] >= half:
        i1 -= 1
    if i1 == 0:
        raise CampaignError(f"{where}: the log starts with the pumps on ({flow[0]:.0f} "
                            f"gal/min): no moment they come on to align the clocks by; give "
                            f"the clock offset (--clock-offset)")
    f0, f1 = float(flow[i1 - 1]), float(flow[i1])
    frac = (half - f0) / (f1 - f0) if f1 != f0 else 1.0
    return float(t[i1 - 1] + frac * (t[i1] - t[i1 - 1])), half


def vibration_onset(t0_s: float, rate_hz: float, accel: np.ndarray, where: str) -> float:
    """When the downhole vibration starts (record clock): the first sample louder than
    :data:`ONSET_FACTOR` times the quiet first second's RMS, followed by 0.1 s that stays
    loud. ``accel`` is one row per sample, one column per sensor (g)."""
    loud = np.sqrt(np.sum(np.square(accel - np.median(accel[: int(rate_hz)], axis=0)),
                          axis=1))
    first = loud[: max(2, int(rate_hz))]
    quiet = float(np.sqrt(np.mean(np.square(first))))
    quiet = max(quiet, 1e-6)
    window = max(1, int(round(0.1 * rate_hz)))
    if float(np.sqrt(np.mean(np.square(first[-window:])))) > 3 * quiet or loud.size < 2 * window:
        raise CampaignError(f"{where}: the record's first second is not quiet: no moment "
                            f"the vibration starts to align the clocks by (were the pumps "
                            f"already on?); give the clock offset (--clock-offset)")
    cumsq = np.concatenate([[0.0], np.cumsum(np.square(loud))])
    for i in np.flatnonzero(loud > ONSET_FACTOR * quiet):
        end = min(loud.size, i + window)
        rms = math.sqrt((cumsq[end] - cumsq[i]) / (end - i))
        if rms > ONSET_FACTOR * quiet / 3:
            return t0_s + float(i) / rate_hz
    raise CampaignError(f"{where}: the vibration never rises above {ONSET_FACTOR:g} times the "
                        f"quiet level of the record's first second; give the clock offset "
                        f"(--clock-offset)")


def estimate_offset(record_onset_s: float, t: np.ndarray, flow: np.ndarray,
                    min_flow_gpm: float, where: str) -> ClockAlignment:
    """The clock offset from the moment the pumps come on in the surface log and the moment
    the vibration starts in the record."""
    surface_onset, half = pumps_on_time(t, flow, min_flow_gpm, where)
    period = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    return ClockAlignment(surface_onset - record_onset_s, True, record_onset_s, surface_onset,
                          period, half)


def find_levels(flow: np.ndarray, wob: np.ndarray, rules: StretchRules,
                sustain: int) -> list[Level]:
    """Cut a log into levels: a change is a deviation beyond the tolerances that lasts
    ``sustain`` samples; a shorter one is an excursion inside the level. The samples of a
    change that are not yet within tolerance of the new level belong to no level."""
    levels: list[Level] = []
    n = flow.size
    start = 0
    out: list[int] = []
    excursions: list[tuple[int, int]] = []
    ref_q, ref_w = float(np.median(flow[:sustain])), float(np.median(wob[:sustain]))
    for i in range(n):
        if abs(flow[i] - ref_q) > rules.flow_tol_gpm or abs(wob[i] - ref_w) > rules.wob_tol_klbf:
            out.append(i)
            if len(out) < sustain:
                continue
            levels.append(Level(start, out[0] - 1, ref_q, ref_w, excursions))
            late = out[len(out) // 2:]  # the settled end of the change
            ref_q, ref_w = float(np.median(flow[late])), float(np.median(wob[late]))
            start = next((j for j in out if abs(flow[j] - ref_q) <= rules.flow_tol_gpm
                          and abs(wob[j] - ref_w) <= rules.wob_tol_klbf), out[-1])
            out, excursions = [], []
        elif out:
            excursions.append((out[0], len(out)))
            out = []
    levels.append(Level(start, (out[0] - 1) if out else n - 1, ref_q, ref_w, excursions))
    return [lv for lv in levels if lv.last >= lv.first]


def _excursion_text(t: np.ndarray, flow: np.ndarray, wob: np.ndarray, level: Level,
                    rules: StretchRules) -> str:
    i, k = level.excursions[0]
    span = slice(i, i + k)
    dq = flow[span] - level.flow_gpm
    if np.max(np.abs(dq)) > rules.flow_tol_gpm:
        j = i + int(np.argmax(np.abs(dq)))
        what = (f"the flow changes inside: {flow[j]:.0f} gal/min at {t[j]:.1f} s, "
                f"{abs(flow[j] - level.flow_gpm):.0f} gal/min from its level "
                f"{level.flow_gpm:.0f} (tolerance {rules.flow_tol_gpm:g})")
    else:
        j = i + int(np.argmax(np.abs(wob[span] - level.wob_klbf)))
        what = (f"the WOB changes inside: {wob[j]:.1f} klbf at {t[j]:.1f} s, "
                f"{abs(wob[j] - level.wob_klbf):.1f} klbf from its level "
                f"{level.wob_klbf:.1f} (tolerance {rules.wob_tol_klbf:g})")
    more = f"; {len(level.excursions) - 1} more" if len(level.excursions) > 1 else ""
    return f"{what}, for {k} sample{'s' if k > 1 else ''}{more}"


def find_stretches(t: np.ndarray, flow: np.ndarray, wob: np.ndarray, rules: StretchRules,
                   alignment: ClockAlignment,
                   covered: list[tuple[float, float]]) -> list[Stretch]:
    """Every level of the surface log (``t`` on the surface clock) with its fate.

    A level becomes an event (``kept_s`` on the record clock, within one of the ``covered``
    spans of the record) when the pumps are on, nothing inside it left the tolerances, and
    at least ``min_duration_s`` remain after the first ``settle_s`` are dropped and the end
    is pulled in by the clock's uncertainty. Otherwise ``reason`` says why not.
    """
    out: list[Stretch] = []
    for level in find_levels(flow, wob, rules, SUSTAIN_SAMPLES):
        keep = np.ones(level.last - level.first + 1, dtype=bool)
        for i, k in level.excursions:
            keep[i - level.first:i - level.first + k] = False
        span = slice(level.first, level.last + 1)
        st = Stretch(float(t[level.first]), float(t[level.last]),
                     float(np.mean(flow[span][keep])), float(np.mean(wob[span][keep])))
        out.append(st)
        if st.flow_gpm < rules.min_flow_gpm:
            st.reason = (f"pumps off: flow {st.flow_gpm:.0f} gal/min, below "
                         f"{rules.min_flow_gpm:g}")
        elif level.excursions:
            st.reason = _excursion_text(t, flow, wob, level, rules)
        else:
            _keep_part(st, t, flow, wob, rules, alignment, covered)
    return out


def _keep_part(st: Stretch, t: np.ndarray, flow: np.ndarray, wob: np.ndarray,
               rules: StretchRules, alignment: ClockAlignment,
               covered: list[tuple[float, float]]) -> None:
    """Set ``kept_s`` (and the level's mean over it) or the reason it has none."""
    lo = st.start_s + rules.settle_s - alignment.offset_s
    hi = st.end_s - 0.5 * alignment.uncertainty_s - alignment.offset_s
    best = (lo, lo)
    for a, b in covered:
        part = (max(lo, a), min(hi, b))
        if part[1] - part[0] > best[1] - best[0]:
            best = part
    length = best[1] - best[0]
    if hi - lo < rules.min_duration_s:
        st.reason = (f"{max(hi - lo, 0.0):.1f} s usable after dropping the first "
                     f"{rules.settle_s:g} s, shorter than the {rules.min_duration_s:g} s minimum")
        return
    if not covered or length <= 0:
        st.reason = "outside the downhole record" + (
            f" (it covers {covered[0][0] + alignment.offset_s:.1f} to "
            f"{covered[-1][1] + alignment.offset_s:.1f} s of the surface clock)" if covered
            else "")
        return
    if length < rules.min_duration_s:
        st.reason = (f"the downhole record covers only {length:.1f} s of it, shorter than the "
                     f"{rules.min_duration_s:g} s minimum")
        return
    if rules.max_duration_s is not None and length > rules.max_duration_s:
        best = (best[0], best[0] + rules.max_duration_s)
    st.kept_s = best
    inside = (t >= best[0] + alignment.offset_s) & (t <= best[1] + alignment.offset_s)
    if inside.any():
        st.flow_gpm = float(np.mean(flow[inside]))
        st.wob_klbf = float(np.mean(wob[inside]))
