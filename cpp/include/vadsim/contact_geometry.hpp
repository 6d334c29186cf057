#pragma once
/// @file contact_geometry.hpp
/// @brief Where a contact's indentation comes from, written once: the right-hand side, the
/// Jacobian, the root functions and the mode logic all call SurfaceGeometry, so they can never
/// disagree on which bodies a surface joins or on its sign convention.

#include "vadsim/types.hpp"

namespace vadsim {

/// @brief Indentation of one contact and its rate at one state.
struct Indentation {
  double d;     ///< overlap (m): > 0 when the surfaces overlap
  double rate;  ///< d' (m/s)
};

/// @brief Geometry of one contact: d = sa * x[a] + sb * x[b] + offset (b < 0: the ground).
struct SurfaceGeometry {
  int a, b;
  double sa, sb;
  double offset;  ///< in terms of displacements u (the static positions folded in)

  /// @brief sa w[a] + sb w[b] for any per-body vector w: on displacements it is d - offset,
  /// on velocities d', on accelerations d''.
  template <typename V>
  double project(const V& w) const {
    return sa * w[a] + (b >= 0 ? sb * w[b] : 0.0);
  }

  /// @brief d and d' at a state y = [u; v] (any 14-long vector expression).
  template <typename S>
  Indentation at(const S& y) const {
    return {project(y.template head<kDof>()) + offset, project(y.template tail<kDof>())};
  }
};

}  // namespace vadsim
