#pragma once
/// @file trajectory.hpp
/// @brief The solution of the segment being integrated, as the classes that sample it (the
/// recorder, the contact tracker's bisection) see it: they need states at times inside the
/// last step, not CVODE.

#include "vadsim/types.hpp"

namespace vadsim {

/// @brief States of the current segment (between two re-initialisations of CVODE).
class Trajectory {
 public:
  virtual ~Trajectory() = default;
  /// @brief The state [u; v] at t from the interpolant of the last step. The view is valid
  /// until the next call (it points into a scratch vector: no copy per sample).
  virtual Eigen::Map<const State> interpolate(double t) const = 0;
  /// @brief The state at a grid time t: the segment's start state when t is at or before the
  /// start (no step exists there yet to interpolate), else interpolate(t).
  virtual Eigen::Map<const State> sample(double t) const = 0;
};

}  // namespace vadsim
