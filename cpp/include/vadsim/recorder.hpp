#pragma once
/// @file recorder.hpp
/// @brief Samples a run on its three time grids as the integration passes them: the stored
/// output, the once-per-cycle Poincare section, and the steady-window summary (J* and
/// per-window peaks on a 20 kHz grid), so that a sweep needs no stored time series.

#include "vadsim/model.hpp"
#include "vadsim/results.hpp"
#include "vadsim/run_options.hpp"
#include "vadsim/trajectory.hpp"

namespace vadsim {

class OrbitTable;

/// @brief The run's time axis, derived once so that the event loop and the recorder agree.
struct Horizon {
  double f_exc_hz;  ///< excitation frequency (Hz)
  double period;    ///< one excitation cycle (s)
  double t_end;     ///< end of the run (s)
  double t_window;  ///< start of the steady window (s)
  Horizon(const Params& p, const RunOptions& opts);
};

/// @brief A uniform time grid that is filled, in order, as the integration passes it.
class TimeGrid {
 public:
  TimeGrid() = default;
  TimeGrid(double t0, double dt, long n) : t0_(t0), dt_(dt), n_(n) {}
  double time(long k) const { return t0_ + static_cast<double>(k) * dt_; }
  long size() const { return n_; }
  /// @brief True if the next point is at or before tlim.
  bool pending(double tlim) const { return next_ < n_ && time(next_) <= tlim; }
  /// @brief The next point's index; moves past it.
  long take() { return next_++; }
  /// @brief Points recorded so far.
  long done() const { return next_; }

 private:
  double t0_ = 0, dt_ = 1;
  long n_ = 0, next_ = 0;
};

/// @brief Fills a RunResult's time series, Poincare section and WindowSummary.
class Recorder {
 public:
  /// @brief Sizes the grids and the result's arrays; throws std::invalid_argument when a rate
  /// asks for more samples than make sense.
  Recorder(const Model& model, const RunOptions& opts, const Horizon& horizon, RunResult& r);

  /// @brief Record every grid point up to tlim from the current segment, with the contact
  /// modes it was integrated with; the summary grid's points too unless with_summary is false
  /// (they stay pending for the overload below).
  void record_until(double tlim, const Trajectory& segment, const Modes& modes,
                    bool with_summary = true);
  /// @brief Record the summary grid's points up to tlim from a periodic orbit's table.
  void record_summary(double tlim, const OrbitTable& table);

  /// @brief Count the window's onsets and turn the impulse sums into means.
  void finish();

  /// @brief Poincare section points recorded so far (rows of RunResult::poincare).
  long sections_recorded() const { return sec_.done(); }
  /// @brief Drop the stored output grid (no rows): a periodic run's orbit table stands for it.
  void drop_output();

 private:
  void size_grids(const RunOptions& opts, const Horizon& horizon);
  void record_section(double tlim, const Trajectory& segment);
  void record_output(double tlim, const Trajectory& segment, const Modes& modes);
  void record_summary(double tlim, const Trajectory& segment, const Modes& modes);
  /// @brief Add one summary sample (index k) to the impulse sums and its window's peaks.
  void accumulate_summary(long k, const Vec7& acc, double f_impact);
  /// @brief The state at t; ev_ receives its forces and accelerations.
  Eigen::Map<const State> sample(double t, const Trajectory& segment, const Modes& modes);

  const Model& model_;
  const Vec7& xs_;  ///< static positions: results are absolute
  double flow_gpm_;
  RunResult& r_;
  TimeGrid out_, sum_, sec_;
  double per_window_ = 1;  ///< summary samples per peak window
  long n_windows_ = 0;
  bool states_ = true;  ///< the stored series keep x, v and the forces, not only a
  Evaluation ev_;  ///< workspace: forces and accelerations at the sampled state
};

}  // namespace vadsim
