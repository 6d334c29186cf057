#pragma once
/// @file contact_law.hpp
/// @brief Force laws of the impact surfaces behind one small interface, so that the model and
/// the integrator never need to know which law is in use.

#include <memory>

#include "vadsim/params.hpp"
#include "vadsim/types.hpp"

namespace vadsim {

/// @brief Force and its partial derivatives at one contact (indentation d >= 0, rate dd).
struct ContactForce {
  double f = 0;      ///< force pushing the two bodies apart (N/kg)
  double df_dd = 0;  ///< d f / d d
  double df_ddd = 0; ///< d f / d d'
};

/// @brief A spring-dashpot contact law. Implementations are immutable and shared by threads.
///
/// A law that cannot pull (pushes_only) changes mode when its unclamped force crosses zero
/// while the surfaces overlap; push_indicator() is a smooth function with the sign of that
/// unclamped force, so the integrator can locate the switch exactly with a root function
/// instead of stepping across a kink.
class ContactLaw {
 public:
  virtual ~ContactLaw() = default;
  /// @brief Unclamped force and derivatives at indentation d (>= 0) and rate dd.
  virtual ContactForce eval(double d, double dd) const = 0;
  /// @brief True if the contact can only push (force clamped at 0).
  virtual bool pushes_only() const = 0;
  /// @brief Sign of the unclamped force; its zero is the lift-off of a pushes-only contact.
  virtual double push_indicator(double d, double dd) const = 0;
};

/// @brief k d + c d' (the dissertation's law); with tension or clamped at zero.
class KelvinVoigtLaw final : public ContactLaw {
 public:
  KelvinVoigtLaw(double k, double c, bool allow_tension) : k_(k), c_(c), tension_(allow_tension) {}
  ContactForce eval(double d, double dd) const override { return {k_ * d + c_ * dd, k_, c_}; }
  bool pushes_only() const override { return !tension_; }
  double push_indicator(double d, double dd) const override { return k_ * d + c_ * dd; }

 private:
  double k_, c_;
  bool tension_;
};

/// @brief Hunt-Crossley k d^n + lambda d^n d' with lambda = alpha k, clamped at zero.
///
/// Its damping vanishes with the indentation, so the force is continuous at first touch and
/// the coefficient of restitution falls with impact speed, as measured on steel impacts.
class HuntCrossleyLaw final : public ContactLaw {
 public:
  HuntCrossleyLaw(double k, double n, double alpha) : k_(k), n_(n), alpha_(alpha) {}
  ContactForce eval(double d, double dd) const override;
  bool pushes_only() const override { return true; }
  double push_indicator(double /*d*/, double dd) const override { return 1.0 + alpha_ * dd; }

 private:
  double k_, n_, alpha_;
};

/// @brief max(0, k d_c (d / d_c)^m + lambda (d / d_c)^s d') with lambda = factor * c, c the
/// surface's own damping: a family of dissipative laws indexed by how the spring and the
/// damping grow with indentation.
///
/// A field's contacts never follow one textbook law exactly, so a diagnosis needs a family
/// wide enough that a near miss of form still lands on the right physics: with the linear
/// spring (m = 1, k d), s = 0 is Kelvin-Voigt without tension (factor 1: the dissertation's k
/// and c, never pulling), s = 1 is Hunt-Crossley's damping on a linear spring (lambda d d':
/// continuous force at first touch, restitution falling with impact speed), s = 1.5 its
/// Hertzian form's exponent. m = 1.5 is Hertz's spring of two curved faces; m = s is
/// Hunt-Crossley's law k_h d^m (1 + alpha d') written with alpha = lambda / (k d_c).
/// d_c is a characteristic indentation that makes k and factor "the stiffness and the damping
/// at a typical impact", so that they stay nearly independent of m and s in a fit:
/// Params::pd_dc = 1 mm is the size of the 7in tool's impacts (peak indentations over
/// 200-650 gal/min: impact face 0.46-4.7 mm with median 1.1-1.7 mm at 350-500 gal/min,
/// recoil spring 1.4-5.3 mm, on-bottom shoulder 0.75-0.87 mm, the static 0.75 mm included).
///
/// The lift-off indicator is the unclamped force divided by (d / d_c)^min(m, s), a positive
/// function of d, so it stays smooth and non-zero at first touch: k d_c (d / d_c)^(m - s) +
/// lambda d' for s <= m (-> lambda d' at d = 0, the sign of the approach) and k d_c + lambda
/// (d / d_c)^(s - m) d' for s > m (-> k d_c > 0: the force never turns negative near first
/// touch because the damping vanishes faster than the spring).
class PowerDampingLaw final : public ContactLaw {
 public:
  /// @param k, c the surface's stiffness and damping; factor, shape, d_c, spring the family's
  /// Params::pd_factor, pd_shape, pd_dc, pd_spring (validated there).
  PowerDampingLaw(double k, double c, double factor, double shape, double d_c,
                  double spring = 1.0)
      : k_(k), lambda_(factor * c), s_(shape), m_(spring), inv_dc_(1.0 / d_c), k_dc_(k * d_c) {}
  ContactForce eval(double d, double dd) const override;
  bool pushes_only() const override { return true; }
  double push_indicator(double d, double dd) const override;

 private:
  double k_, lambda_, s_, m_, inv_dc_, k_dc_;
};

/// @brief The law surface s (a Surface) gets under Params::law, with its stiffness k and
/// damping c: the rock always keeps Kelvin-Voigt, and PowerDampingImpact gives the
/// power-damping law to the impact face alone (the others keep Kelvin-Voigt).
std::shared_ptr<const ContactLaw> make_contact_law(int s, double k, double c, const Params& p);

}  // namespace vadsim
