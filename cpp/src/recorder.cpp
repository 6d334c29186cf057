#include "vadsim/recorder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vadsim/errors.hpp"
#include "vadsim/orbit_table.hpp"

namespace vadsim {

namespace {

/// @brief Points of a grid of the given rate over span; refuses absurd requests.
long grid_count(double span, double rate, const char* name, bool stored) {
  // A stored sample is 28 doubles (x, v, a, 5 forces, F_H, t): 2e7 samples are 4.5 GB,
  // beyond which a request is a mistake (this machine has 24 GB), not an analysis.
  const double samples_limit = 2e7;
  const double n = std::floor(span * rate * (1 + 1e-12)) + 1;
  if (stored && n > samples_limit)
    fail_option(name, rate, "asks for more than 2e7 stored samples (4.5 GB): lower the rate "
                            "or record only the window");
  if (n > 1e10) fail_option(name, rate, "asks for more than 1e10 samples");
  return static_cast<long>(n);
}

}  // namespace

Horizon::Horizon(const Params& p, const RunOptions& opts)
    : f_exc_hz(p.excitation_hz(opts.flow_gpm)),
      period(1.0 / f_exc_hz),
      t_end(opts.cycles * period),
      t_window((opts.cycles - opts.analyse_cycles) * period) {}

Recorder::Recorder(const Model& model, const RunOptions& opts, const Horizon& horizon,
                   RunResult& r)
    : model_(model),
      xs_(model.static_positions()),
      flow_gpm_(opts.flow_gpm),
      r_(r),
      states_(!opts.accelerations_only) {
  size_grids(opts, horizon);
  const long n_states = states_ ? out_.size() : 0;
  r_.t.resize(out_.size());
  r_.x.resize(n_states, kDof);
  r_.v.resize(n_states, kDof);
  r_.a.resize(out_.size(), kDof);
  r_.fc.resize(n_states, kSurfaces);
  r_.fh.resize(n_states);
  r_.poincare_t.resize(sec_.size());
  r_.poincare.resize(sec_.size(), kState);
  auto& sm = r_.summary;
  sm.t0 = horizon.t_window;
  sm.t1 = horizon.t_end;
  sm.rate_hz = opts.summary_rate_hz;
  sm.samples = sum_.size();
  per_window_ = opts.peak_window_s * opts.summary_rate_hz;
  n_windows_ = opts.summary_rate_hz > 0
                   ? static_cast<long>(std::floor(
                         (horizon.t_end - horizon.t_window) / opts.peak_window_s + 1e-9))
                   : 0;
  sm.window_peaks = RowMat7::Zero(std::max(0L, n_windows_), kDof);
}

void Recorder::size_grids(const RunOptions& opts, const Horizon& h) {
  if (opts.record != Record::None && opts.output_rate_hz > 0) {
    const double t0 = (opts.record == Record::Window) ? h.t_window : 0.0;
    out_ = TimeGrid(t0, 1.0 / opts.output_rate_hz,
                    grid_count(h.t_end - t0, opts.output_rate_hz, "output_rate_hz", true));
  }
  if (opts.summary_rate_hz > 0) {
    const long n_sum = grid_count(h.t_end - h.t_window, opts.summary_rate_hz,
                                  "summary_rate_hz", false);
    sum_ = TimeGrid(h.t_window, 1.0 / opts.summary_rate_hz, std::max(1L, n_sum - 1));
  }
  sec_ = TimeGrid(0.0, h.period, static_cast<long>(std::floor(opts.cycles * (1 + 1e-12))) + 1);
}

void Recorder::record_until(double tlim, const Trajectory& segment, const Modes& modes,
                            bool with_summary) {
  record_section(tlim, segment);
  record_output(tlim, segment, modes);
  if (with_summary) record_summary(tlim, segment, modes);
}

Eigen::Map<const State> Recorder::sample(double t, const Trajectory& segment,
                                         const Modes& modes) {
  const Eigen::Map<const State> y = segment.sample(t);
  model_.evaluate(t, flow_gpm_, y, modes, ev_);
  return y;
}

void Recorder::record_section(double tlim, const Trajectory& segment) {
  while (sec_.pending(tlim)) {
    const long k = sec_.take();
    const double t = sec_.time(k);
    const auto y = segment.sample(t);  // the section stores states only: no forces needed
    r_.poincare_t[k] = t;
    r_.poincare.row(k).head<kDof>() = (xs_ + y.head<kDof>()).transpose();
    r_.poincare.row(k).tail<kDof>() = y.tail<kDof>().transpose();
  }
}

void Recorder::record_output(double tlim, const Trajectory& segment, const Modes& modes) {
  while (out_.pending(tlim)) {
    const long k = out_.take();
    const double t = out_.time(k);
    const auto y = sample(t, segment, modes);
    r_.t[k] = t;
    r_.a.row(k) = ev_.acc.transpose();
    if (!states_) continue;
    r_.x.row(k) = (xs_ + y.head<kDof>()).transpose();
    r_.v.row(k) = y.tail<kDof>().transpose();
    for (int s = 0; s < kSurfaces; ++s) r_.fc(k, s) = ev_.fc[s];
    r_.fh[k] = ev_.fh;
  }
}

void Recorder::record_summary(double tlim, const Trajectory& segment, const Modes& modes) {
  while (sum_.pending(tlim)) {
    const long k = sum_.take();
    sample(sum_.time(k), segment, modes);
    accumulate_summary(k, ev_.acc, ev_.fc[kImpact]);
  }
}

void Recorder::record_summary(double tlim, const OrbitTable& table) {
  OrbitSample s;
  while (sum_.pending(tlim)) {
    const long k = sum_.take();
    table.at(sum_.time(k), s);
    accumulate_summary(k, s.acc, s.f_impact);
  }
}

void Recorder::accumulate_summary(long k, const Vec7& acc, double f_impact) {
  auto& sm = r_.summary;
  sm.impulse_mean += f_impact;
  sm.impulse_pos += f_impact > 0 ? f_impact : 0.0;
  const long win = static_cast<long>(std::floor(k / per_window_ + 1e-9));
  if (win < n_windows_) {
    for (int i = 0; i < kDof; ++i)
      sm.window_peaks(win, i) = std::max(sm.window_peaks(win, i), std::abs(acc[i]));
  }
}

void Recorder::drop_output() {
  out_ = TimeGrid();
  r_.t.resize(0);
  r_.x.resize(0, kDof);
  r_.v.resize(0, kDof);
  r_.a.resize(0, kDof);
  r_.fc.resize(0, kSurfaces);
  r_.fh.resize(0);
}

void Recorder::finish() {
  auto& sm = r_.summary;
  for (const auto& e : r_.events)
    if (e.kind == EventKind::Onset && e.t >= sm.t0) sm.onsets[e.surface] += 1;
  if (sm.samples > 0) {
    sm.impulse_mean /= static_cast<double>(sm.samples);
    sm.impulse_pos /= static_cast<double>(sm.samples);
  } else {
    sm.impulse_mean = sm.impulse_pos = std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace vadsim
