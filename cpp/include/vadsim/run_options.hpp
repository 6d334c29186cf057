#pragma once
/// @file run_options.hpp
/// @brief How to run one simulation: the horizon, the integration method and tolerances, and
/// what to record. Plain data, so that the bindings, the CVODE wrapper and the event loop can
/// share it without depending on each other.

#include <optional>

#include "vadsim/params.hpp"
#include "vadsim/types.hpp"

namespace vadsim {

/// @brief CVODE's linear multistep method.
enum class Method { BDF = 0, Adams = 1 };
/// @brief Which stored time series a run keeps (the summary and Poincare section always are).
enum class Record { None = 0, Window = 1, All = 2 };
/// @brief Whether a run may stop once its response is periodic (steady_state.hpp): Full
/// integrates every cycle (the dissertation's literal run); Auto stops at a confirmed periodic
/// orbit and builds the rest of the run from it.
enum class Steady { Full = 0, Auto = 1 };

/// @brief How to run: the horizon in excitation cycles and what to record.
struct RunOptions {
  double flow_gpm = 200;
  double cycles = 400;           ///< run length in excitation cycles
  double analyse_cycles = 200;   ///< the steady window: the last cycles of the run
  /// Adams by default: the stiffest mode (sub-LWD, ~1 kHz, damping ratio 0.13) must be resolved
  /// for accuracy anyway, and Adams then needs ~30 % fewer steps than BDF for the same answer.
  /// BDF is the choice for much stiffer parameter sets.
  Method method = Method::Adams;
  double rtol = 1e-6;
  /// On displacements (m); velocities get atol * 1000 1/s. 10 nm is 1e-6 of the 7in gap;
  /// tighter values multiply the steps without moving peaks or J* by more than 0.05 %.
  double atol = 1e-8;
  double max_step = 0;           ///< 0: CVODE's default (unbounded)
  Record record = Record::Window;
  double output_rate_hz = 20000; ///< stored time series (0: none)
  /// The stored series keep only t and the accelerations (x, v and the forces stay empty):
  /// what a sensor measures. Not writing the other 20 columns of each sample made a fresh
  /// vadsim_bench process 0.89x as long at 20 kHz (mostly fewer page faults) and a third of
  /// the memory; in a long diagnosis it saved about 1 %.
  bool accelerations_only = false;
  /// The grid of WindowSummary (MODEL.md "full resolution"); 0: no summary (J* is NaN and
  /// there are no peak windows), for runs measured from their stored series alone.
  double summary_rate_hz = 20000;
  double peak_window_s = 0.2;    ///< window of the peak statistics (dissertation section 3.2)
  long max_steps = 0;   ///< step budget, so that a pathological input cannot hang; 0: default
  long max_events = 0;  ///< contact event budget; 0: default
  std::optional<State> initial_state;  ///< absolute [x; v]; default: static equilibrium
  /// [u; v]: displacements from this run's own static state and velocities, instead of
  /// initial_state (not both). A warm start from another model's steady state: its motion
  /// about its static state carries over where the static state itself moved (a WOB or a
  /// length that changed it by centimetres would make an absolute state a violent kick).
  std::optional<State> initial_displacement;

  /// Stop at a periodic steady state (Steady::Auto) or integrate every cycle (Full).
  Steady steady = Steady::Auto;
  /// Longest orbit looked for, in excitation cycles (1..kMaxSteadyPeriod).
  int steady_max_period = 8;
  /// Cycles integrated before the first comparison: the start-up transient is never periodic,
  /// and a section that happens to repeat in it must not count.
  double steady_min_cycles = 5;
  /// Consecutive sections that must each repeat the one n cycles before, at least (and at
  /// least two whole orbits): with 2 a slowly converging transient could pass.
  int steady_confirm_cycles = 6;
  /// The confirmed section must also repeat the one at least this many cycles before (a
  /// whole number of orbits): a slowly converging orbit changes by less than the tolerance
  /// from one orbit to the next but not over many.
  int steady_drift_cycles = 12;
  /// Relative tolerance of a repeat, on each state component's amplitude over the last
  /// cycles (plus atol); 0: derived from rtol, kSteadyTolPerRtol * rtol within
  /// [kSteadyTolMin, kSteadyTolMax].
  double steady_tol = 0;
  /// Rate (Hz) of the orbit table a periodic run returns (RunResult::orbit_a): one orbit on a
  /// uniform grid of round(P * rate) points; 0: none.
  double orbit_rate_hz = 0;
  /// When the whole analysed window lies on the detected orbit, leave the stored output grid
  /// empty: the orbit table stands for it (a measurement reads the orbit, not 200 copies).
  bool orbit_replaces_window = false;

  static constexpr int kMaxSteadyPeriod = 32;
  /// A periodic 7in run at rtol 1e-6 repeats, cycle to cycle, to 4e-5-4e-3 of each
  /// component's amplitude (the ~1 kHz sub-LWD mode rings at every impact); at 1e-7 to
  /// 5e-7-2e-4. 1e-3 at rtol 1e-6 confirms as many orbits as 2e-3 or 3e-3 did (175 of 300
  /// random thesis-map points against 176-177) but not the slowly drifting ones those took:
  /// Z* then equal the full runs' everywhere, J* within 0.4 %.
  static constexpr double kSteadyTolPerRtol = 1e3;
  static constexpr double kSteadyTolMin = 1e-6;
  static constexpr double kSteadyTolMax = 5e-2;
  /// @brief The relative tolerance of a repeat that the run uses.
  double steady_tolerance() const;

  /// Default step budget per cycle: a valid run takes 20 to 4000 steps per cycle (7in tool,
  /// 1 to 5000 gal/min), so this only stops runs that are far off any valid one.
  static constexpr long kStepsPerCycle = 20000;
  /// The default step budget never goes below the fixed budget of old (20 million steps), so
  /// that short runs keep the room they always had.
  static constexpr long kMinStepBudget = 20000000;
  /// Default contact event budget: 200 per cycle plus 1000 (valid runs: at most ~15 per cycle).
  static constexpr long kEventsPerCycle = 200;

  /// @brief The run's step budget: max_steps if given, else grows with the run length,
  /// max(kMinStepBudget, kStepsPerCycle * ceil(cycles)).
  long step_budget() const;
  /// @brief The run's contact event budget: max_events if given, else
  /// kEventsPerCycle * ceil(cycles) + 1000.
  long event_budget() const;

  /// @brief Throws std::invalid_argument naming the bad option (each has a physical range).
  void validate() const;
  /// @brief validate(), and what depends on the model: the flow's excitation frequency must
  /// lie in [kMinExcitationHz, kMaxExcitationHz] (Params::check_flow).
  void validate(const Params& p) const;
};

}  // namespace vadsim
