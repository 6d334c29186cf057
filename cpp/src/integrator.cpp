#include "vadsim/integrator.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "vadsim/contact_tracker.hpp"
#include "vadsim/cvode_solver.hpp"
#include "vadsim/recorder.hpp"

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
  if (opts.initial_state) {
    y0 = *opts.initial_state;
    y0.head<kDof>() -= model.static_positions();
    for (int i = 0; i < kState; ++i) {
      if (!(std::abs(y0[i]) <= 1e3)) {
        std::ostringstream os;
        os << "option initial_state[" << i << "] = " << (*opts.initial_state)[i]
           << (i < kDof ? " m is " : " m/s is ") << y0[i]
           << (i < kDof ? " m from the static state: must be within 1000 m"
                        : " m/s: must be within 1000 m/s");
        throw std::invalid_argument(os.str());
      }
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
  /// @brief Grid points at t_end, summary means, statistics and the final state.
  void finish();
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
}

void EventLoop::run() {
  const State y0 = initial_displacements(model_, opts_);
  contacts_.start(y0);
  restart(0.0, y0);
  while (true) {
    const double t_prev = t_;
    double tret = t_;
    const int flag = take_step(tret);
    if (flag != CV_ROOT_RETURN && restart_at_missed_crossing(t_prev, tret)) continue;
    recorder_.record_until(tret, segment_, contacts_.modes());
    check_progress(tret);
    t_ = tret;
    if (flag == CV_TSTOP_RETURN || t_ >= horizon_.t_end) break;
    if (flag == CV_ROOT_RETURN) restart_at_roots();
  }
  finish();
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
  recorder_.record_until(c.t, segment_, contacts_.modes());  // up to the switch, old modes
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
