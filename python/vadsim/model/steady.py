"""Runs whose steady window is steady: continue a run whose window still drifts.

Why this module exists: a run analyses its last ``analyse_cycles`` after ``cycles -
analyse_cycles`` settling cycles (the dissertation: 200 after 200; a diagnosis: 200 after 100).
Near a regime boundary an intermittent response can take longer than that to settle. Measured
on the 7in tool (300 cycles, 200 analysed, phase at rest 1.964): at 500 gal/min the window
still holds the transient from intermittent impacts (spring contacts 0.1 per cycle, Z* 0.85)
to one impact every cycle, which the response reaches after about 150 cycles; a recording
of steady drilling shows the settled response, and the diagnosis of a campaign that was the
base model plus a phase at rest read that event as a 35 % lighter sub.

A field recording is taken in steady drilling, minutes after the flow settled. So a
comparison continues a run whose window drifts -- contact onsets per cycle on some surface
differ between the window's halves by more than :data:`DRIFT_TOL` -- from its final state for
another run of the same length, at most :data:`MAX_EXTENSIONS` times. The excitation is
periodic in time, so a run of a whole number of cycles continues exactly in phase. A chaotic
response drifts too, by 0.05-0.1 per cycle between 100-cycle halves; the tolerance is above
that, so only a transient (measured: 0.15-0.3) pays for a second run.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vadsim.model.result import SimulationResult
from vadsim.model.settings import RunSettings

__all__ = ["DRIFT_TOL", "MAX_EXTENSIONS", "steady_run", "window_drift"]

DRIFT_TOL = 0.15
"""Largest change of contact onsets per cycle, on any surface, between the halves of a steady
window that counts as settled (module docstring for the measurements behind it)."""

MAX_EXTENSIONS = 2
"""Continuations of a drifting run at most: a response still drifting after three runs is
chaotic or a very slow transient, and a longer run does not make it steadier."""


def window_drift(r: SimulationResult) -> float:
    """Largest change of contact onsets per cycle, over every surface, from the first half of
    the run's steady window to its second (0 without contacts)."""
    w0, w1 = r.window
    mid = 0.5 * (w0 + w1)
    half = 0.5 * float(r.analyse_cycles)
    ev = r.events
    if half <= 0 or ev.empty:
        return 0.0
    # counted per surface code with numpy: a pandas groupby cost 2 ms, a tenth of a warm
    # started run's measurement in a diagnosis
    onset = (ev["kind"] == "onset").to_numpy()
    t = ev["time_s"].to_numpy(float)[onset]
    surface = ev["surface"].cat.codes.to_numpy()[onset]
    n = len(ev["surface"].cat.categories)
    first = np.bincount(surface[(t >= w0) & (t < mid)], minlength=n) / half
    second = np.bincount(surface[(t >= mid) & (t <= w1)], minlength=n) / half
    return float(np.max(np.abs(second - first), initial=0.0))


def steady_run(settings: RunSettings, flow_gpm: float, *, wob_klbf: float | None = None,
               max_extensions: int = MAX_EXTENSIONS, drift_tol: float = DRIFT_TOL,
               initial_displacement: np.ndarray | None = None, **options: Any
               ) -> SimulationResult:
    """:meth:`RunSettings.run`, continued from its final state while its window drifts.

    Parameters
    ----------
    settings, flow_gpm, wob_klbf
        As :meth:`RunSettings.run`.
    max_extensions
        Continuations at most (0: a plain run).
    drift_tol
        :func:`window_drift` that counts as settled.
    initial_displacement
        Where the first run starts, ``[u; v]`` about its own static state (e.g. a base
        model's steady motion at the same operating point, ``end_displacement``: a warm
        start); None: from rest.
    options
        :func:`vadsim.simulate`'s output options.

    Returns
    -------
    SimulationResult
        The last run. Its ``stats["steady_extensions"]`` says how many continuations it took.

    Raises
    ------
    ValueError
        For a negative ``max_extensions`` or a drift tolerance that is not a positive number.
    """
    if isinstance(max_extensions, bool) or not isinstance(max_extensions, int) \
            or max_extensions < 0:
        raise ValueError(f"max_extensions = {max_extensions!r} must be an integer >= 0")
    if not (isinstance(drift_tol, (int, float)) and math.isfinite(drift_tol) and drift_tol > 0):
        raise ValueError(f"drift_tol = {drift_tol!r} must be a positive number")
    r = settings.run(flow_gpm, wob_klbf=wob_klbf, initial_displacement=initial_displacement,
                     **options)
    # A fraction of a cycle would restart the excitation out of phase.
    whole = float(settings.cycles).is_integer()
    extensions = 0
    while whole and extensions < max_extensions and window_drift(r) > drift_tol:
        r = settings.run(flow_gpm, wob_klbf=wob_klbf, initial_state=r, **options)
        extensions += 1
    r.stats = {**r.stats, "steady_extensions": extensions}
    return r
