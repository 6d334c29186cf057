#include "vadsim/contact_law.hpp"

#include <cmath>

namespace vadsim {

ContactForce HuntCrossleyLaw::eval(double d, double dd) const {
  // Roots are located on the far side of a crossing, but a rounding error can still leave
  // d a hair below zero: d^n must not become NaN there.
  const double dp = d > 0 ? d : 0.0;
  const double dn = (n_ == 1.0) ? dp : std::pow(dp, n_);
  const double ddn = (n_ == 1.0) ? 1.0 : (dp > 0 ? n_ * dn / dp : 0.0);
  const double g = 1.0 + alpha_ * dd;
  return {k_ * dn * g, k_ * ddn * g, k_ * dn * alpha_};
}

ContactForce PowerDampingLaw::eval(double d, double dd) const {
  // As in Hunt-Crossley, d may be a hair below zero after a located root: (d/d_c)^s at d < 0
  // would be NaN. w = (d / d_c)^s and dw = d w / d d; s = 0 and 1 skip pow (exact, cheap).
  const double dp = d > 0 ? d : 0.0;
  double w = 1.0, dw = 0.0;
  if (s_ == 1.0) {
    w = dp * inv_dc_;
    dw = inv_dc_;
  } else if (s_ != 0.0) {
    w = std::pow(dp * inv_dc_, s_);
    dw = dp > 0 ? s_ * w / dp : 0.0;  // unbounded as d -> 0 for s < 1: its limit is not used
  }
  if (m_ == 1.0) return {k_ * d + lambda_ * w * dd, k_ + lambda_ * dw * dd, lambda_ * w};
  // k d_c (d/d_c)^m: its slope k m (d/d_c)^(m-1) is 0 at first touch for m > 1.
  const double x = dp * inv_dc_, x_m1 = std::pow(x, m_ - 1.0);
  return {k_dc_ * x * x_m1 + lambda_ * w * dd, k_ * m_ * x_m1 + lambda_ * dw * dd, lambda_ * w};
}

double PowerDampingLaw::push_indicator(double d, double dd) const {
  // Kelvin-Voigt without tension, bit for bit
  if (s_ == 0.0 && m_ == 1.0) return k_ * d + lambda_ * dd;
  const double dp = d > 0 ? d : 0.0;
  if (s_ <= m_) return k_dc_ * std::pow(dp * inv_dc_, m_ - s_) + lambda_ * dd;
  return k_dc_ + lambda_ * std::pow(dp * inv_dc_, s_ - m_) * dd;
}

std::shared_ptr<const ContactLaw> make_contact_law(int s, double k, double c, const Params& p) {
  ContactLawKind kind = (s == kRock) ? ContactLawKind::KelvinVoigt : p.law;
  if (kind == ContactLawKind::PowerDampingImpact)
    kind = (s == kImpact) ? ContactLawKind::PowerDamping : ContactLawKind::KelvinVoigt;
  switch (kind) {
    case ContactLawKind::KelvinVoigtNoTension:
      return std::make_shared<KelvinVoigtLaw>(k, c, false);
    case ContactLawKind::HuntCrossley:
      return std::make_shared<HuntCrossleyLaw>(k, p.hc_n, p.hc_alpha);
    case ContactLawKind::PowerDamping:
      return std::make_shared<PowerDampingLaw>(k, c, p.pd_factor, p.pd_shape, p.pd_dc,
                                               p.pd_spring);
    case ContactLawKind::KelvinVoigt:
    default:
      return std::make_shared<KelvinVoigtLaw>(k, c, true);
  }
}

}  // namespace vadsim
