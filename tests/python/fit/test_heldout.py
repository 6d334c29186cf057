"""The held-out cost of a fold: the rise of its training cost that buys the held-out events'
fit (`vadsim.fit.scoring.predictive_cost`), and its use in the folds' scores."""

from __future__ import annotations

import math

import numpy as np
import pytest
from vadsim.compare import EventEval
from vadsim.fit.hypothesis import Hypothesis
from vadsim.fit.nuisance import DEFAULT_NUISANCE
from vadsim.fit.scoring import predictive_cost, score_folds


@pytest.mark.parametrize("x_e", [0.3, 1.0, 4.0])
def test_for_a_linear_model_it_is_the_residual_over_its_predictive_variance(x_e):
    """y = a x + e with unit noise: adding one observation to a least-squares fit raises its
    cost by r^2 / (1 + h), r the prediction error of the training fit and h = x_e^2 / sum x^2
    the prediction's own variance. On a dense grid of a the cost must be that, and below the
    prediction's plain r^2."""
    rng = np.random.default_rng(7)
    x = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    y = 1.3 * x + rng.normal(size=x.size)
    y_e = 1.3 * x_e + 2.5  # a held-out observation 2.5 sigma off
    a = np.linspace(-5.0, 8.0, 260_001)
    train = ((y[None, :] - a[:, None] * x[None, :]) ** 2).sum(axis=1)
    test = (y_e - a * x_e) ** 2
    a_hat = float(np.sum(x * y) / np.sum(x * x))
    r2 = (y_e - a_hat * x_e) ** 2
    h = x_e ** 2 / float(np.sum(x * x))
    cost, via = predictive_cost(train, test, r2)
    assert cost == pytest.approx(r2 / (1 + h), rel=1e-4)
    assert via is not None and cost < r2


def test_a_flip_within_the_parameters_uncertainty_does_not_decide_it():
    """An event near a regime boundary flips at the fold's point (cost 400) but is fitted by
    a point the training events barely tell apart (rise 0.5): its cost is that rise plus its
    fit there. An event no training-consistent point fits keeps its whole cost."""
    a = np.linspace(-1.0, 1.0, 201)
    train = 50.0 * a ** 2  # the fold's optimum at a = 0
    flipped = np.where(a < 0.1, 400.0, 0.2)
    cost, via = predictive_cost(train, flipped, at_fold_point=400.0)
    assert via is not None and a[via] == pytest.approx(0.1)
    assert cost == pytest.approx(50.0 * 0.1 ** 2 + 0.2)
    # a real misfit: fitted only where the training cost rises by 50
    misfit = np.where(a > 0.99, 0.0, 30.0)
    assert predictive_cost(train, misfit, at_fold_point=30.0) == (30.0, None)
    # never above the prediction of the fold's own point
    assert predictive_cost(train, np.full(a.size, 9.0), at_fold_point=4.0) == (4.0, None)
    assert predictive_cost(np.array([]), np.array([]), at_fold_point=4.0) == (4.0, None)


class _Costs:
    """Stand-in for a hypothesis' evaluations: two residuals per event, the first driven by
    the WOB scale. The training events pull WOB to 0.99, where the held-out e4 flips (z 30);
    at WOB 1.0, a rise of 0.75 in the training cost, e4 is fitted."""

    def __init__(self) -> None:
        self.hyp = Hypothesis((), DEFAULT_NUISANCE)
        self.eids = ["e1", "e2", "e3", "e4"]
        self.ev = type("Ev", (), {"keys": {e: ["k_wob", "k_flat"] for e in self.eids}})()

    def z(self, point, e) -> np.ndarray:
        wob = point[0]
        if e == "e4":
            return np.array([30.0 if wob < 0.995 else 10.0 * (wob - 1.0), 0.1])
        return np.array([50.0 * (wob - 0.99), 0.1])

    def evaluate(self, points, eids=None):
        eids = eids if eids is not None else self.eids
        return {(p, e): EventEval(None, self.z(p, e), self.z(p, e) + 1.0)
                for p in points for e in eids}


