#include "vadsim/integrator.hpp"

#include <cmath>
#include <sstream>

#include "vadsim/cvode_solver.hpp"

namespace vadsim {

namespace {

/// @brief What the CVODE callbacks need: the const model, the flow and the current modes.
struct Workspace {
  const Model* model;
  double flow;
  Modes modes;
  int n_roots;
};

int rhs_cb(sunrealtype t, N_Vector y, N_Vector ydot, void* data) {
  const auto* w = static_cast<const Workspace*>(data);
  Eigen::Map<const State> ym(NV_DATA_S(y));
  Eigen::Map<State> yd(NV_DATA_S(ydot));
  w->model->rhs(t, w->flow, ym, w->modes, yd);
  return yd.allFinite() ? 0 : 1;  // recoverable: CVODE retries with a smaller step
}

int jac_cb(sunrealtype t, N_Vector y, N_Vector, SUNMatrix J, void* data, N_Vector, N_Vector,
           N_Vector) {
  const auto* w = static_cast<const Workspace*>(data);
  Eigen::Map<const State> ym(NV_DATA_S(y));
  Eigen::Map<Mat14> Jm(SM_DATA_D(J));
  w->model->jacobian(t, w->flow, ym, w->modes, Jm);
  return 0;
}

int root_cb(sunrealtype, N_Vector y, sunrealtype* g, void* data) {
  const auto* w = static_cast<const Workspace*>(data);
  Eigen::Map<const State> ym(NV_DATA_S(y));
  for (int s = 0; s < kSurfaces; ++s) g[s] = w->model->indentation(s, ym);
  for (int s = 0; 2 * kSurfaces <= w->n_roots && s < kSurfaces; ++s) {
    const bool live = w->model->pushes_only(s) && w->modes[s] != ContactMode::Open;
    g[kSurfaces + s] = live ? w->model->push_indicator(s, ym) : 1.0;
  }
  return 0;
}

/// @brief A uniform time grid that is filled as the integration passes it.
struct Grid {
  double t0 = 0, dt = 1;
  long n = 0, next = 0;
  double time(long k) const { return t0 + static_cast<double>(k) * dt; }
  bool pending(double tlim) const { return next < n && time(next) <= tlim; }
};

}  // namespace

RunResult simulate(const Model& model, const RunOptions& opts) {
  opts.validate();
  const Params& p = model.params();
  RunResult r;
  r.flow_gpm = opts.flow_gpm;
  r.f_exc_hz = p.excitation_hz(opts.flow_gpm);
  const double period = 1.0 / r.f_exc_hz;
  r.t_end = opts.cycles * period;
  const double t_w0 = (opts.cycles - opts.analyse_cycles) * period;
  // A stored sample is 28 doubles (x, v, a, 5 forces, F_H, t): 2e7 samples are 4.5 GB,
  // beyond which a request is a mistake (this machine has 24 GB), not an analysis.
  const double samples_limit = 2e7;
  auto grid_count = [&](double span, double rate, const char* name, bool stored) {
    const double n = std::floor(span * rate * (1 + 1e-12)) + 1;
    if (stored && n > samples_limit)
      fail_option(name, rate, "asks for more than 2e7 stored samples (4.5 GB): lower the rate "
                              "or record only the window");
    if (n > 1e10) fail_option(name, rate, "asks for more than 1e10 samples");
    return static_cast<long>(n);
  };

  // Output grid, summary grid and Poincare section.
  Grid out, sum, sec;
  if (opts.record != Record::None && opts.output_rate_hz > 0) {
    out.t0 = (opts.record == Record::Window) ? t_w0 : 0.0;
    out.dt = 1.0 / opts.output_rate_hz;
    out.n = grid_count(r.t_end - out.t0, opts.output_rate_hz, "output_rate_hz", true);
  }
  sum.t0 = t_w0;
  sum.dt = 1.0 / opts.summary_rate_hz;
  sum.n = std::max(1L, grid_count(r.t_end - t_w0, opts.summary_rate_hz, "summary_rate_hz", false) - 1);
  sec.dt = period;
  sec.n = static_cast<long>(std::floor(opts.cycles * (1 + 1e-12))) + 1;

  r.t.resize(out.n);
  r.x.resize(out.n, kDof);
  r.v.resize(out.n, kDof);
  r.a.resize(out.n, kDof);
  r.fc.resize(out.n, kSurfaces);
  r.fh.resize(out.n);
  r.poincare_t.resize(sec.n);
  r.poincare.resize(sec.n, kState);
  auto& sm = r.summary;
  sm.t0 = t_w0;
  sm.t1 = r.t_end;
  sm.rate_hz = opts.summary_rate_hz;
  sm.samples = sum.n;
  const double per_window = opts.peak_window_s * opts.summary_rate_hz;
  const long n_windows =
      static_cast<long>(std::floor((r.t_end - t_w0) / opts.peak_window_s + 1e-9));
  sm.window_peaks = RowMat7::Zero(std::max(0L, n_windows), kDof);

  // Initial state in displacements from the static equilibrium.
  const Vec7& xs = model.static_positions();
  State y0 = State::Zero();
  if (opts.initial_state) {
    y0 = *opts.initial_state;
    y0.head<kDof>() -= xs;
  }

  Workspace w{&model, opts.flow_gpm, {}, kSurfaces};
  for (int s = 0; s < kSurfaces; ++s) {
    if (model.pushes_only(s)) w.n_roots = 2 * kSurfaces;
    w.modes[s] = model.indentation(s, y0) > 0 ? ContactMode::Pushing : ContactMode::Open;
  }
  for (int s = 0; s < kSurfaces; ++s) w.modes[s] = model.mode_at(s, y0, 0.0, opts.flow_gpm, w.modes);

  State atol;
  atol.head<kDof>().setConstant(opts.atol);
  atol.tail<kDof>().setConstant(opts.atol * 1e3);
  CvodeSolver solver(w.n_roots, opts.method, opts.rtol, atol, &w, rhs_cb, jac_cb,
                     root_cb);
  if (opts.max_step > 0) solver.set_max_step(opts.max_step);

  const long max_events = opts.max_events > 0
                              ? opts.max_events
                              : static_cast<long>(200 * std::ceil(opts.cycles)) + 1000;
  Evaluation ev;
  State yk;
  N_Vector tmp = solver.work();

  // Fill every grid point up to tlim with the current segment's interpolant (or y_at when the
  // point is the segment's own start, where no step exists yet to interpolate).
  auto emit = [&](double tlim, double t_start, const State& y_start) {
    auto sample = [&](double t) {
      if (t <= t_start) {
        yk = y_start;
      } else {
        solver.interpolate(t, tmp);
        yk = Eigen::Map<const State>(NV_DATA_S(tmp));
      }
      model.evaluate(t, opts.flow_gpm, yk, w.modes, ev);
    };
    while (sec.pending(tlim)) {
      const double t = sec.time(sec.next);
      sample(t);
      r.poincare_t[sec.next] = t;
      r.poincare.row(sec.next).head<kDof>() = (xs + yk.head<kDof>()).transpose();
      r.poincare.row(sec.next).tail<kDof>() = yk.tail<kDof>().transpose();
      ++sec.next;
    }
    while (out.pending(tlim)) {
      const long k = out.next++;
      const double t = out.time(k);
      sample(t);
      r.t[k] = t;
      r.x.row(k) = (xs + yk.head<kDof>()).transpose();
      r.v.row(k) = yk.tail<kDof>().transpose();
      r.a.row(k) = ev.acc.transpose();
      for (int s = 0; s < kSurfaces; ++s) r.fc(k, s) = ev.fc[s];
      r.fh[k] = ev.fh;
    }
    while (sum.pending(tlim)) {
      const long k = sum.next++;
      sample(sum.time(k));
      const double fi = ev.fc[kImpact];
      sm.impulse_mean += fi;
      sm.impulse_pos += fi > 0 ? fi : 0.0;
      const long win = static_cast<long>(std::floor(k / per_window + 1e-9));
      if (win < n_windows) {
        for (int i = 0; i < kDof; ++i)
          sm.window_peaks(win, i) = std::max(sm.window_peaks(win, i), std::abs(ev.acc[i]));
      }
    }
  };

  // A contact whose indentation is exactly zero when CVODE restarts has its root function
  // switched off until it moves away from zero, and CVODE then turns it back on without
  // reporting the crossing (e.g. a bit resting on the rock with zero force, pushed by the
  // anvil's first impact). Two guards: such contacts get their mode from mode_at() at every
  // restart, and after every step each mode is checked against the sign of its indentation,
  // a disagreement being located by bisection on CVODE's interpolant.
  const double tiny = 1e-13 * p.l0;
  auto record_switch = [&](int s, ContactMode next, double te, const State& y) {
    const ContactMode prev = w.modes[s];
    if (next == prev) return;
    EventKind kind;
    if (prev == ContactMode::Open) kind = EventKind::Onset;
    else if (next == ContactMode::Open) kind = EventKind::Release;
    else kind = (next == ContactMode::Lifted) ? EventKind::Lift : EventKind::Relatch;
    w.modes[s] = next;
    r.events.push_back({te, s, kind, model.indentation_rate(s, y)});
  };
  auto resolve_boundaries = [&](double te, const State& y, const int* skip) {
    for (int s = 0; s < kSurfaces; ++s) {
      if ((skip && skip[s] != 0) || std::abs(model.indentation(s, y)) > tiny) continue;
      record_switch(s, model.mode_at(s, y, te, opts.flow_gpm, w.modes), te, y);
    }
  };
  auto contradicts = [&](int s, const Eigen::Ref<const State>& y) {
    const double d = model.indentation(s, y);
    return (w.modes[s] == ContactMode::Open) ? d > tiny : d < -tiny;
  };
  auto state_at = [&](double te) {
    solver.interpolate(te, tmp);
    return State(Eigen::Map<const State>(NV_DATA_S(tmp)));
  };

  double t = 0.0;
  State y_seg = y0;
  double t_seg = 0.0;
  solver.restart(0.0, y0, r.t_end);
  long calls = 0, stalled = 0;
  while (true) {
    const double t_prev = t;
    double tret = t;
    const int flag = solver.step(r.t_end, tret);
    if (++calls > opts.max_steps) {
      throw SolverError("CVode", tret, 0,
                        "step budget max_steps = " + std::to_string(opts.max_steps) +
                            " exhausted: the run is too stiff or chatters");
    }
    if (flag != CV_ROOT_RETURN) {
      Eigen::Map<const State> yc(NV_DATA_S(solver.y()));
      int missed = -1;
      double t_cross = tret;
      for (int s = 0; s < kSurfaces; ++s) {
        if (!contradicts(s, yc)) continue;
        double lo = t_prev, hi = tret;  // consistent at lo, not at hi
        for (int it = 0; it < 200 && hi - lo > 4e-16 * std::max(1.0, std::abs(hi)); ++it) {
          const double mid = 0.5 * (lo + hi);
          (contradicts(s, state_at(mid)) ? hi : lo) = mid;
        }
        if (hi < t_cross || missed < 0) {
          missed = s;
          t_cross = hi;
        }
      }
      if (missed >= 0) {
        const State yx = state_at(t_cross);
        emit(t_cross, t_seg, y_seg);
        record_switch(missed,
                      w.modes[missed] != ContactMode::Open ? ContactMode::Open
                      : (model.pushes_only(missed) && model.push_indicator(missed, yx) < 0)
                          ? ContactMode::Lifted
                          : ContactMode::Pushing,
                      t_cross, yx);
        resolve_boundaries(t_cross, yx, nullptr);
        y_seg = yx;
        t = t_seg = t_cross;
        solver.restart(t, y_seg, r.t_end);
        continue;
      }
    }
    emit(tret, t_seg, y_seg);
    stalled = (tret - t <= 1e-12 * std::max(1.0, std::abs(t))) ? stalled + 1 : 0;
    if (stalled > 1000) {
      throw SolverError("CVode", tret, 0, "no progress in time over 1000 steps (contact chatter)");
    }
    t = tret;
    if (flag == CV_TSTOP_RETURN || t >= r.t_end) break;
    if (flag != CV_ROOT_RETURN) continue;

    const State yr = Eigen::Map<const State>(NV_DATA_S(solver.y()));
    const int* found = solver.roots_found();
    int handled[kSurfaces] = {};
    for (int s = 0; s < kSurfaces; ++s) {
      const int dir_d = found[s];
      const int dir_f = (w.n_roots > kSurfaces) ? found[kSurfaces + s] : 0;
      if (dir_d == 0 && dir_f == 0) continue;
      handled[s] = 1;
      if (dir_d > 0 && w.modes[s] == ContactMode::Open) {
        record_switch(s,
                      (model.pushes_only(s) && model.push_indicator(s, yr) < 0)
                          ? ContactMode::Lifted
                          : ContactMode::Pushing,
                      t, yr);
      } else if (dir_d < 0 && w.modes[s] != ContactMode::Open) {
        record_switch(s, ContactMode::Open, t, yr);
      } else if (dir_f < 0 && w.modes[s] == ContactMode::Pushing) {
        record_switch(s, ContactMode::Lifted, t, yr);
      } else if (dir_f > 0 && w.modes[s] == ContactMode::Lifted) {
        record_switch(s, ContactMode::Pushing, t, yr);
      }
    }
    resolve_boundaries(t, yr, handled);
    if (static_cast<long>(r.events.size()) > max_events) {
      throw SolverError("root-finding", t, 0,
                        "more than max_events = " + std::to_string(max_events) +
                            " contact events: the contacts chatter");
    }
    y_seg = yr;
    t_seg = t;
    solver.restart(t, y_seg, r.t_end);
  }
  // Points at exactly t_end (rounding) that the last step did not reach.
  Eigen::Map<const State> ye(NV_DATA_S(solver.y()));
  y_seg = ye;
  emit(r.t_end * (1 + 1e-12), r.t_end * (1 + 1e-12), y_seg);

  for (const auto& e : r.events)
    if (e.kind == EventKind::Onset && e.t >= t_w0) sm.onsets[e.surface] += 1;
  if (sm.samples > 0) {
    sm.impulse_mean /= static_cast<double>(sm.samples);
    sm.impulse_pos /= static_cast<double>(sm.samples);
  }
  r.stats = solver.stats();
  r.y_end.head<kDof>() = xs + ye.head<kDof>();
  r.y_end.tail<kDof>() = ye.tail<kDof>();
  return r;
}

}  // namespace vadsim
