#include "vadsim/extra_force.hpp"

#include <cmath>
#include <stdexcept>

namespace vadsim {

namespace {
void check_dof(int dof, const char* what, bool allow_ground) {
  if (dof >= kDof || dof < (allow_ground ? -1 : 0)) {
    throw std::invalid_argument(std::string(what) + " = " + std::to_string(dof + 1) +
                                " is not a degree of freedom (1..7)");
  }
}
void check_nonneg(double v, const char* what) {
  if (!(v >= 0) || !std::isfinite(v))
    throw std::invalid_argument(std::string(what) + " = " + std::to_string(v) +
                                " must be finite and >= 0");
}
}  // namespace

HydraulicForce::HydraulicForce(int dof, double c) : dof_(dof), c_(c) {
  check_dof(dof, "hydraulic_force dof", false);
  if (!std::isfinite(c)) throw std::invalid_argument("hydraulic_force c must be finite");
}

CoulombFriction::CoulombFriction(int a, int b, double force, double v_eps)
    : a_(a), b_(b), force_(force), v_eps_(v_eps) {
  check_dof(a, "coulomb_friction dof_a", false);
  check_dof(b, "coulomb_friction dof_b", true);
  check_nonneg(force, "coulomb_friction force");
  if (!(v_eps > 0)) throw std::invalid_argument("coulomb_friction v_eps must be > 0");
}

void CoulombFriction::add_force(double, double, const Vec7CRef&, const Vec7CRef& v,
                                Vec7& f) const {
  const double vr = v[a_] - (b_ >= 0 ? v[b_] : 0.0);
  const double F = force_ * std::tanh(vr / v_eps_);
  f[a_] -= F;
  if (b_ >= 0) f[b_] += F;
}

void CoulombFriction::add_jacobian(double, double, const Vec7CRef&, const Vec7CRef& v, Mat7&,
                                   Mat7& dfdv) const {
  const double vr = v[a_] - (b_ >= 0 ? v[b_] : 0.0);
  const double th = std::tanh(vr / v_eps_);
  const double g = force_ * (1.0 - th * th) / v_eps_;  // dF/dvr
  dfdv(a_, a_) -= g;
  if (b_ >= 0) {
    dfdv(a_, b_) += g;
    dfdv(b_, a_) += g;
    dfdv(b_, b_) -= g;
  }
}

SpringDashpot::SpringDashpot(int a, int b, double k, double c) : a_(a), b_(b), k_(k), c_(c) {
  check_dof(a, "spring_dashpot dof_a", false);
  check_dof(b, "spring_dashpot dof_b", true);
  check_nonneg(k, "spring_dashpot k");
  check_nonneg(c, "spring_dashpot c");
}

void SpringDashpot::add_force(double, double, const Vec7CRef& u, const Vec7CRef& v,
                              Vec7& f) const {
  const double du = u[a_] - (b_ >= 0 ? u[b_] : 0.0);
  const double dv = v[a_] - (b_ >= 0 ? v[b_] : 0.0);
  const double F = k_ * du + c_ * dv;
  f[a_] -= F;
  if (b_ >= 0) f[b_] += F;
}

void SpringDashpot::add_jacobian(double, double, const Vec7CRef&, const Vec7CRef&, Mat7& dfdu,
                                 Mat7& dfdv) const {
  dfdu(a_, a_) -= k_;
  dfdv(a_, a_) -= c_;
  if (b_ >= 0) {
    dfdu(a_, b_) += k_;
    dfdu(b_, a_) += k_;
    dfdu(b_, b_) -= k_;
    dfdv(a_, b_) += c_;
    dfdv(b_, a_) += c_;
    dfdv(b_, b_) -= c_;
  }
}

}  // namespace vadsim