def test_folds_score_a_flipped_event_at_its_predictive_cost():
    costs = _Costs()
    points = [(w, 1.0) for w in (0.98, 0.99, 1.0, 1.01)]
    event_rss = np.array([[np.sum(costs.z(p, e) ** 2) for e in costs.eids] for p in points])
    folds = [("lofo-e4", ["e1", "e2", "e3"], ["e4"]), ("lofo-e1", ["e2", "e3", "e4"], ["e1"])]
    h = score_folds(costs, folds, points, event_rss)
    # the fold point is WOB 0.99 (training cost 0.03), where e4 flips; WOB 1.0 fits it for a
    # rise of 3 x 0.5^2 = 0.75 in the training cost
    assert h.fold_values["lofo-e4"]["wob_scale"] == 0.99
    assert h.predicted_values["lofo-e4"] == {"wob_scale": 1.0, "theta0": 1.0}
    z4 = np.array(list(h.held["e4"].values()))
    assert np.sum(z4 ** 2) == pytest.approx(0.75 + 0.01)
    assert np.sum(h.sq_lofo[0]) == pytest.approx(0.75 + 0.01)
    # the residuals keep their signs and proportions (scaled, not replaced)
    assert z4[0] == 0.0 and z4[1] > 0
    # e1's fold is not fooled by e4: its fold point is WOB 1.0 (e4 forbids 0.99), and
    # moving to 0.99 would cost the training events 900
    assert "lofo-e1" not in h.predicted_values
    assert np.sum(h.sq_lofo[1]) == pytest.approx(0.25 + 0.01)


def test_a_candidate_vanishes_in_the_folds_only_where_every_scoring_point_has_it_at_null():
    """A fit on top of the current model whose new candidate vanished in every fold lends the
    current model its held-out score; not when a fold's held-out events were scored at a
    point where the candidate acts (that score is not one of the current model)."""
    from dataclasses import replace

    from vadsim.fit.diagnosis.policy import vanishes_in_folds as _vanishes_in_folds
    from vadsim.fit.hypothesis_fit import HypothesisFit

    fit = HypothesisFit(keys=("anvil_friction",), nuisance_specs=(), point=(0.0,), k=1,
                        intervals=[], rss=1.0, n=10, heldout_rms=0.5, heldout_rms_lofo=0.5,
                        heldout_rms_block=0.5, score=0.0,
                        fold_values={"lofo-a": {"force": 0.0}, "block": {"force": 0.0}})
    assert _vanishes_in_folds(fit)
    assert not _vanishes_in_folds(replace(fit, predicted_values={"lofo-a": {"force": 50.0}}))
    assert _vanishes_in_folds(replace(fit, predicted_values={"lofo-a": {"force": 0.0}}))


class _Evaluator:
    """Stand-in for the comparison engine (the interface ``fit_hypothesis`` uses): one
    residual per event, zero at anvil friction 100 N/kg, and a flat one."""

    def __init__(self, eids) -> None:
        self.keys = {e: ["k_force", "k_flat"] for e in eids}
        self.n_evals = 0

    def evaluate(self, items, eids):
        out = {}
        for key, _change in items:
            force = 0.0 if key == "base" else key[1][0]
            for i, e in enumerate(eids):
                z = np.array([(force - 100.0) / (20.0 + i), 0.1])
                out[(key, e)] = EventEval(None, z, z)
                self.n_evals += 1
        return out


def test_a_fit_on_events_that_leave_no_flow_block_scores_its_flow_folds_alone():
    """The pair screen probes the events the base model fits worst; where those are the
    highest flows, the flow block keeps no training event and is dropped. The fit then scores
    on the leave-one-flow-out folds alone (its block RMS is NaN); with no fold at all it says
    so by name."""
    from vadsim.fit.hypothesis_fit import fit_hypothesis
    from vadsim.fit.stages import Stage

    eids = ["e08", "e09", "e10"]
    lofo = [(f"lofo {e}", [x for x in eids if x != e], [e]) for e in eids]
    hyp = Hypothesis(("anvil_friction",))
    stages = [Stage(grid=(0,), refine=(), maxfev=0, max_per_axis=5)]
    fit = fit_hypothesis(_Evaluator(eids), hyp, hyp.null_point(), stages, lofo, eids)
    assert fit.point == (100.0,)
    assert fit.heldout_rms == pytest.approx(fit.heldout_rms_lofo) and fit.heldout_rms < 0.2
    assert math.isnan(fit.heldout_rms_block)
    with pytest.raises(ValueError, match="anvil_friction: no fold has both"):
        fit_hypothesis(_Evaluator(eids), hyp, hyp.null_point(), stages, [], eids)


