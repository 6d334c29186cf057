#include "vadsim/steady_state.hpp"

#include "vadsim/orbit_table.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace vadsim {

// ---------------------------------------------------------------------------- PeriodDetector

PeriodDetector::PeriodDetector(const RunOptions& opts, const State& atol)
    : tol_(opts.steady_tolerance()),
      atol_(atol),
      min_section_(static_cast<long>(std::ceil(opts.steady_min_cycles - 1e-9))),
      max_period_(opts.steady_max_period),
      confirm_(opts.steady_confirm_cycles),
      drift_(opts.steady_drift_cycles) {
  lo_.setConstant(std::numeric_limits<double>::infinity());
  hi_.setConstant(-std::numeric_limits<double>::infinity());
  for (auto& r : ranges_) r.setZero();
}

void PeriodDetector::observe(const Eigen::Ref<const State>& y) {
  lo_ = lo_.cwiseMin(y);
  hi_ = hi_.cwiseMax(y);
}

State PeriodDetector::scale(int n) const {
  State range = State::Zero();
  const long cycles = std::min<long>(cycles_seen_, std::min<long>(window(n), kRanges));
  for (long j = 1; j <= cycles; ++j) range = range.cwiseMax(ranges_[(cycles_seen_ - j) % kRanges]);
  return tol_ * range + atol_;
}

double PeriodDetector::scaled_difference(const Eigen::Ref<const State>& a,
                                         const Eigen::Ref<const State>& b,
                                         const State& scale) {
  return ((a - b).cwiseAbs().cwiseQuotient(scale)).maxCoeff();
}

int PeriodDetector::add_section(long k, const Eigen::Ref<const State>& y) {
  observe(y);
  if (last_k_ >= 0) {
    // The cycle that ends here joins the recent cycles whose ranges scale the tolerance.
    ranges_[cycles_seen_ % kRanges] = hi_ - lo_;
    ++cycles_seen_;
  }
  lo_ = y;
  hi_ = y;
  if (k != last_k_ + 1) passes_.fill(0);  // a gap in the sections: start over
  last_k_ = k;
  sections_[k % kHistory] = y;
  if (k < min_section_) return 0;
  int found = 0;
  for (int n = 1; n <= max_period_ && k - n >= min_section_; ++n) {
    const State sc = scale(n);
    const double d = scaled_difference(y, section(k - n), sc);
    if (d > 1.0) {
      passes_[n] = 0;
      continue;
    }
    worst_[n] = passes_[n] == 0 ? d : std::max(worst_[n], d);
    ++passes_[n];
    if (found || passes_[n] < window(n)) continue;
    // The repeats chain within tol per orbit; the section must also be within tol of the one
    // a whole number of orbits before the window, or it is drifting slowly.
    const long far = k - static_cast<long>((std::max(window(n), drift_) + n - 1) / n) * n;
    if (far < min_section_) continue;
    const double d_far = scaled_difference(y, section(far), sc);
    if (d_far > 1.0) continue;
    residual_ = std::max(worst_[n], d_far) * tol_;
    found = n;
  }
  return found ? smallest_period(k, found) : 0;
}

int PeriodDetector::smallest_period(long k, int n) const {
  // A repeat after n cycles may be one after a divisor d of n that missed the tolerance in
  // a section or two (a period-1 orbit at its noise floor): the orbit is then d cycles long,
  // and so is the recording of it.
  for (int d = 1; d < n; ++d) {
    if (n % d != 0 || k - n - d < min_section_) continue;
    const State sc = scale(d);
    bool repeats = true;
    for (int j = 0; j < n && repeats; ++j)
      repeats = scaled_difference(section(k - j), section(k - j - d), sc) <= 1.0;
    if (repeats) return d;
  }
  return n;
}

bool PeriodDetector::repeats(long k, int n, const Eigen::Ref<const State>& y) {
  if (k - n < 0 || last_k_ - (k - n) >= kHistory) return false;
  const double d = scaled_difference(y, section(k - n), scale(n));
  residual_ = std::max(residual_, d * tol_);
  return d <= 1.0;
}

// ------------------------------------------------------------------------------------ Orbit

Orbit::Orbit(double t0, double period) : t0_(t0), period_(period), covered_(t0) {
  pieces_.reserve(4096);
  columns_.reserve(4096 * 6 * kState);
}

void Orbit::add(double t_lo, double t_hi, const CvodeSolver::StepInterpolant& step,
                const Modes& modes) {
  const double lo = std::max(t_lo, covered_);
  const double hi = std::min(t_hi, t0_ + period_);
  if (!(hi > lo)) return;
  Piece p{lo, hi, step.tn, step.h, step.q, columns_.size(), modes};
  for (int j = 0; j <= step.q; ++j) columns_.insert(columns_.end(), step.zn[j], step.zn[j] + kState);
  pieces_.push_back(p);
  covered_ = hi;
}

void Orbit::take_events(const std::vector<ContactEvent>& events) {
  events_.clear();
  for (const auto& e : events)
    if (e.t > t0_ && e.t <= t0_ + period_) events_.push_back(e);
}

