"""The comparison engine: from a campaign and run settings to standardised residuals.

Why this module exists: validation, calibration and diagnosis all ask one question -- how far
is the model from the recordings, event by event and feature by feature, in units of the
recording's own spread? They answer it here, the same way, with the same failure handling:

1. **run** an event at its flow and WOB (:func:`run_event`, or :func:`summary_event` when only
   the core's full-resolution summary is needed), continued while its window drifts (a
   recording is steady drilling: :mod:`vadsim.model.steady`). A periodic run stops at its
   orbit (``steady="auto"``) and hands over one orbit instead of its window's fine series
   (:func:`fine_series` rebuilds the window from it). With ``warm_starts``, a model change
   starts each event from the base model's steady state there (:class:`WarmStart`: a fixed,
   stored state) and settles :data:`WARM_SETTLE_CYCLES`;
2. **measure** the run through each sensor's chain, averaged over sampling phases, and at full
   resolution (:func:`measure_event`), optionally after measurement-side physics;
3. compute the **recorded** features (:func:`recorded_features`);

Folded evidence (:data:`FOLDED`, on by default; ``folded=False`` gives the features of before):
a recorded time series is also folded by excitation phase (equivalent-time sampling,
:mod:`vadsim.signals.folding`), which recovers the cycle's waveform -- the 1 ms impact spike
included -- far beyond what 1024 Hz sampling shows, and the simulation gives the matching
features from its fine grid through the sensors' analog chain
(:mod:`vadsim.signals.fold_features`; the recording decides between folded and distribution
features, the simulation computes every kind). They enter ``EventSimulation.sensor`` with a
``phase_sd`` of 0, so residuals and the evaluator compare them like every other feature.
4. **standardise** (:func:`standardised_residual`, the one definition of a residual;
   :func:`event_residuals` for an event, :func:`residual_table` for a campaign).

:class:`CampaignEvaluator` does 1-4 for every event of a campaign and any model change (extra
physics, overrides, a measurement), in parallel threads, caching runs: a measurement-side
change re-measures the base model's runs instead of running the model again. With a
:class:`~vadsim.model.cache.ResultCache` (``cache=`` or ``$VADSIM_CACHE``) each event's
measured simulation is also kept on disk, keyed by its exact inputs and the code's
fingerprint, so another diagnosis, calibration or validation that meets the same run (the same
event under the same model) reads it instead of running it again.
"""

from vadsim.compare.engine import NOISE_SEED, NOISE_STEP_G, CampaignEvaluator, EventEval
from vadsim.compare.events import (
    FAILED_RESIDUAL,
    FOLDED,
    ORBIT_OVERSAMPLING,
    WARM_SETTLE_CYCLES,
    EventSimulation,
    WarmStart,
    fine_rate_hz,
    fine_series,
    measure_event,
    recorded_features,
    recorded_noise_g,
    run_event,
    sensor_groups,
    simulate_event,
    summary_event,
)
from vadsim.compare.residuals import event_residuals, residual_table, standardised_residual
from vadsim.model.change import Measurement, ModelChange

__all__ = [
    "FAILED_RESIDUAL",
    "FOLDED",
    "ORBIT_OVERSAMPLING",
    "WARM_SETTLE_CYCLES",
    "NOISE_SEED",
    "NOISE_STEP_G",
    "CampaignEvaluator",
    "EventEval",
    "EventSimulation",
    "Measurement",
    "WarmStart",
    "ModelChange",
    "event_residuals",
    "fine_rate_hz",
    "fine_series",
    "measure_event",
    "recorded_features",
    "recorded_noise_g",
    "residual_table",
    "run_event",
    "sensor_groups",
    "simulate_event",
    "standardised_residual",
    "summary_event",
]
