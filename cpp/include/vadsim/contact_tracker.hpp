#pragma once
/// @file contact_tracker.hpp
/// @brief The contact modes of a run and the events that switch them: CVODE's root functions,
/// what a reported root means for each surface, and the guard that finds a crossing CVODE did
/// not report.
///
/// A contact whose indentation is exactly zero when CVODE restarts has its root function
/// switched off until it moves away from zero, and CVODE then turns it back on without
/// reporting the crossing (e.g. a bit resting on the rock with zero force, pushed by the
/// anvil's first impact). Two guards: such contacts get their mode from Model::mode_at() at
/// every restart, and after every step each mode is checked against the sign of its
/// indentation, a disagreement being located by bisection on CVODE's interpolant.

#include <vector>

#include "vadsim/model.hpp"
#include "vadsim/results.hpp"
#include "vadsim/trajectory.hpp"

namespace vadsim {

/// @brief A contact switch CVODE stepped over.
struct MissedCrossing {
  int surface;  ///< the first surface to switch (-1: none)
  double t;     ///< its crossing time (s)
};

/// @brief Owns the modes CVODE's callbacks read, and appends every switch to the event list.
class ContactTracker {
 public:
  /// @brief events is the run's event table (RunResult::events).
  ContactTracker(const Model& model, double flow_gpm, std::vector<ContactEvent>& events);

  /// @brief The modes at the initial state y0 (t = 0): from the indentations' signs, then
  /// refined surface by surface with Model::mode_at().
  void start(const State& y0);

  const Modes& modes() const { return modes_; }
  /// @brief kSurfaces indentation roots, plus one lift-off root per surface if any law
  /// pushes only.
  int n_roots() const { return n_roots_; }

  /// @brief CVODE's root functions at y: the indentations, then (pushes-only laws) the sign
  /// of the unclamped force of each overlapping surface. Inline: CVODE calls it more often
  /// than the right-hand side, and it then compiles into the root callback.
  void roots(const Eigen::Ref<const State>& y, double* g) const {
    for (int s = 0; s < kSurfaces; ++s) g[s] = model_.indentation(s, y);
    for (int s = 0; 2 * kSurfaces <= n_roots_ && s < kSurfaces; ++s) {
      const bool live = model_.pushes_only(s) && modes_[s] != ContactMode::Open;
      g[kSurfaces + s] = live ? model_.push_indicator(s, y) : 1.0;
    }
  }

  /// @brief Switch the surfaces whose roots CVODE reported at (t, y) (found as from
  /// CVodeGetRootInfo), then settle any other surface sitting on its boundary.
  void apply_roots(const int* found, double t, const State& y);

  /// @brief The earliest surface whose mode contradicts its indentation at the end of the step
  /// (t_prev, t_step], located by bisection; surface -1 if none.
  MissedCrossing find_missed(double t_prev, double t_step, const Eigen::Ref<const State>& y_step,
                             const Trajectory& segment);

  /// @brief Switch the surface of a missed crossing at its state y, then settle any other
  /// surface sitting on its boundary.
  void apply_missed(const MissedCrossing& c, const State& y);

 private:
  /// @brief True if the sign of the indentation disagrees with the mode (beyond rounding).
  /// Inline: checked for every surface after every step.
  bool contradicts(int s, const Eigen::Ref<const State>& y) const {
    const double d = model_.indentation(s, y);
    return (modes_[s] == ContactMode::Open) ? d > tiny_ : d < -tiny_;
  }
  /// @brief The mode of a surface that has just started to overlap.
  ContactMode entered_mode(int s, const State& y) const;
  /// @brief Record an event and set the mode if next differs from the current mode.
  void switch_mode(int s, ContactMode next, double t, const State& y);
  /// @brief Surfaces exactly on their boundary (skip[s] == 0 or no skip) take Model::mode_at().
  void resolve_boundaries(double t, const State& y, const int* skip);

  const Model& model_;
  double flow_gpm_;
  double tiny_;  ///< indentation (m) below which a surface counts as on its boundary
  int n_roots_ = kSurfaces;
  Modes modes_{};
  std::vector<ContactEvent>& events_;
};

}  // namespace vadsim
