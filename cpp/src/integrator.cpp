#include "vadsim/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>
#include <sstream>
#include <string>

#include "vadsim/contact_tracker.hpp"
#include "vadsim/cvode_solver.hpp"
#include "vadsim/recorder.hpp"
#include "vadsim/steady_state.hpp"

namespace vadsim {

namespace {

/// @brief What CVODE's callbacks need: the const model, the flow, and the tracker that owns
/// the contact modes of the running segment.
struct CallbackData {
  const Model* model;
  double flow_gpm;
  const ContactTracker* contacts;
};

int rhs_cb(sunrealtype t, N_Vector y, N_Vector ydot, void* data) {
  const auto* w = static_cast<const CallbackData*>(data);
  Eigen::Map<const State> ym(NV_DATA_S(y));
  Eigen::Map<State> yd(NV_DATA_S(ydot));
  w->model->rhs(t, w->flow_gpm, ym, w->contacts->modes(), yd);
  return yd.allFinite() ? 0 : 1;  // recoverable: CVODE retries with a smaller step
}

int jac_cb(sunrealtype t, N_Vector y, N_Vector, SUNMatrix J, void* data, N_Vector, N_Vector,
           N_Vector) {
  const auto* w = static_cast<const CallbackData*>(data);
  Eigen::Map<const State> ym(NV_DATA_S(y));
  Eigen::Map<Mat14> Jm(SM_DATA_D(J));
  w->model->jacobian(t, w->flow_gpm, ym, w->contacts->modes(), Jm);
  return 0;
}

int root_cb(sunrealtype, N_Vector y, sunrealtype* g, void* data) {
  const auto* w = static_cast<const CallbackData*>(data);
  w->contacts->roots(Eigen::Map<const State>(NV_DATA_S(y)), g);
  return 0;
}

/// @brief The segment CVODE is integrating: its start state, then CVODE's interpolant.
class Segment final : public Trajectory {
 public:
  explicit Segment(const CvodeSolver& solver) : solver_(solver) {}
  void begin(double t0, const State& y0) {
    t0_ = t0;
    y0_ = y0;
  }
  double t0() const { return t0_; }
  Eigen::Map<const State> interpolate(double t) const override {
    solver_.interpolate(t, solver_.work());
    return Eigen::Map<const State>(NV_DATA_S(solver_.work()));
  }
  Eigen::Map<const State> sample(double t) const override {
    return t <= t0_ ? Eigen::Map<const State>(y0_.data()) : interpolate(t);
  }

 private:
  const CvodeSolver& solver_;
  double t0_ = 0;
  State y0_ = State::Zero();
};

/// @brief The initial state in displacements from the static equilibrium; throws
/// std::invalid_argument for one beyond a kilometre or 1000 m/s (the tool's length bound).
State initial_displacements(const Model& model, const RunOptions& opts) {
  State y0 = State::Zero();
  const char* name = "initial_state";
  if (opts.initial_state) {
    y0 = *opts.initial_state;
    y0.head<kDof>() -= model.static_positions();
  } else if (opts.initial_displacement) {
    y0 = *opts.initial_displacement;
    name = "initial_displacement";
  }
  for (int i = 0; i < kState; ++i) {
    if (!(std::abs(y0[i]) <= 1e3)) {
      const State& given = opts.initial_state ? *opts.initial_state : *opts.initial_displacement;
      std::ostringstream os;
      os << "option " << name << "[" << i << "] = " << given[i]
         << (i < kDof ? " m is " : " m/s is ") << y0[i]
         << (i < kDof ? " m from the static state: must be within 1000 m"
                      : " m/s: must be within 1000 m/s");
      throw std::invalid_argument(os.str());
    }
  }
  return y0;
}

/// @brief CVODE's absolute tolerances: atol on displacements, atol * 1000 1/s on velocities.
State absolute_tolerances(const RunOptions& opts) {
  State atol;
  atol.head<kDof>().setConstant(opts.atol);
  atol.tail<kDof>().setConstant(opts.atol * 1e3);
  return atol;
}

/// @brief One run: steps CVODE, and at every contact switch records it and restarts.
class EventLoop {
 public:
  /// @brief Sizes the recorder and creates CVODE; throws before any step on bad input.
  EventLoop(const Model& model, const RunOptions& opts, const InterruptCheck& interrupted,
            RunResult& r);
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;
  /// @brief The whole run: step, record, switch contacts at events, restart, until t_end.
  void run();

