#include "vadsim/model.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vadsim {

namespace {

/// wob / k, refusing a support that cannot carry the weight on bit, or only by a static
/// deflection beyond 1 km (the tool's lengths are bounded the same way, Params::validate).
double compliance_term(double wob, double k, const char* name) {
  if (wob == 0) return 0.0;
  if (k == 0) {
    std::ostringstream os;
    os << "parameter " << name << " = 0 gives no static on-bottom equilibrium under wob = " << wob;
    throw std::invalid_argument(os.str());
  }
  const double deflection = wob / k;
  if (deflection > 1e3) {
    std::ostringstream os;
    os << "parameter " << name << " = " << k << " N/m/kg gives a static deflection wob / " << name
       << " = " << deflection << " m under wob = " << wob << " N/kg: must be <= 1000 m";
    throw std::invalid_argument(os.str());
  }
  return deflection;
}

void add_link(Mat7& m, int i, int j, double k) {
  m(i, i) += k;
  if (j >= 0) {
    m(j, j) += k;
    m(i, j) -= k;
    m(j, i) -= k;
  }
}

}  // namespace

const char* Model::surface_name(int s) {
  static const char* names[kSurfaces] = {"spring", "impact", "off_bottom", "on_bottom", "rock"};
  return (s >= 0 && s < kSurfaces) ? names[s] : "?";
}

Model::Model(const Params& p, std::vector<ExtraForcePtr> extras)
    : p_(p), extras_(std::move(extras)), exc_(p, 0.0) {
  p_.validate();
  for (const auto& e : extras_)
    if (!e) throw std::invalid_argument("extra force is null");
  const double l0 = p_.l0, w = p_.wob;

  // MODEL.md "The run", step 1.
  xs_[0] = (p_.LR - p_.L1) * l0 + compliance_term(w, p_.kR, "kR");
  xs_[1] = xs_[0];
  xs_[2] = xs_[0] + (p_.LI + p_.LOn - p_.L3) * l0 + compliance_term(w, p_.kOn, "kOn");
  xs_[3] = xs_[2] + compliance_term(w, p_.k3, "k3");
  xs_[4] = xs_[3] + compliance_term(w, p_.k4, "k4");
  xs_[5] = xs_[4] + compliance_term(w, p_.k5, "k5");
  xs_[6] = xs_[5] + compliance_term(w, p_.k6, "k6");
  x_top_ = xs_[6] + compliance_term(w, p_.k7, "k7");
  rel23_static_ = xs_[1] - xs_[2];
  theta0_ = p_.theta0;
  if (std::isnan(theta0_)) {
    // The dissertation's psi at this rest state, reduced to [0, 2 pi): the same phase, a
    // readable number (theta0 +- pi is the same steady state but not the same run).
    theta0_ = std::fmod(p_.beta * rel23_static_ + p_.psi, 2.0 * M_PI);
    if (theta0_ < 0) theta0_ += 2.0 * M_PI;
  }
  exc_ = Excitation(p_, theta0_);

  const double m[kDof] = {p_.m1, p_.m2, p_.m3, p_.m4, p_.m5, p_.m6, p_.m7};
  for (int i = 0; i < kDof; ++i) inv_mass_[i] = 1.0 / m[i];

  k_lin_.setZero();
  c_lin_.setZero();
  const double ks[5] = {p_.k3, p_.k4, p_.k5, p_.k6, p_.k7};
  const double cs[5] = {p_.c3, p_.c4, p_.c5, p_.c6, p_.c7};
  for (int i = 0; i < 5; ++i) {
    const int a = 2 + i, b = (i < 4) ? 3 + i : -1;  // k3: x3-x4 ... k7: x7-support
    add_link(k_lin_, a, b, ks[i]);
    add_link(c_lin_, a, b, cs[i]);
    link_k_[i] = ks[i];
    link_c_[i] = cs[i];
  }
  f_static_ = -k_lin_ * xs_;
  f_static_[6] += p_.k7 * x_top_;

  // Indentations of MODEL.md's table, in absolute positions: d = sa x_a + sb x_b + off.
  const double off_abs[kSurfaces] = {(p_.spring_length() + p_.L2) * l0, 0.0, (p_.LI - p_.L3) * l0,
                                     (p_.L3 - p_.LI - p_.LOn) * l0, (p_.L1 - p_.LR) * l0};
  const int ia[kSurfaces] = {2, 1, 0, 2, 0}, ib[kSurfaces] = {1, 0, 2, 0, -1};
  for (int s = 0; s < kSurfaces; ++s) {
    SurfaceGeometry g{ia[s], ib[s], 1.0, ib[s] >= 0 ? -1.0 : 0.0, 0.0};
    // Not g.project(xs_) + off_abs: the sum's order fixes the offset's last bit.
    g.offset = off_abs[s] + g.sa * xs_[g.a] + (g.b >= 0 ? g.sb * xs_[g.b] : 0.0);
    geom_[s] = g;
  }
  const double kc[kSurfaces] = {p_.kS, p_.kI, p_.kOff, p_.kOn, p_.kR};
  const double cc[kSurfaces] = {p_.cS, p_.cI, p_.cOff, p_.cOn, p_.cR};
  for (int s = 0; s < kSurfaces; ++s) laws_[s] = make_contact_law(s, kc[s], cc[s], p_);
}

