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