void Orbit::evaluate(const Piece& p, double tau, double* out) const {
  const double* zn[CvodeSolver::kMaxColumns];
  for (int j = 0; j <= p.q; ++j) zn[j] = columns_.data() + p.column + j * kState;
  CvodeSolver::evaluate_interpolant(tau, p.tn, p.h, p.q, zn, out);
}

void Orbit::state_at(double tau, State& y, Modes& modes) const {
  // The first piece whose end is at or after tau (pieces are (t_lo, t_hi], in order).
  auto it = std::lower_bound(pieces_.begin(), pieces_.end(), tau,
                             [](const Piece& p, double t) { return p.t_hi < t; });
  if (it == pieces_.end()) it = pieces_.end() - 1;
  const double t = std::clamp(tau, it->t_lo, it->t_hi);
  evaluate(*it, t, y.data());
  modes = it->modes;
}

Eigen::Map<const State> Orbit::Replay::interpolate(double t) const {
  orbit_.evaluate(orbit_.pieces_[piece_], t - shift_, y_.data());
  return Eigen::Map<const State>(y_.data());
}

// ---------------------------------------------------------------------------- the synthesis

namespace {

/// @brief The orbit table of RunOptions::orbit_rate_hz: one period on a uniform grid, and its
/// corners.
void tabulate(const Model& model, const RunOptions& opts, const Orbit& orbit, RunResult& r) {
  if (!(opts.orbit_rate_hz > 0)) return;
  const OrbitTable table(model, opts.flow_gpm, orbit,
                         std::max(1L, std::lround(orbit.period() * opts.orbit_rate_hz)));
  const long m = table.size();
  r.orbit_t.resize(m);
  r.orbit_a.resize(m, kDof);
  for (long j = 0; j < m; ++j) {
    r.orbit_t[j] = table.time(j);
    r.orbit_a.row(j) = table.grid(j).acc.transpose();
  }
  const auto& corners = table.corners();
  const auto n = static_cast<Eigen::Index>(corners.size());
  r.orbit_corner_t.resize(n);
  r.orbit_corner_before.resize(n, kDof);
  r.orbit_corner_after.resize(n, kDof);
  for (Eigen::Index c = 0; c < n; ++c) {
    const auto& corner = corners[static_cast<std::size_t>(c)];
    r.orbit_corner_t[c] = orbit.t0() + corner.offset;
    r.orbit_corner_before.row(c) = corner.before.acc.transpose();
    r.orbit_corner_after.row(c) = corner.after.acc.transpose();
  }
}

}  // namespace

void synthesize_rest(const Model& model, const RunOptions& opts, const Horizon& horizon,
                     const Orbit& orbit, double t_stop, long skip_events, Recorder& recorder,
                     RunResult& r) {
  const double period = orbit.period();
  const double t_last = horizon.t_end * (1 + 1e-12);  // grid points at t_end after rounding
  // The summary grid from a table of one period when that takes fewer model evaluations than
  // the grid's own remaining points (a short orbit, a long window).
  const double table_points = kSummaryTableOversampling * period * opts.summary_rate_hz;
  const bool summary_from_table =
      opts.summary_rate_hz > 0 && table_points < (horizon.t_end - t_stop) * opts.summary_rate_hz;
  // Whole orbits after the recorded one, each piece replayed at its shifted time: the grids
  // are filled in time order, and points already recorded (up to t_stop) are not pending.
  for (long m = 1;; ++m) {
    const double shift = static_cast<double>(m) * period;
    if (orbit.t0() + shift > t_last) break;
    const auto& pieces = orbit.pieces();
    for (std::size_t p = 0; p < pieces.size(); ++p) {
      const double hi = pieces[p].t_hi + shift;
      if (hi <= t_stop) continue;
      const Orbit::Replay replay(orbit, p, shift);
      recorder.record_until(std::min(hi, t_last), replay, pieces[p].modes,
                            !summary_from_table);
      if (hi >= t_last) break;
    }
    for (const auto& e : orbit.events()) {
      const double t = e.t + shift;
      if (skip_events > 0) {
        --skip_events;
        continue;
      }
      if (t <= horizon.t_end) r.events.push_back({t, e.surface, e.kind, e.rel_velocity});
    }
  }
  if (summary_from_table)
    recorder.record_summary(
        t_last, OrbitTable(model, opts.flow_gpm, orbit, std::max(1L, std::lround(table_points))));
  // The final state: where t_end falls on the orbit, as the grids replayed it (the shift
  // that puts t_end in (t0, t0 + P]); at a whole number of cycles, the last section itself.
  const long last = r.poincare.rows() - 1;
  if (last >= 0 && std::abs(r.poincare_t[last] - horizon.t_end) <= 1e-12 * horizon.t_end) {
    r.y_end = r.poincare.row(last).transpose();
  } else {
    const double whole = std::ceil((horizon.t_end - orbit.t0()) / period) - 1;
    State y;
    Modes modes;
    orbit.state_at(horizon.t_end - whole * period, y, modes);
    r.y_end.head<kDof>() = model.static_positions() + y.head<kDof>();
    r.y_end.tail<kDof>() = y.tail<kDof>();
  }
  tabulate(model, opts, orbit, r);
  r.orbit_period_s = period;
}

}  // namespace vadsim