double Model::push_indicator(int s, const Eigen::Ref<const State>& y) const {
  const Indentation c = geom_[s].at(y);
  return laws_[s]->push_indicator(c.d, c.rate);
}

ContactMode Model::mode_at(int s, const Eigen::Ref<const State>& y, double t, double flow_gpm,
                           const Modes& modes) const {
  const Indentation c = geom_[s].at(y);
  const double tiny = 1e-13 * p_.l0;
  auto overlapping_mode = [&]() {
    if (laws_[s]->pushes_only() && laws_[s]->push_indicator(c.d, c.rate) < 0)
      return ContactMode::Lifted;
    return ContactMode::Pushing;
  };
  if (c.d > tiny) return overlapping_mode();
  if (c.d < -tiny) return ContactMode::Open;
  // On the boundary: the direction of travel decides, then the curvature with the contact open.
  const double vtiny = 1e-12;
  if (c.rate > vtiny) return overlapping_mode();
  if (c.rate < -vtiny) return ContactMode::Open;
  Modes trial = modes;
  trial[s] = ContactMode::Open;
  Evaluation e;
  evaluate(t, flow_gpm, y, trial, e);
  const double ddd = geom_[s].project(e.acc);
  return ddd > 0 ? overlapping_mode() : ContactMode::Open;
}

void Model::evaluate(double t, double flow_gpm, const Eigen::Ref<const State>& y,
                     const Modes& modes, Evaluation& out) const {
  const auto u = y.head<kDof>();
  const auto v = y.tail<kDof>();
  // The string is a chain (housing-motor-sub-LWD-MWD-support): link forces, not a dense 7x7
  // product. Its preload at rest (f_static_) is a constant; the contacts carry their full force.
  out.f = f_static_;
  for (int i = 0; i < 4; ++i) {
    const int a = 2 + i, b = 3 + i;
    const double F = link_k_[i] * (u[a] - u[b]) + link_c_[i] * (v[a] - v[b]);
    out.f[a] -= F;
    out.f[b] += F;
  }
  out.f[6] -= link_k_[4] * u[6] + link_c_[4] * v[6];
  for (int s = 0; s < kSurfaces; ++s) {
    double F = 0;
    if (modes[s] == ContactMode::Pushing) {
      const auto& g = geom_[s];
      const Indentation c = g.at(y);
      F = laws_[s]->eval(c.d, c.rate).f;
      out.f[g.a] -= F * g.sa;
      if (g.b >= 0) out.f[g.b] -= F * g.sb;
    }
    out.fc[s] = F;
  }
  out.fh = exc_.force(t, flow_gpm, u[1] - u[2]);
  double ddrag;
  out.f[1] += out.fh - exc_.drag(v[1], ddrag);
  if (!extras_.empty()) {
    const Vec7CRef uu(u), vv(v);  // views of y, not copies
    for (const auto& e : extras_) e->add_force(t, flow_gpm, uu, vv, out.f);
  }
  out.acc = out.f.cwiseProduct(inv_mass_);
}

