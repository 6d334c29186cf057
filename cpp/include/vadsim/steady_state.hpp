#pragma once
/// @file steady_state.hpp
/// @brief The periodic steady state of a run: detected on the Poincare section, recorded as
/// one orbit of CVODE's own interpolants, and replayed to build the rest of the run.
///
/// Why: a run integrates 300-400 excitation cycles and analyses the last 200, but most
/// operating points settle onto a periodic orbit within a few tens of cycles; from there every
/// cycle repeats one already computed. The model is periodic in time with the excitation
/// period T (the excitation is the only explicit time dependence: extra forces are autonomous),
/// so once the state at t_c repeats after P = n T, the solution after t_c is y(t_c + (t - t_c)
/// mod P). The run then integrates one more orbit while keeping every step's interpolant,
/// checks that it closed, and fills every grid and the event table of the remaining time from
/// it (synthesize_rest). Where no orbit is confirmed the run goes on exactly as a literal one.

#include <array>
#include <vector>

#include "vadsim/cvode_solver.hpp"
#include "vadsim/model.hpp"
#include "vadsim/recorder.hpp"
#include "vadsim/results.hpp"
#include "vadsim/run_options.hpp"
#include "vadsim/trajectory.hpp"

namespace vadsim {

/// @brief Finds the smallest n (1..max) for which the once-per-cycle section repeats after n
/// cycles, confirmed over consecutive sections, within a tolerance per state component.
///
/// A repeat of component i counts when |y_i(k) - y_i(k - n)| <= tol (A_i + atol_i / tol)
/// = tol A_i + atol_i, A_i being the component's range (max - min) over the last
/// cycles: the tolerance follows each component's own motion and never falls below what
/// CVODE itself controls. Period n is confirmed at section k when the last max(2 n,
/// confirm) sections each repeat and the section k also repeats the one a whole number of
/// orbits before the first of them (a slow drift that stays within tol per orbit fails that).
class PeriodDetector {
 public:
  PeriodDetector(const RunOptions& opts, const State& atol);

  /// @brief Widen the current cycle's range of each component by y (any state of the cycle).
  void observe(const Eigen::Ref<const State>& y);
  /// @brief Section k (the state at k T): closes the current cycle's range and looks for a
  /// period. Returns the confirmed period (0: none yet).
  int add_section(long k, const Eigen::Ref<const State>& y);
  /// @brief Does section y repeat the stored section k - n (the check of a closing orbit)?
  /// Updates residual().
  bool repeats(long k, int n, const Eigen::Ref<const State>& y);
  /// @brief The largest scaled difference of the last confirmation, relative to amplitude.
  double residual() const { return residual_; }
  double tolerance() const { return tol_; }

 private:
  static constexpr int kHistory = 4 * RunOptions::kMaxSteadyPeriod + 2;
  static constexpr int kRanges = 2 * RunOptions::kMaxSteadyPeriod;
  /// @brief The confirmation window of period n, in sections.
  int window(int n) const { return std::max(2 * n, confirm_); }
  /// @brief tol A_i + atol_i, A_i the component's largest range over the last window(n)
  /// cycles: the recent motion, not the start-up transient's.
  State scale(int n) const;
  /// @brief The smallest divisor d of a confirmed period n at section k whose repeats hold
  /// over the last n sections (n itself if none).
  int smallest_period(long k, int n) const;
  /// @brief max_i |a_i - b_i| / scale_i: <= 1 is a repeat.
  static double scaled_difference(const Eigen::Ref<const State>& a,
                                  const Eigen::Ref<const State>& b, const State& scale);
  const State& section(long k) const { return sections_[k % kHistory]; }

  double tol_;
  State atol_;
  long min_section_;
  int max_period_, confirm_, drift_;
  std::array<State, kHistory> sections_;
  /// passes_[n] counts consecutive sections that repeated the one n before
  std::array<int, RunOptions::kMaxSteadyPeriod + 1> passes_{};
  std::array<double, RunOptions::kMaxSteadyPeriod + 1> worst_{};
  State lo_, hi_;  ///< the current cycle's range
  std::array<State, kRanges> ranges_;  ///< ranges of the recent cycles (a ring)
  long cycles_seen_ = 0;
  long last_k_ = -1;
  double residual_ = 0;
};

/// @brief One period of a run, recorded step by step with CVODE's interpolants: the piece of
/// each step inside [t0, t0 + P], its contact modes, and the events in it.
class Orbit {
 public:
  /// @brief An orbit that starts at t0 and lasts period (s).
  Orbit(double t0, double period);
  double t0() const { return t0_; }
  double period() const { return period_; }
  /// @brief True once pieces cover [t0, t0 + P].
  bool closed() const { return covered_ >= t0_ + period_; }
  /// @brief Keep the part of (t_lo, t_hi] inside the orbit, with the interpolant of the step
  /// that covers it and the modes it was integrated with.
  void add(double t_lo, double t_hi, const CvodeSolver::StepInterpolant& step,
           const Modes& modes);
  /// @brief Keep the run's events with t0 < t <= t0 + P (events ordered in time).
  void take_events(const std::vector<ContactEvent>& events);
  const std::vector<ContactEvent>& events() const { return events_; }

  /// @brief The state at tau in [t0, t0 + P] (clamped), with the modes of its piece.
  void state_at(double tau, State& y, Modes& modes) const;

  /// @brief A Trajectory over piece p of the orbit, shifted by a whole number of orbits.
  class Replay final : public Trajectory {
   public:
    Replay(const Orbit& orbit, std::size_t piece, double shift)
        : orbit_(orbit), piece_(piece), shift_(shift) {}
    Eigen::Map<const State> interpolate(double t) const override;
    Eigen::Map<const State> sample(double t) const override { return interpolate(t); }

   private:
    const Orbit& orbit_;
    std::size_t piece_;
    double shift_;
    mutable State y_;
  };

  struct Piece {
    double t_lo, t_hi;  ///< the part of the step kept: (t_lo, t_hi]
    double tn, h;       ///< the step's end and size: s = (t - tn) / h
    int q;              ///< its order: columns zn[0..q]
    std::size_t column; ///< where its columns start in columns_ (14 doubles each)
    Modes modes;
  };
  const std::vector<Piece>& pieces() const { return pieces_; }

 private:
  void evaluate(const Piece& p, double tau, double* out) const;
  double t0_, period_, covered_;
  std::vector<Piece> pieces_;
  std::vector<double> columns_;
  std::vector<ContactEvent> events_;
};

/// @brief The summary grid's remaining points are read from a table of one period at this
/// many times the summary rate (OrbitTable): at 8x its interpolation is within the orbit's own
/// repeat tolerance (measured on 7in runs against the replayed samples).
constexpr double kSummaryTableOversampling = 8;

/// @brief Everything a run returns after t_stop, built from a closed orbit: the recorder's
/// grids (output, Poincare section) through Orbit::Replay, the summary grid through an
/// OrbitTable where that is cheaper (kSummaryTableOversampling), the events shifted by
/// whole orbits, the orbit table (RunOptions::orbit_rate_hz) and the final state.
/// skip_events: how many of the replayed events were integrated already (the run went on past
/// the orbit's end to its step's end); counted, not timed, so rounding cannot double one.
void synthesize_rest(const Model& model, const RunOptions& opts, const Horizon& horizon,
                     const Orbit& orbit, double t_stop, long skip_events, Recorder& recorder,
                     RunResult& r);

}  // namespace vadsim
