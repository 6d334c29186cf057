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

std::shared_ptr<const ContactLaw> make_contact_law(ContactLawKind kind, double k, double c,
                                                   const Params& p) {
  switch (kind) {
    case ContactLawKind::KelvinVoigtNoTension:
      return std::make_shared<KelvinVoigtLaw>(k, c, false);
    case ContactLawKind::HuntCrossley:
      return std::make_shared<HuntCrossleyLaw>(k, p.hc_n, p.hc_alpha);
    case ContactLawKind::KelvinVoigt:
    default:
      return std::make_shared<KelvinVoigtLaw>(k, c, true);
  }
}

}  // namespace vadsim
