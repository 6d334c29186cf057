#pragma once
/// @file model.hpp
/// @brief The 7-DOF vibro-impact model of MODEL.md as an immutable object: right-hand side,
/// analytic Jacobian and contact indentations for a given set of contact modes.
///
/// The state is u = x - x_static (displacements from the static on-bottom equilibrium) and v.
/// Absolute positions are ~3 m while the dynamics lives in millimetres: integrating
/// displacements keeps CVODE's relative tolerance meaningful.

#include <string>
#include <vector>

#include "vadsim/contact_geometry.hpp"
#include "vadsim/contact_law.hpp"
#include "vadsim/excitation.hpp"
#include "vadsim/extra_force.hpp"
#include "vadsim/params.hpp"
#include "vadsim/types.hpp"

namespace vadsim {

/// @brief Everything the right-hand side computes, for outputs and for the Jacobian.
struct Evaluation {
  Vec7 f;                              ///< total force per body (N/kg)
  Vec7 acc;                            ///< accelerations (m/s^2)
  std::array<double, kSurfaces> fc{};  ///< contact forces F_S, F_I, F_Off, F_On, F_R
  double fh = 0;                       ///< excitation force F_H
};

/// @brief Const model: built once from Params, evaluated by any number of threads.
class Model {
 public:
  /// @brief Validates the parameters (std::invalid_argument names the bad one).
  explicit Model(const Params& p, std::vector<ExtraForcePtr> extras = {});

  const Params& params() const { return p_; }
  const std::vector<ExtraForcePtr>& extras() const { return extras_; }

  /// @brief Static on-bottom positions (m), MODEL.md "The run" step 1.
  const Vec7& static_positions() const { return xs_; }
  /// @brief Position of the top support (m).
  double x_top() const { return x_top_; }
  /// @brief The excitation phase at rest theta0 the run uses (rad): Params::theta0 when set,
  /// else beta (x2 - x3)_rest + psi reduced to [0, 2 pi). Setting Params::theta0 to this
  /// value gives the same run bit for bit, whatever l0 then does.
  double rest_phase() const { return theta0_; }

  /// @brief Contact indentation d (m) and its rate d' (m/s) for a state [u; v].
  /// Inline: the root functions and the missed-crossing guard call these ~10 times a step.
  Indentation contact(int s, const Eigen::Ref<const State>& y) const { return geom_[s].at(y); }
  double indentation(int s, const Eigen::Ref<const State>& y) const { return geom_[s].at(y).d; }
  double indentation_rate(int s, const Eigen::Ref<const State>& y) const {
    return geom_[s].at(y).rate;
  }
  /// @brief Sign of the unclamped force of a pushes-only law (for its lift-off root).
  double push_indicator(int s, const Eigen::Ref<const State>& y) const;
  /// @brief True if the surface's law cannot pull (it has a Lifted mode).
  bool pushes_only(int s) const { return laws_[s]->pushes_only(); }

  /// @brief The mode a contact takes at a state where it sits exactly on its boundary.
  ContactMode mode_at(int s, const Eigen::Ref<const State>& y, double t, double flow_gpm,
                      const Modes& modes) const;

  /// @brief Forces and accelerations for the given contact modes.
  void evaluate(double t, double flow_gpm, const Eigen::Ref<const State>& y, const Modes& modes,
                Evaluation& out) const;
  /// @brief ydot = [v; a].
  void rhs(double t, double flow_gpm, const Eigen::Ref<const State>& y, const Modes& modes,
           Eigen::Ref<State> ydot) const;
  /// @brief d ydot / d y, analytic.
  void jacobian(double t, double flow_gpm, const Eigen::Ref<const State>& y, const Modes& modes,
                Eigen::Ref<Mat14> J) const;

  /// @brief Kinetic + elastic energy of the string and of the active contact springs (N m/kg):
  /// conserved when damping, excitation and drag are zero. Used by tests.
  double energy(const Eigen::Ref<const State>& y, const Modes& modes) const;

  const SurfaceGeometry& geometry(int s) const { return geom_[s]; }

  /// @brief Names of the surfaces in index order.
  static const char* surface_name(int s);

 private:
  Params p_;
  std::vector<ExtraForcePtr> extras_;
  Excitation exc_;
  std::array<std::shared_ptr<const ContactLaw>, kSurfaces> laws_;
  std::array<SurfaceGeometry, kSurfaces> geom_;
  Vec7 inv_mass_;
  Mat7 k_lin_, c_lin_;  // the string's springs and dashpots (constant)
  Vec7 f_static_;       // the string's spring forces at rest (its preload)
  double link_k_[5] = {}, link_c_[5] = {};  // k3..k7, c3..c7 of the chain's links
  Vec7 xs_;
  double x_top_ = 0;
  double rel23_static_ = 0;  // x2 - x3 at rest, m
  double theta0_ = 0;        // the excitation phase at rest (rad)
};

}  // namespace vadsim
