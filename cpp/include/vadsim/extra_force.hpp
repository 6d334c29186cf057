#pragma once
/// @file extra_force.hpp
/// @brief A hook for physics the dissertation left out (hydraulic force, friction, radiation
/// into the string...), evaluated inside the core so that fits stay fast and the integrator
/// never changes when a term is added.

#include <cmath>
#include <memory>
#include <string>

#include "vadsim/types.hpp"

namespace vadsim {

/// @brief One additional generalized force (N/kg of m*) with its Jacobian.
///
/// Implementations must be immutable (shared across threads), smooth in the state (the
/// integrator does not look for their switches), and must not allocate.
class ExtraForce {
 public:
  virtual ~ExtraForce() = default;
  /// @brief Short identifier used in results and error messages.
  virtual std::string name() const = 0;
  /// @brief Add the force to f. u are displacements (m) from the static on-bottom state (the
  /// state the run starts from), v velocities (m/s): extra physics is a perturbation of that
  /// state, and a spring added this way does not move the equilibrium. u and v view the
  /// integrator's state in place (no copy per call).
  virtual void add_force(double t, double flow_gpm, const Vec7CRef& u, const Vec7CRef& v,
                         Vec7& f) const = 0;
  /// @brief Add df/du and df/dv.
  virtual void add_jacobian(double t, double flow_gpm, const Vec7CRef& u, const Vec7CRef& v,
                            Mat7& dfdu, Mat7& dfdv) const = 0;
};

/// @brief c Q^n pushing one body (anvil or bit) towards the rock: the pressure drop across
/// the tool's nozzles and ports.
///
/// A turbulent orifice gives n = 2 (the default), a laminar or partly choked path less, a
/// motor whose differential pressure rises with flow more: the exponent makes the force a
/// family, so a fit is not forced onto the square law when the field's hydraulics differ.
/// The force is independent of the state (no Jacobian entries).
class HydraulicForce final : public ExtraForce {
 public:
  /// @param dof body (0-based); c in (N/kg)/(gal/min)^n; n in [0, 4] (checked).
  HydraulicForce(int dof, double c, double n = 2.0);
  std::string name() const override { return "hydraulic_force"; }
  void add_force(double, double flow_gpm, const Vec7CRef&, const Vec7CRef&,
                 Vec7& f) const override {
    // n = 2 keeps the square exact, so c Q^2 runs are bit-identical to the square law's.
    f[dof_] += c_ * (n_ == 2.0 ? flow_gpm * flow_gpm : std::pow(flow_gpm, n_));
  }
  void add_jacobian(double, double, const Vec7CRef&, const Vec7CRef&, Mat7&,
                    Mat7&) const override {}

 private:
  int dof_;
  double c_, n_;
};

/// @brief Coulomb friction between two bodies, regularised as F tanh(v_rel / v_eps) so that
/// stick-slip needs no extra root functions; optionally with a Stribeck peak, F(v) = force +
/// (static - force) exp(-(v / v_s)^2), the higher force of a seal or spline that has just
/// stopped sliding.
class CoulombFriction final : public ExtraForce {
 public:
  /// @param static_force the force at rest (N/kg; >= force; NaN or equal to force: no peak);
  /// v_s the Stribeck velocity (m/s) over which it falls to the kinetic force.
  CoulombFriction(int dof_a, int dof_b, double force, double v_eps,
                  double static_force = std::nan(""), double v_s = 0.05);
  std::string name() const override { return "coulomb_friction"; }
  void add_force(double, double, const Vec7CRef&, const Vec7CRef& v, Vec7& f) const override;
  void add_jacobian(double, double, const Vec7CRef&, const Vec7CRef& v, Mat7&,
                    Mat7& dfdv) const override;

 private:
  /// @brief The Stribeck excess over the kinetic force at sliding velocity vr (0 without
  /// a peak, so that Coulomb runs stay bit for bit and skip the exponential).
  double stribeck_excess(double vr) const {
    return peak_ == 0.0 ? 0.0 : peak_ * std::exp(-vr * vr * inv_vs2_);
  }

  int a_, b_;
  double force_, v_eps_;
  double peak_;        ///< static - force (0: Coulomb, bit for bit)
  double inv_vs2_;     ///< 1 / v_s^2
};

/// @brief A linear spring-dashpot from a body to the ground (dof_b < 0) or to another body:
/// e.g. the impedance of the string above the top support (waves radiated away).
class SpringDashpot final : public ExtraForce {
 public:
  SpringDashpot(int dof_a, int dof_b, double k, double c);
  std::string name() const override { return "spring_dashpot"; }
  void add_force(double, double, const Vec7CRef& u, const Vec7CRef& v,
                 Vec7& f) const override;
  void add_jacobian(double, double, const Vec7CRef&, const Vec7CRef&, Mat7& dfdu,
                    Mat7& dfdv) const override;

 private:
  int a_, b_;
  double k_, c_;
};

using ExtraForcePtr = std::shared_ptr<const ExtraForce>;

}  // namespace vadsim
