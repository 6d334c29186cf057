#pragma once
/// @file contact_law.hpp
/// @brief Force laws of the impact surfaces behind one small interface, so that the model and
/// the integrator never need to know which law is in use.

#include <memory>

#include "vadsim/params.hpp"

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

/// @brief The law a surface gets for the chosen kind (the rock always keeps Kelvin-Voigt).
std::shared_ptr<const ContactLaw> make_contact_law(ContactLawKind kind, double k, double c,
                                                   const Params& p);

}  // namespace vadsim
