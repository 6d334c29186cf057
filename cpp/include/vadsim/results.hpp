#pragma once
/// @file results.hpp
/// @brief What one run returns: sampled outputs, the exact event table, the once-per-cycle
/// Poincare section, steady-window summaries and solver statistics.

#include <Eigen/Dense>
#include <vector>

#include "vadsim/types.hpp"

namespace vadsim {

/// @brief Kinds of contact event located by root-finding.
enum class EventKind : int {
  Onset = 0,    ///< d crosses 0 upwards: an impact (MODEL.md)
  Release = 1,  ///< d crosses 0 downwards
  Lift = 2,     ///< a pushes-only law reaches zero force while overlapping
  Relatch = 3   ///< its force becomes positive again while still overlapping
};

/// @brief One contact switch, located to CVODE's root tolerance.
struct ContactEvent {
  double t;             ///< time (s)
  int surface;          ///< 0 spring, 1 impact face, 2 off-bottom, 3 on-bottom, 4 rock
  EventKind kind;
  double rel_velocity;  ///< d' at the event (m/s): impact speed for an onset
};

/// @brief Solver statistics summed over every re-initialisation of one run.
struct SolverStats {
  long steps = 0, rhs_evals = 0, jac_evals = 0, lin_setups = 0, err_test_fails = 0;
  long nonlin_iters = 0, nonlin_conv_fails = 0, root_evals = 0, reinits = 0;
};

using RowMat7 = Eigen::Matrix<double, Eigen::Dynamic, kDof, Eigen::RowMajor>;
using RowMat5 = Eigen::Matrix<double, Eigen::Dynamic, kSurfaces, Eigen::RowMajor>;
using RowMat14 = Eigen::Matrix<double, Eigen::Dynamic, kState, Eigen::RowMajor>;

/// @brief Steady-window features computed on the fly on a fine grid, so sweeps need not
/// store time series.
struct WindowSummary {
  double t0 = 0, t1 = 0;     ///< the analysed window (s)
  double rate_hz = 0;        ///< the summary grid's rate
  long samples = 0;
  std::array<long, kSurfaces> onsets{};  ///< impacts per surface inside the window
  double impulse_mean = 0;   ///< mean of F_I over the window (N/kg): J* plain
  double impulse_pos = 0;    ///< mean of max(F_I, 0) (N/kg): J* of compressive force
  RowMat7 window_peaks;      ///< max |a| (m/s^2) per full 200 ms window, per dof
};

/// @brief What the steady-state engine did (RunOptions::steady): whether the run stopped at a
/// periodic orbit, where, and how closely the orbit repeated.
struct SteadyInfo {
  bool enabled = false;         ///< RunOptions::steady was Auto
  int period = 0;               ///< cycles of the detected orbit; 0: none, the run is literal
  double detected_cycle = 0;    ///< where the orbit recorded for the rest starts (t / period)
  double stopped_cycle = 0;     ///< where integration stopped (t / period); cycles if it did not
  double residual = 0;          ///< largest repeat difference over its component's amplitude
  double tolerance = 0;         ///< the relative tolerance residual was held to
  bool window_on_orbit = false; ///< the whole analysed window is built from the orbit
};

/// @brief Everything one run produces. Positions are absolute (m), as in MODEL.md.
struct RunResult {
  double flow_gpm = 0, f_exc_hz = 0, t_end = 0;
  Eigen::VectorXd t;   ///< output grid (s)
  RowMat7 x, v, a;     ///< positions (m), velocities (m/s), accelerations (m/s^2)
  RowMat5 fc;          ///< contact forces F_S, F_I, F_Off, F_On, F_R (N/kg)
  Eigen::VectorXd fh;  ///< excitation force (N/kg)
  Eigen::VectorXd poincare_t;  ///< times k / f_exc, k = 0..cycles
  RowMat14 poincare;           ///< state [x; v] at those times
  std::vector<ContactEvent> events;
  WindowSummary summary;
  SolverStats stats;
  State y_end;  ///< final [x; v], to continue a sweep from
  Vec7 x_static = Vec7::Zero();  ///< the static positions (m) the run's displacements are from
  SteadyInfo steady;
  /// One period of the detected orbit on a uniform grid (RunOptions::orbit_rate_hz):
  /// orbit_t[j] = start + j P / M (absolute s), orbit_a the accelerations there (m/s^2).
  /// Empty without an orbit.
  Eigen::VectorXd orbit_t;
  RowMat7 orbit_a;
  /// The orbit's corners: the times inside the period where a contact closes or opens, and the
  /// accelerations (m/s^2) just before and just after. A Kelvin-Voigt force jumps there, so a
  /// uniform table alone smears the peak over a spacing; with the corners, interpolation
  /// between the table and the corners keeps it (vadsim.model.result.Orbit.at).
  Eigen::VectorXd orbit_corner_t;
  RowMat7 orbit_corner_before;
  RowMat7 orbit_corner_after;
  double orbit_period_s = 0;  ///< P = period / f_exc (s); 0 without an orbit
};

}  // namespace vadsim
