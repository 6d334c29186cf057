#pragma once
/// @file orbit_table.hpp
/// @brief One period of a periodic orbit's accelerations and impact force on a uniform grid,
/// plus its corners, read back by linear interpolation.
///
/// Why: replaying the orbit evaluates the model at every sample of a grid over the whole
/// window (200 cycles at 20 kHz: some 180,000 evaluations for the summary alone), although
/// the orbit repeats every period. A table of one period at 8x the grid's rate costs a few
/// thousand evaluations. Linear interpolation on a uniform table alone would smear each
/// contact's corner (a Kelvin-Voigt force jumps where a contact closes), where an impact's
/// acceleration peaks; the corners are therefore kept exactly, with the values just before
/// and just after, and interpolation runs between grid points and corners.

#include <vector>

#include "vadsim/model.hpp"
#include "vadsim/steady_state.hpp"
#include "vadsim/types.hpp"

namespace vadsim {

/// @brief Accelerations (m/s^2) and the impact face's contact force (N/kg) at one time.
struct OrbitSample {
  Vec7 acc = Vec7::Zero();
  double f_impact = 0;
};

/// @brief An orbit's period on m uniform points (t0 + j P / m) and at its corners.
class OrbitTable {
 public:
  /// @brief A corner: a boundary between two pieces of the orbit integrated with different
  /// contact modes, and the values on either side.
  struct Corner {
    double offset;  ///< time after the orbit's start (s)
    OrbitSample before, after;
  };

  /// @brief Evaluate the model on the orbit at m >= 1 uniform points and at every corner.
  OrbitTable(const Model& model, double flow_gpm, const Orbit& orbit, long m);

  long size() const { return static_cast<long>(grid_.size()); }
  double t0() const { return t0_; }
  double period() const { return period_; }
  /// @brief The time (s) of grid point j: t0 + j P / m.
  double time(long j) const {
    return t0_ + period_ * static_cast<double>(j) / static_cast<double>(size());
  }
  /// @brief The value at grid point j, time(j).
  const OrbitSample& grid(long j) const { return grid_[static_cast<std::size_t>(j)]; }
  const std::vector<Corner>& corners() const { return corners_; }

  /// @brief The value at time t >= t0 (the orbit repeats with its period); at a corner's
  /// own time, the value just after it.
  void at(double t, OrbitSample& out) const;

 private:
  double t0_, period_, per_second_;  ///< per_second_: grid points per second, m / P
  std::vector<OrbitSample> grid_;
  std::vector<Corner> corners_;      ///< in time order
  std::vector<int> first_corner_;    ///< per grid interval: its first corner, or -1
};

}  // namespace vadsim
