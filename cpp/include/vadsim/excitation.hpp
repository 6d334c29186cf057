#pragma once
/// @file excitation.hpp
/// @brief The flow-driven force on the anvil and its fluid drag (MODEL.md), kept apart so
/// that a different valve law can replace it without touching the contact model.

#include <cmath>

#include "vadsim/params.hpp"

namespace vadsim {

/// @brief F_H = Fo cos(alpha Q t + phi) sin(beta (x2 - x3) + psi) and F_D = cD v2 |v2|.
struct Excitation {
  double Fo, alpha, beta, phi, psi, cD;

  explicit Excitation(const Params& p)
      : Fo(p.Fo), alpha(p.alpha), beta(p.beta), phi(p.phi), psi(p.psi), cD(p.cD) {}

  /// @brief Angular frequency (rad/s) at a flow rate (gal/min).
  double omega(double flow_gpm) const { return alpha * flow_gpm; }

  /// @brief Force on the anvil; rel = x2 - x3 in metres. dF_drel receives dF/d(x2 - x3).
  double force(double t, double flow_gpm, double rel, double& dF_drel) const {
    const double c = Fo * std::cos(omega(flow_gpm) * t + phi);
    const double arg = beta * rel + psi;
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