class _CorrelatedEvaluator:
    """Stand-in for the comparison engine whose events each repeat one residual ``copies``
    times: ``(force - target_e) / 20`` -- features of one record that share its error, as a
    folded waveform's phase bins do."""

    def __init__(self, targets: dict[str, float], copies: int, misfit: float = 0.0) -> None:
        self.targets, self.copies, self.misfit = targets, copies, misfit
        self.keys = {e: [f"k{i}" for i in range(copies + (misfit != 0.0))] for e in targets}
        self.n_evals = 0

    def evaluate(self, items, eids):
        out = {}
        for key, _change in items:
            force = 0.0 if key == "base" else key[1][0]
            for e in eids:
                z = np.full(self.copies, (force - self.targets[e]) / 20.0)
                if self.misfit:  # one more feature that no force fits
                    z = np.append(z, self.misfit)
                out[(key, e)] = EventEval(None, z, z)
                self.n_evals += 1
        return out


_TARGETS = dict(zip([f"e{i:02d}" for i in range(1, 9)],
                    [94.0, 104.0, 98.0, 108.0, 95.0, 103.0, 101.0, 97.0], strict=True))


def _t_interval(values) -> tuple[float, float]:
    """The textbook 95 % t-interval of a mean (what the jackknife of a mean must give)."""
    from scipy import stats

    v = np.asarray(values, dtype=float)
    half = stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size)
    return float(v.mean() - half), float(v.mean() + half)


def test_the_jackknife_interval_of_a_mean_is_the_t_interval():
    """Leaving out each of m values and re-estimating their mean gives the jackknife standard
    error s / sqrt(m) exactly; the interval is then mean +- t(0.975, m-1) s / sqrt(m)."""
    from vadsim.fit.intervals import jackknife_interval

    hyp = Hypothesis(("anvil_friction",))
    vals = list(_TARGETS.values())
    mean = float(np.mean(vals))
    folds = [((sum(vals) - v) / (len(vals) - 1),) for v in vals]
    (lo, hi), = jackknife_interval(hyp, (mean,), folds)
    assert (lo, hi) == pytest.approx(_t_interval(vals), abs=1e-9)
    # fewer than three folds: no spread to speak of, the point itself
    assert jackknife_interval(hyp, (mean,), folds[:2]) == [(mean, mean)]


def test_a_periodic_constant_jackknifes_across_the_period_edge():
    """theta0 near 0 with fold estimates on both sides of the edge (0.02 and pi - 0.02 rad):
    the spread is 0.02 rad, not half the period, and the interval is given unwrapped."""
    from vadsim.fit.intervals import jackknife_interval
    from vadsim.fit.nuisance import THETA0

    hyp = Hypothesis((), (THETA0,))
    folds = [(0.02,), (math.pi - 0.02,), (0.01,), (math.pi - 0.01,)]
    (lo, hi), = jackknife_interval(hyp, (0.0,), folds)
    assert -0.2 < lo < 0.0 < hi < 0.2
    # estimates spread over the whole period: the interval is the period
    spread = [(0.0,), (0.8,), (1.6,), (2.4,)]
    assert jackknife_interval(hyp, (1.2,), spread) == [(0.0, pytest.approx(math.pi))]


