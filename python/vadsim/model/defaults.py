"""The defaults of how runs are made and measured, declared once.

Why this module exists: a run's length, its analysed window and the sampling phases a
measurement averages over were written as literals in some fifteen signatures (400/200 in
most, 300/200 in the diagnosis and the blind benchmark, 8 or 4 phases). Every function that
takes one of them takes its default from :data:`DEFAULTS`.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DEFAULTS", "RunDefaults"]


@dataclass(frozen=True)
class RunDefaults:
    """The defaults of how runs are made and measured, declared once: every function that
    takes one of these takes its default from :data:`DEFAULTS`.

    Attributes
    ----------
    cycles, analyse_cycles
        The dissertation's literal run: 400 excitation cycles, the last 200 analysed.
    recording_cycles
        A run compared with recordings (validation, calibration, diagnosis, the blind
        benchmark): 300 cycles, the last ``analyse_cycles`` analysed. A window that still
        drifts after its 100 settling cycles is continued (:mod:`vadsim.model.steady`).
    phases
        Sampling phases a simulated sensor's features are averaged over in a validation or a
        calibration (the phase of a recording is unknown).
    diagnosis_phases
        The same in a diagnosis, which evaluates thousands of points: fewer phases, the same
        ranking.
    workers
        Threads or processes (None: one per core).
    scheduler
        A Dask scheduler's address (None: local).
    """

    cycles: float = 400.0
    analyse_cycles: float = 200.0
    recording_cycles: float = 300.0
    phases: int = 8
    diagnosis_phases: int = 4
    workers: int | None = None
    scheduler: str | None = None


DEFAULTS = RunDefaults()
"""The run defaults (:class:`RunDefaults`)."""
