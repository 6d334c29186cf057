"""Missing-physics diagnosis: locate a mismatch, fit candidate physics with the nuisance
constants, select one or several effects on held-out data, or say the mismatch is unexplained.

Why this module exists: the dissertation could only say in prose what its model probably
misses ("hydraulics at high flow"). A diagnosis here does it with numbers, on campaigns that
are not kind -- an uncertain WOB, an unknown excitation phase, two mechanisms at once,
physics outside the list:

1. **Calibrate "none".** The base model is fitted with the nuisance constants
   (:mod:`vadsim.fit.nuisance`: by default the WOB scale within +-15 % and the excitation
   phase at rest theta0 over its period): a grid, then Nelder-Mead from the three best grid
   points. "none" below means this *calibrated* base model.
2. **Locate.** Its residuals say which features of which sensor are offset or trend with
   flow (:func:`vadsim.fit.locate.locate`), and which events exceed RMS z 2.
3. **Fit every candidate** (:mod:`vadsim.fit.candidates`) with the nuisance constants:
   a grid over the candidate's parameters at the calibrated nuisance values, a local
   refinement, and -- where the candidate already cuts the training cost by 10 % -- a joint
   Nelder-Mead over the candidate's parameters and the nuisance constants together
   (:func:`vadsim.fit.hypothesis_fit.fit_hypothesis`). Candidates are fitted in parallel
   processes.
4. **Score on held-out events.** Leave-one-flow-out folds and a block of the highest flows;
   each fold refits on its training events among the evaluated points; the held-out error is
   the pooled RMS standardised residual, the score an AICc on the held-out residuals.
5. **Forward selection.** The best-scoring candidate is added if it beats the current model by
   ``min_delta`` in score *and* cuts its held-out RMS by ``min_reduction``, cuts the all-event
   RMS of the model it extends by ``min_reduction`` too
   (:func:`~vadsim.fit.diagnosis.policy.passes` says why), and does not vanish; then every
   remaining candidate is probed and the most promising fitted on top of the chosen ones (their
   values and the nuisance constants as the start, or the candidate's own first-step fit with
   the chosen ones at their nulls, then jointly), and the next is added on the same test, up to
   ``max_effects``, while the current model's held-out RMS is above ``noise_rms``.
6. **Review.** The chosen model is refitted with each effect as each of its variants (a
   resonance on both sensors for one on x1) from the final values, a better-scoring variant
   taking its place; then, with two or more effects, without each effect, and one the
   held-out error does not need (score ``min_delta`` better and RMS 10 % lower with it) is
   dropped (:func:`~vadsim.fit.diagnosis.selection.review`).
7. **Verdict.** ``"explained"`` when effects were chosen and the final model's held-out RMS is
   at most ``max_rms``; ``"none"`` when nothing was chosen and the calibrated base model is
   within ``max_rms``; ``"unexplained"`` otherwise -- a mismatch no hypothesis explains is
   never reported as "none". The events and features left are listed.

The package is laid out as the pipeline runs (docs/ARCHITECTURE.md):

- :mod:`~vadsim.fit.diagnosis.evidence`: the campaign's evidence and the engines built on it;
- :mod:`~vadsim.fit.diagnosis.hypotheses`: the fits of one hypothesis (starts and stages);
- :mod:`~vadsim.fit.diagnosis.search`: probes that rank candidates, and pairs;
- :mod:`~vadsim.fit.diagnosis.policy`: every threshold, and the functions that decide;
- :mod:`~vadsim.fit.diagnosis.selection`: forward selection and the review;
- :mod:`~vadsim.fit.diagnosis.result`: what was found, as data;
- :mod:`~vadsim.fit.diagnosis.parallel`: where the fits run;
- :mod:`~vadsim.fit.diagnosis.pipeline`: :func:`diagnose` and :func:`predict`.
"""

from vadsim.fit.diagnosis.evidence import make_folds
from vadsim.fit.diagnosis.pipeline import diagnose, predict
from vadsim.fit.diagnosis.policy import Policy, none_model
from vadsim.fit.diagnosis.result import Diagnosis
from vadsim.fit.diagnosis.search import pair_prospects, screen_pairs

__all__ = ["Diagnosis", "Policy", "diagnose", "make_folds", "none_model", "pair_prospects",
           "predict", "screen_pairs"]