 private:
  /// @brief One CVODE step within the run's step budget; every kInterruptCheckEvery steps,
  /// asks the interrupt check (throws Interrupted when it says stop).
  int take_step(double& tret);
  /// @brief After a step without roots: if a contact switched unreported inside it, record
  /// up to the switch, apply it and restart there (true); else false.
  bool restart_at_missed_crossing(double t_prev, double tret);
  /// @brief At a root return: apply the reported switches and restart (event budget checked).
  void restart_at_roots();
  /// @brief Throws when steps stop advancing time (contact chatter).
  void check_progress(double tret);
  /// @brief Start a new smooth segment at (t, y).
  void restart(double t, const State& y);
  /// @brief Record every grid point up to tlim from the current segment, then let the
  /// steady-state engine see what was recorded.
  void record_until(double tlim);
  /// @brief New Poincare sections: look for a period, start or close an orbit's capture; keep
  /// the piece (t_lo, tlim] of the current step while capturing.
  void watch_steady_state(double t_lo, double tlim);
  /// @brief Whether the captured orbit closed: its last section repeats its first and its
  /// events repeat those of the orbit before, surface by surface.
  bool orbit_closes() const;
  /// @brief Grid points at t_end, summary means, statistics and the final state.
  void finish();
  /// @brief The rest of the run from the closed orbit (synthesize_rest), then as finish().
  void finish_from_orbit();
  State current_state() const { return Eigen::Map<const State>(NV_DATA_S(solver_.y())); }

