"""The held-out score of a hypothesis: each fold refitted on its training events, its held-out
events predicted, and an AICc on those predictions.

Each fold chooses, among the points evaluated on every event, the one with the lowest
*training* cost (refined by a parabola when the hypothesis has a single coordinate) and
predicts its held-out events (:func:`score_folds`). Their cost is the *predictive* one: the
least rise of the fold's training cost that buys the held-out events' fit,
``min_p [train(p) + test(p)] - min_p train(p)``, which is at most the prediction's own cost
``test(fold point)`` (:func:`predictive_cost`). The error is the RMS standardised residual
pooled over all held-out predictions, and the score an AICc on those residuals
(:func:`aicc`).

Why a module of its own: a diagnosis ranks its hypotheses by this score, so it is one
definition, read by :func:`~vadsim.fit.hypothesis_fit.fit_hypothesis` and the selection alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from vadsim.fit.hypothesis import Fold, Hypothesis, HypothesisCosts, Point

__all__ = ["aicc", "events_cost", "is_block_fold", "predictive_cost", "score_folds"]


def aicc(n: int, mse: float, k: int) -> float:
    """Corrected Akaike criterion of ``n`` residuals with mean square ``mse`` and ``k``
    fitted parameters."""
    pen = 2 * k + (2 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else math.inf)
    return n * math.log(max(mse, 1e-12)) + pen


def is_block_fold(fold_name: str) -> bool:
    """Whether a fold is the high-flow block fold (the others leave one flow out).

    Why: the two kinds are scored apart (a block predicts flows beyond every training flow),
    and only the leave-one-flow-out folds' refits feed the jackknife interval
    (:func:`~vadsim.fit.intervals.jackknife_interval`); the fold's name tells them apart
    (:func:`~vadsim.fit.diagnosis.make_folds` names the block ``"block >= ..."``).

    Parameters
    ----------
    fold_name
        The fold's name, the first item of a :data:`~vadsim.fit.hypothesis.Fold`.

    Returns
    -------
    bool
        True for the block fold.
    """
    return fold_name.startswith("block")


def events_cost(event_rss: np.ndarray, eids: Sequence[str], events: Sequence[str]
                ) -> np.ndarray:
    """Per point, the summed cost of ``events`` (columns of ``event_rss`` in ``eids``).

    Why: a fold's training and held-out costs are sums over its events of the points'
    per-event costs, which were evaluated on every event already: no new run.

    Parameters
    ----------
    event_rss
        Points x events sums of squared residuals
        (:meth:`~vadsim.fit.hypothesis.HypothesisCosts.event_rss`).
    eids
        The events of ``event_rss``'s columns, in order.
    events
        The events summed (some of ``eids``).

    Returns
    -------
    numpy.ndarray
        One cost per point.
    """
    return event_rss[:, [eids.index(e) for e in events]].sum(axis=1)


def _parabola_min(u: np.ndarray, c: np.ndarray) -> float:
    """Minimum of the parabola through the best point and its neighbours (1-D)."""
    i = int(np.argmin(c))
    if i == 0 or i == len(u) - 1:
        return float(u[i])
    x0, x1, x2 = u[i - 1], u[i], u[i + 1]
    y0, y1, y2 = c[i - 1], c[i], c[i + 1]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    if den == 0:
        return float(x1)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
    if a <= 0:
        return float(x1)
    return float(min(max(-b / (2 * a), x0), x2))


def _fold_point(hyp: Hypothesis, points: list[Point], train_cost: np.ndarray) -> Point:
    """A fold's point among the evaluated ones: the lowest training cost, refined by a
    parabola through its neighbours when the hypothesis has a single coordinate."""
    if len(hyp.specs) == 1:
        us = np.array([hyp.unit(p)[0] for p in points])
        o = np.argsort(us)
        return hyp.from_unit([_parabola_min(us[o], train_cost[o])])
    return points[int(np.argmin(train_cost))]


@dataclass
class _Heldout:
    """The folds' held-out predictions and refits (:func:`score_folds`)."""

    held: dict[str, dict[str, float]] = field(default_factory=dict)
    held_sim: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_values: dict[str, dict[str, float]] = field(default_factory=dict)
    fold_points: dict[str, Point] = field(default_factory=dict)
    sq_lofo: list[np.ndarray] = field(default_factory=list)
    sq_block: list[np.ndarray] = field(default_factory=list)
    predicted_values: dict[str, dict[str, float]] = field(default_factory=dict)
    """Folds whose held-out cost came from a point other than the fold point: its values."""