void Model::rhs(double t, double flow_gpm, const Eigen::Ref<const State>& y, const Modes& modes,
                Eigen::Ref<State> ydot) const {
  Evaluation e;
  evaluate(t, flow_gpm, y, modes, e);
  ydot.head<kDof>() = y.tail<kDof>();
  ydot.tail<kDof>() = e.acc;
}

void Model::jacobian(double t, double flow_gpm, const Eigen::Ref<const State>& y,
                     const Modes& modes, Eigen::Ref<Mat14> J) const {
  const auto u = y.head<kDof>();
  const auto v = y.tail<kDof>();
  Mat7 dfdx = -k_lin_, dfdv = -c_lin_;
  for (int s = 0; s < kSurfaces; ++s) {
    if (modes[s] != ContactMode::Pushing) continue;
    const auto& g = geom_[s];
    const Indentation c = g.at(y);
    const ContactForce cf = laws_[s]->eval(c.d, c.rate);
    const int idx[2] = {g.a, g.b};
    const double sg[2] = {g.sa, g.sb};
    for (int i = 0; i < 2; ++i) {
      if (idx[i] < 0) continue;
      for (int j = 0; j < 2; ++j) {
        if (idx[j] < 0) continue;
        dfdx(idx[i], idx[j]) -= cf.df_dd * sg[i] * sg[j];
        dfdv(idx[i], idx[j]) -= cf.df_ddd * sg[i] * sg[j];
      }
    }
  }
  double dfh, ddrag;
  exc_.force(t, flow_gpm, u[1] - u[2], dfh);
  exc_.drag(v[1], ddrag);
  dfdx(1, 1) += dfh;
  dfdx(1, 2) -= dfh;
  dfdv(1, 1) -= ddrag;
  if (!extras_.empty()) {
    const Vec7CRef uu(u), vv(v);  // views of y, not copies
    for (const auto& e : extras_) e->add_jacobian(t, flow_gpm, uu, vv, dfdx, dfdv);
  }
  J.setZero();
  J.topRightCorner<kDof, kDof>().setIdentity();
  J.bottomLeftCorner<kDof, kDof>() = inv_mass_.asDiagonal() * dfdx;
  J.bottomRightCorner<kDof, kDof>() = inv_mass_.asDiagonal() * dfdv;
}

double Model::energy(const Eigen::Ref<const State>& y, const Modes& modes) const {
  const double m[kDof] = {p_.m1, p_.m2, p_.m3, p_.m4, p_.m5, p_.m6, p_.m7};
  double e = 0;
  for (int i = 0; i < kDof; ++i) e += 0.5 * m[i] * y[kDof + i] * y[kDof + i];
  const Vec7 x = xs_ + y.head<kDof>();
  const double ks[5] = {p_.k3, p_.k4, p_.k5, p_.k6, p_.k7};
  for (int i = 0; i < 5; ++i) {
    const double ext = (i < 4) ? x[2 + i] - x[3 + i] : x[6] - x_top_;
    e += 0.5 * ks[i] * ext * ext;
  }
  const double kc[kSurfaces] = {p_.kS, p_.kI, p_.kOff, p_.kOn, p_.kR};
  for (int s = 0; s < kSurfaces; ++s) {
    if (modes[s] == ContactMode::Open) continue;
    const double d = indentation(s, y);
    e += 0.5 * kc[s] * d * d;
  }
  return e;
}

}  // namespace vadsim