  const Model& model_;
  const RunOptions& opts_;
  const InterruptCheck& interrupted_;
  RunResult& r_;
  const Horizon horizon_;
  const long max_steps_;
  const long max_events_;
  Recorder recorder_;
  ContactTracker contacts_;
  CallbackData callbacks_;
  CvodeSolver solver_;
  Segment segment_;
  double t_ = 0;
  long calls_ = 0, stalled_ = 0;
  // The steady-state engine (RunOptions::steady == Auto).
  std::optional<PeriodDetector> detector_;
  std::optional<Orbit> orbit_;   ///< the orbit being captured
  long orbit_k0_ = 0;            ///< its first section
  int orbit_n_ = 0;              ///< its period in cycles
  bool closing_repeats_ = false; ///< its closing section repeated its first
  bool ready_ = false;           ///< an orbit closed: the rest is built from it
  long sections_seen_ = 0;
  double recorded_to_ = 0;
};

EventLoop::EventLoop(const Model& model, const RunOptions& opts,
                     const InterruptCheck& interrupted, RunResult& r)
    : model_(model),
      opts_(opts),
      interrupted_(interrupted),
      r_(r),
      horizon_(model.params(), opts),
      max_steps_(opts.step_budget()),
      max_events_(opts.event_budget()),
      recorder_(model, opts, horizon_, r),
      contacts_(model, opts.flow_gpm, r.events),
      callbacks_{&model, opts.flow_gpm, &contacts_},
      solver_(contacts_.n_roots(), opts.method, opts.rtol, absolute_tolerances(opts),
              &callbacks_, rhs_cb, jac_cb, root_cb),
      segment_(solver_) {
  r_.flow_gpm = opts.flow_gpm;
  r_.f_exc_hz = horizon_.f_exc_hz;
  r_.t_end = horizon_.t_end;
  if (opts.max_step > 0) solver_.set_max_step(opts.max_step);
  r_.x_static = model.static_positions();
  r_.steady.enabled = opts.steady == Steady::Auto;
  r_.steady.tolerance = opts.steady_tolerance();
  if (r_.steady.enabled) detector_.emplace(opts, absolute_tolerances(opts));
}

void EventLoop::run() {
  const State y0 = initial_displacements(model_, opts_);
  contacts_.start(y0);
  restart(0.0, y0);
  while (!ready_) {
    const double t_prev = t_;
    double tret = t_;
    const int flag = take_step(tret);
    if (detector_) detector_->observe(current_state());
    if (flag != CV_ROOT_RETURN && restart_at_missed_crossing(t_prev, tret)) continue;
    record_until(tret);
    check_progress(tret);
    t_ = tret;
    if (flag == CV_TSTOP_RETURN || t_ >= horizon_.t_end) {
      ready_ = false;  // the run reached its end: nothing is left to build
      break;
    }
    if (flag == CV_ROOT_RETURN) restart_at_roots();
  }
  if (ready_)
    finish_from_orbit();
  else
    finish();
}

void EventLoop::record_until(double tlim) {
  const double t_lo = recorded_to_;
  recorder_.record_until(tlim, segment_, contacts_.modes());
  recorded_to_ = tlim;
  if (detector_) watch_steady_state(t_lo, tlim);
}

void EventLoop::watch_steady_state(double t_lo, double tlim) {
  const Vec7& xs = model_.static_positions();
  while (sections_seen_ < recorder_.sections_recorded()) {
    const long k = sections_seen_++;
    State y = r_.poincare.row(k).transpose();
    y.head<kDof>() -= xs;
    const int n = detector_->add_section(k, y);
    if (orbit_) {
      if (k == orbit_k0_ + orbit_n_) closing_repeats_ = detector_->repeats(k, orbit_n_, y);
      continue;
    }
    const double t_k = r_.poincare_t[k];
    // Worth it only if the orbit closes well before the end of the run.
    if (n > 0 && t_k + (n + 1) * horizon_.period < horizon_.t_end) {
      orbit_.emplace(t_k, n * horizon_.period);
      orbit_k0_ = k;
      orbit_n_ = n;
      closing_repeats_ = false;
    }
  }
  if (!orbit_) return;
  CvodeSolver::StepInterpolant step;
  if (!solver_.last_interpolant(step)) {  // no copy of the steps can be kept: run literally
    orbit_.reset();
    detector_.reset();
    return;
  }
  orbit_->add(t_lo, tlim, step, contacts_.modes());
  if (!orbit_->closed() || sections_seen_ <= orbit_k0_ + orbit_n_) return;
  if (closing_repeats_ && tlim < horizon_.t_end && orbit_closes()) {
    ready_ = true;
  } else {
    orbit_.reset();
  }
}

bool EventLoop::orbit_closes() const {
  const double t0 = orbit_->t0(), period = orbit_->period();
  const double slack = r_.steady.tolerance * period;
  std::vector<const ContactEvent*> before, during;
  for (const auto& e : r_.events) {
    if (e.t > t0 - period && e.t <= t0) before.push_back(&e);
    if (e.t > t0 && e.t <= t0 + period) during.push_back(&e);
  }
  if (before.size() != during.size()) return false;
  for (std::size_t i = 0; i < before.size(); ++i) {
    const ContactEvent &a = *before[i], &b = *during[i];
    if (a.surface != b.surface || a.kind != b.kind) return false;
    if (std::abs(b.t - a.t - period) > slack) return false;
  }
  return true;
}

int EventLoop::take_step(double& tret) {
  const int flag = solver_.step(horizon_.t_end, tret);
  if (++calls_ > max_steps_) {
    throw SolverError("CVode", tret, 0,
                      "step budget max_steps = " + std::to_string(max_steps_) +
                          " exhausted: the run is too stiff or chatters");
  }
  if (interrupted_ && calls_ % kInterruptCheckEvery == 0 && interrupted_())
    throw Interrupted(tret, horizon_.t_end, calls_);
  return flag;
}

bool EventLoop::restart_at_missed_crossing(double t_prev, double tret) {
  const MissedCrossing c = contacts_.find_missed(
      t_prev, tret, Eigen::Map<const State>(NV_DATA_S(solver_.y())), segment_);
  if (c.surface < 0) return false;
  const State yx = segment_.interpolate(c.t);  // a copy: recording reuses the scratch vector
  record_until(c.t);  // up to the switch, old modes
  contacts_.apply_missed(c, yx);
  restart(c.t, yx);
  return true;
}

void EventLoop::restart_at_roots() {
  const State yr = current_state();
  contacts_.apply_roots(solver_.roots_found(), t_, yr);
  if (static_cast<long>(r_.events.size()) > max_events_) {
    throw SolverError("root-finding", t_, 0,
                      "more than max_events = " + std::to_string(max_events_) +
                          " contact events: the contacts chatter");
  }
  restart(t_, yr);
}

void EventLoop::check_progress(double tret) {
  stalled_ = (tret - t_ <= 1e-12 * std::max(1.0, std::abs(t_))) ? stalled_ + 1 : 0;
  if (stalled_ > 1000) {
    throw SolverError("CVode", tret, 0, "no progress in time over 1000 steps (contact chatter)");
  }
}

void EventLoop::restart(double t, const State& y) {
  segment_.begin(t, y);
  t_ = t;
  solver_.restart(t, y, horizon_.t_end);
}

void EventLoop::finish() {
  // Points at exactly t_end (rounding) that the last step did not reach.
  const State ye = current_state();
  const double t_last = horizon_.t_end * (1 + 1e-12);
  segment_.begin(t_last, ye);
  recorder_.record_until(t_last, segment_, contacts_.modes());
  recorder_.finish();
  r_.stats = solver_.stats();
  r_.y_end.head<kDof>() = model_.static_positions() + ye.head<kDof>();
  r_.y_end.tail<kDof>() = ye.tail<kDof>();
  r_.steady.stopped_cycle = horizon_.t_end / horizon_.period;
  r_.steady.residual = std::numeric_limits<double>::quiet_NaN();
}

void EventLoop::finish_from_orbit() {
  Orbit& orbit = *orbit_;
  orbit.take_events(r_.events);
  auto& info = r_.steady;
  info.period = orbit_n_;
  info.detected_cycle = static_cast<double>(orbit_k0_);
  info.stopped_cycle = recorded_to_ / horizon_.period;
  info.residual = detector_->residual();
  info.window_on_orbit = horizon_.t_window >= orbit.t0() - 1e-12 * horizon_.t_end;
  if (info.window_on_orbit && opts_.orbit_replaces_window && opts_.record == Record::Window)
    recorder_.drop_output();
  // Events integrated past the orbit's end are its first ones again: not replayed twice.
  long integrated_after = 0;
  for (const auto& e : r_.events) integrated_after += e.t > orbit.t0() + orbit.period();
  synthesize_rest(model_, opts_, horizon_, orbit, recorded_to_, integrated_after, recorder_, r_);
  recorder_.finish();
  r_.stats = solver_.stats();
}

}  // namespace

RunResult simulate(const Model& model, const RunOptions& opts,
                   const InterruptCheck& interrupted) {
  opts.validate(model.params());
  initial_displacements(model, opts);  // checked before any allocation
  RunResult r;
  EventLoop(model, opts, interrupted, r).run();
  return r;
}

}  // namespace vadsim
