#pragma once
/// @file excitation.hpp
/// @brief The flow-driven force on the anvil and its fluid drag (MODEL.md), kept apart so
/// that a different valve law can replace it without touching the contact model.

#include <cmath>

#include "vadsim/params.hpp"

namespace vadsim {

/// @brief F_H = Fo cos(alpha Q t + phi) sin(beta (x2 - x3) + psi) and F_D = cD v2 |v2|.
///
/// Written as sin(beta du + theta0), du = (x2 - x3) - (x2 - x3)_rest: the phase at rest theta0
/// is what the dynamics depends on (MODEL.md), and beta du stays small where beta (x2 - x3) is
/// some 260 rad whose rounding the subtraction of psi would keep.
struct Excitation {
  double Fo, alpha, beta, phi, theta0, cD;

  /// @brief theta0: the phase at rest, Params::theta0 or the one psi and the rest state give.
  Excitation(const Params& p, double theta0_at_rest)
      : Fo(p.Fo), alpha(p.alpha), beta(p.beta), phi(p.phi), theta0(theta0_at_rest), cD(p.cD) {}

  /// @brief Angular frequency (rad/s) at a flow rate (gal/min).
  double omega(double flow_gpm) const { return alpha * flow_gpm; }

  /// @brief Force on the anvil; du = (x2 - x3) - (x2 - x3)_rest in metres. The right-hand
  /// side's form: no derivative, so one transcendental call fewer per evaluation.
  double force(double t, double flow_gpm, double du) const {
    return Fo * std::cos(omega(flow_gpm) * t + phi) * std::sin(beta * du + theta0);
  }

  /// @brief force(), and dF_drel receives dF/d(x2 - x3) (the Jacobian's form).
  double force(double t, double flow_gpm, double du, double& dF_drel) const {
    const double c = Fo * std::cos(omega(flow_gpm) * t + phi);
    const double arg = beta * du + theta0;
    dF_drel = c * beta * std::cos(arg);
    return c * std::sin(arg);
  }

  /// @brief Drag opposing the anvil's motion (signed form of the dissertation's cD v^2).
  double drag(double v2, double& dD_dv2) const {
    dD_dv2 = 2.0 * cD * std::abs(v2);
    return cD * v2 * std::abs(v2);
  }
};

}  // namespace vadsim