def predictive_cost(train: np.ndarray, test: np.ndarray, at_fold_point: float
                    ) -> tuple[float, int | None]:
    """A fold's held-out cost over evaluated points (``train``, ``test``: their training and
    held-out sums of squared standardised residuals) and the one that gives it (None: the
    fold point, whose held-out cost is ``at_fold_point``).

    The cost is the least rise of the training cost that buys the held-out events' fit,
    ``min_p [train(p) + test(p)] - min_p train(p)``, capped by ``at_fold_point``. Why not
    simply the fold point's prediction: near a regime boundary an event's response flips
    between parameter values that the training events cannot tell apart (measured: blind-01's
    450 gal/min event at RMS z 14.6 from a fold point whose all-event counterpart fits it at
    0.3; blind-16's 500 gal/min at 6.1), and one such flip then decides a verdict. For a
    model linear in its parameters with unit-variance residuals this rise is exactly the
    prediction's squared error over its *predictive* variance, noise plus the parameters'
    uncertainty, ``r^2 / (1 + h)``: the held-out residual standardised honestly, which a
    flip within the parameters' uncertainty cannot inflate. An event no training-consistent
    point fits keeps its whole cost."""
    train = np.asarray(train, dtype=float)
    test = np.asarray(test, dtype=float)
    if train.size == 0:
        return float(at_fold_point), None
    rise = train + test - float(np.min(train))
    i = int(np.argmin(rise))
    if rise[i] < at_fold_point:
        return float(rise[i]), i
    return float(at_fold_point), None


def score_folds(costs: HypothesisCosts, folds: Sequence[Fold], points: list[Point],
                event_rss: np.ndarray) -> _Heldout:
    """Refit on each fold's training events (choosing among evaluated points) and predict its
    held-out events, at the predictive cost (:func:`predictive_cost`)."""
    hyp, eids, ev = costs.hyp, costs.eids, costs.ev
    names = [p.name for p in hyp.specs]
    out = _Heldout()
    for name, train, test in folds:
        tc = events_cost(event_rss, eids, train)
        pt = _fold_point(hyp, points, tc) if hyp.specs else ()
        if hyp.specs:
            out.fold_values[name] = dict(zip(names, pt, strict=True))
            out.fold_points[name] = pt
        res = costs.evaluate([pt], test)
        own = float(sum(np.sum(res[(pt, e)].z ** 2) for e in test))
        test_rss = events_cost(event_rss, eids, test)
        cost, via = predictive_cost(tc, test_rss, own) if hyp.specs else (own, None)
        scale, uniform = 1.0, 0.0
        if via is not None:
            # the held-out residuals of the point that buys their fit, scaled so that their
            # squares sum to the predictive cost (its rise of the training cost included)
            pt = points[via]
            out.predicted_values[name] = dict(zip(names, pt, strict=True))
            res = costs.evaluate([pt], test)
            at = float(test_rss[via])
            if at > 0:
                scale = math.sqrt(cost / at)
            else:  # the point fits them exactly: its rise of the training cost is all
                uniform = math.sqrt(cost / sum(res[(pt, e)].z.size or 1 for e in test))
        block = is_block_fold(name)
        for e in test:
            z = res[(pt, e)].z * scale + uniform
            (out.sq_block if block else out.sq_lofo).append(z ** 2)
            if not block:
                out.held[e] = dict(zip(ev.keys[e], map(float, z), strict=True))
                out.held_sim[e] = dict(zip(ev.keys[e], map(float, res[(pt, e)].values),
                                           strict=True))
    return out