@pytest.mark.parametrize("copies", [1, 100])
def test_a_fit_interval_does_not_shrink_when_each_event_repeats_its_residual(copies):
    """A parameter's interval must reflect what the events say, not how many correlated
    features each carries: with every event's residual repeated 100 times neither the
    leave-one-flow-out jackknife nor the profile (its threshold per record) narrows. The
    fit's interval is the t-interval of the events' targets (the analytic answer for this
    least-squares mean) in both cases: the jackknife gives it, and the profile is the
    normal-theory interval ``mean +- 1.96 s / sqrt(m)`` inside it. Per feature (its old
    threshold, ``n`` the features) the profile narrowed 10-fold with 100 copies."""
    from vadsim.fit.hypothesis_fit import fit_hypothesis
    from vadsim.fit.intervals import profile_interval
    from vadsim.fit.stages import Stage

    eids = list(_TARGETS)
    lofo = [(f"flow {i}", [x for x in eids if x != e], [e]) for i, e in enumerate(eids)]
    hyp = Hypothesis(("anvil_friction",))
    ev = _CorrelatedEvaluator(_TARGETS, copies)
    stages = [Stage(grid=(0,), refine=(0,), maxfev=40)]
    # and points every 0.25 N/kg, so that the profile interval is not widened to far ones
    dense = [(float(f),) for f in np.arange(85.0, 115.0, 0.25)]
    fit = fit_hypothesis(ev, hyp, hyp.null_point(), stages, lofo, eids, alternatives=dense)
    assert fit.point[0] == pytest.approx(np.mean(list(_TARGETS.values())), abs=0.05)
    lo, hi = fit.intervals[0]
    t_lo, t_hi = _t_interval(list(_TARGETS.values()))
    assert (lo, hi) == pytest.approx((t_lo, t_hi), abs=0.05)
    pts = sorted(fit.point_rss)
    rss = np.array([fit.point_rss[p] for p in pts])
    values = np.array(list(_TARGETS.values()))
    half = 1.96 * values.std(ddof=1) / math.sqrt(values.size)
    (p_lo, p_hi), = profile_interval(hyp, pts, rss, len(eids))
    # the profile lies between evaluated points, 0.25 N/kg apart
    assert (p_lo, p_hi) == pytest.approx((values.mean() - half, values.mean() + half), abs=0.26)
    assert t_lo <= p_lo and p_hi <= t_hi
    (f_lo, f_hi), = profile_interval(hyp, pts, rss, fit.n)  # per feature
    if copies == 100:
        assert f_hi - f_lo < 0.2 * (p_hi - p_lo)


def test_a_misfit_every_event_shares_widens_the_interval_beyond_the_jackknife():
    """A feature of every event that no force fits (0.5 spreads each) leaves the estimate and
    its jackknife where they were, but the model is worse than its events' scatter says:
    the interval is the profile's with the record as its unit, ``RSS_min`` 0.41 + 8 x 0.25,
    ``s^2`` = that / 7, ``|force - mean| <= sqrt(3.84 s^2 x 400 / 8)`` = 8.1 N/kg, twice the
    t-interval's 4.05."""
    from vadsim.fit.hypothesis_fit import fit_hypothesis
    from vadsim.fit.stages import Stage

    eids = list(_TARGETS)
    lofo = [(f"flow {i}", [x for x in eids if x != e], [e]) for i, e in enumerate(eids)]
    hyp = Hypothesis(("anvil_friction",))
    values = np.array(list(_TARGETS.values()))
    dense = [(float(f),) for f in np.arange(85.0, 115.0, 0.25)]
    fit = fit_hypothesis(_CorrelatedEvaluator(_TARGETS, 1, misfit=0.5), hyp, hyp.null_point(),
                         [Stage(grid=(0,), refine=(0,), maxfev=40)], lofo, eids,
                         alternatives=dense)
    assert fit.point[0] == pytest.approx(values.mean(), abs=0.05)
    rss_min = float(np.sum((values - values.mean()) ** 2) / 400 + 8 * 0.25)
    half = math.sqrt(3.84 * rss_min / 7 * 400 / 8)
    lo, hi = fit.intervals[0]
    assert (lo, hi) == pytest.approx((values.mean() - half, values.mean() + half), abs=0.26)
    t_lo, t_hi = _t_interval(values)
    assert hi - lo > 1.8 * (t_hi - t_lo)


def test_a_profile_reaches_as_far_on_the_side_its_search_left_unexplored():
    """A refinement walked up one side of the optimum (100 N/kg; cost 10 + (x - 100)^2 at
    100-104 every 0.5) and evaluated one point just below it with the other coordinates off
    (cost 100). The threshold, 10 + 3.84 x 10 / 7 per record, keeps 100-102 inside; above,
    the interval ends at the next evaluated value, 102.5; below it reaches as far as the
    other side's inside, 98, not the lone point at 99.5."""
    from vadsim.fit.intervals import profile_interval

    hyp = Hypothesis(("anvil_friction",))
    xs = [*np.arange(100.0, 104.01, 0.5), 99.5]
    rss = np.array([10.0 + (x - 100.0) ** 2 if x >= 100.0 else 100.0 for x in xs])
    (lo, hi), = profile_interval(hyp, [(float(x),) for x in xs], rss, 8)
    assert (lo, hi) == pytest.approx((98.0, 102.5))
    # a periodic constant keeps the evaluated ends: theta0's 0 and pi are one point
    hyp = Hypothesis((), DEFAULT_NUISANCE[1:])
    (lo, hi), = profile_interval(hyp, [(float(x) / 100,) for x in xs], rss, 8)
    assert (lo, hi) == pytest.approx((0.995, 1.025))


class _TwoParameterEvaluator:
    """Stand-in engine for anvil friction with the WOB scale: each event pulls the force
    towards ``a_e`` and the WOB scale towards ``b_e``, one residual each, so every fold's
    optimum is the mean of its training events' targets."""

    def __init__(self, a: dict[str, float], b: dict[str, float]) -> None:
        self.a, self.b = a, b
        self.keys = {e: ["force", "wob"] for e in a}
        self.n_evals = 0

    def evaluate(self, items, eids):
        out = {}
        for key, _change in items:
            force, wob = (0.0, 1.0) if key == "base" else key[1]
            for e in eids:
                z = np.array([(force - self.a[e]) / 20.0, (wob - self.b[e]) / 0.02])
                out[(key, e)] = EventEval(None, z, z)
                self.n_evals += 1
        return out


def test_two_coordinates_jackknife_between_the_points_the_fit_evaluated():
    """With two coordinates refined by Nelder-Mead, a fold's own optimum lies between the
    evaluated points (here up to 1.7 N/kg from the nearest, about the folds' whole spread).
    The jackknife reads it from a quadratic through them (no new run): every fold's
    estimate is the mean of its training targets (the analytic optimum), the jackknife
    interval as wide as the t-interval, and the fit's interval contains it."""
    from vadsim.fit.hypothesis import HypothesisCosts
    from vadsim.fit.hypothesis_fit import fit_hypothesis
    from vadsim.fit.intervals import fold_estimates, jackknife_interval
    from vadsim.fit.nuisance import WOB_SCALE
    from vadsim.fit.stages import Stage

    eids = list(_TARGETS)
    b = dict(zip(eids, [0.97, 1.01, 0.99, 1.04, 0.95, 1.02, 1.0, 0.98], strict=True))
    lofo = [(f"flow {i}", [x for x in eids if x != e], [e]) for i, e in enumerate(eids)]
    hyp = Hypothesis(("anvil_friction",), (WOB_SCALE,))
    ev = _TwoParameterEvaluator(_TARGETS, b)
    stages = [Stage(grid=(0, 1), refine=(0, 1), maxfev=20)]
    fit = fit_hypothesis(ev, hyp, hyp.null_point(), stages, lofo, eids)
    points = list(fit.point_rss)
    rss = HypothesisCosts(ev, hyp, eids).event_rss(points)
    trains = [rss[:, [eids.index(x) for x in train]].sum(axis=1) for _n, train, _t in lofo]
    folds = [tuple(fit.fold_values[name].values()) for name, _tr, _t in lofo]
    est = fold_estimates(hyp, fit.point, points, trains, folds)
    exact = [((sum(_TARGETS.values()) - _TARGETS[e]) / 7, (sum(b.values()) - b[e]) / 7)
             for e in eids]
    assert np.array(est) == pytest.approx(np.array(exact), abs=1e-3)
    for j, targets in enumerate((_TARGETS, b)):
        t_lo, t_hi = _t_interval(list(targets.values()))
        lo, hi = jackknife_interval(hyp, fit.point, est)[j]
        # the t-interval's width, centred on the full fit's point
        assert hi - lo == pytest.approx(t_hi - t_lo, rel=1e-3)
        assert (lo + hi) / 2 == pytest.approx(fit.point[j], rel=1e-5)
        assert fit.intervals[j][0] <= lo and fit.intervals[j][1] >= hi
