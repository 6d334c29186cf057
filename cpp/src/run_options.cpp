#include "vadsim/run_options.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "vadsim/errors.hpp"

namespace vadsim {

long RunOptions::step_budget() const {
  if (max_steps > 0) return max_steps;
  // cycles <= 1e6 (validate): at most 2e10 steps, well inside a long.
  const double n = kStepsPerCycle * std::ceil(std::max(cycles, 0.0));
  return std::max(kMinStepBudget, static_cast<long>(std::min(n, 1e15)));
}

long RunOptions::event_budget() const {
  if (max_events > 0) return max_events;
  const double n = kEventsPerCycle * std::ceil(std::max(cycles, 0.0)) + 1000;
  return static_cast<long>(std::min(n, 1e15));
}

double RunOptions::steady_tolerance() const {
  if (steady_tol > 0) return steady_tol;
  return std::clamp(kSteadyTolPerRtol * rtol, kSteadyTolMin, kSteadyTolMax);
}

void RunOptions::validate() const {
  if (!(flow_gpm > 0) || !std::isfinite(flow_gpm)) fail_option("flow_gpm", flow_gpm, "must be > 0");
  if (!(cycles >= 1e-3) || !std::isfinite(cycles)) fail_option("cycles", cycles, "must be >= 0.001");
  if (cycles > 1e6) fail_option("cycles", cycles, "must be <= 1e6");
  if (!(analyse_cycles >= 1e-3) || analyse_cycles > cycles)
    fail_option("analyse_cycles", analyse_cycles, "must be in [0.001, cycles]");
  if (!(rtol >= 1e-14 && rtol <= 1e-1)) fail_option("rtol", rtol, "must be in [1e-14, 0.1]");
  // atol is on displacements: below 1e-20 m it asks for more digits than a double has at the
  // tool's scale (CVODE stalls at t = 0), above 1 m it controls nothing.
  if (!(atol >= 1e-20 && atol <= 1)) fail_option("atol", atol, "must be in [1e-20, 1] m");
  if (!(max_step == 0 || (max_step >= 1e-12 && max_step <= 1e6)))
    fail_option("max_step", max_step, "must be 0 (no limit) or in [1e-12, 1e6] s");
  if (!(output_rate_hz == 0 || (output_rate_hz >= 1e-3 && output_rate_hz <= 1e7)))
    fail_option("output_rate_hz", output_rate_hz, "must be 0 (none) or in [0.001, 1e7] Hz");
  if (!(summary_rate_hz == 0 || (summary_rate_hz >= 1e-3 && summary_rate_hz <= 1e7)))
    fail_option("summary_rate_hz", summary_rate_hz, "must be 0 (none) or in [0.001, 1e7] Hz");
  if (!(peak_window_s >= 1e-4 && peak_window_s <= 1e4))
    fail_option("peak_window_s", peak_window_s, "must be in [1e-4, 1e4] s");
  if (max_steps < 0)
    fail_option("max_steps", static_cast<double>(max_steps), "must be >= 0 (0: the default)");
  if (max_events < 0)
    fail_option("max_events", static_cast<double>(max_events), "must be >= 0 (0: the default)");
  if (steady != Steady::Full && steady != Steady::Auto)
    fail_option("steady", static_cast<double>(static_cast<int>(steady)), "must be Full or Auto");
  if (steady_max_period < 1 || steady_max_period > kMaxSteadyPeriod)
    fail_option("steady_max_period", steady_max_period, "must be in [1, 32] cycles");
  if (!(steady_min_cycles >= 0 && steady_min_cycles <= 1e6))
    fail_option("steady_min_cycles", steady_min_cycles, "must be in [0, 1e6] cycles");
  if (steady_confirm_cycles < 1 || steady_confirm_cycles > 2 * kMaxSteadyPeriod)
    fail_option("steady_confirm_cycles", steady_confirm_cycles, "must be in [1, 64] cycles");
  if (steady_drift_cycles < 1 || steady_drift_cycles > 3 * kMaxSteadyPeriod)
    fail_option("steady_drift_cycles", steady_drift_cycles, "must be in [1, 96] cycles");
  if (!(steady_tol == 0 || (steady_tol >= 1e-12 && steady_tol <= 1)))
    fail_option("steady_tol", steady_tol, "must be 0 (from rtol) or in [1e-12, 1]");
  if (!(orbit_rate_hz == 0 || (orbit_rate_hz >= 1e-3 && orbit_rate_hz <= 1e7)))
    fail_option("orbit_rate_hz", orbit_rate_hz, "must be 0 (none) or in [0.001, 1e7] Hz");
  if (initial_state && !initial_state->allFinite())
    throw std::invalid_argument("option initial_state must be finite");
  if (initial_displacement && !initial_displacement->allFinite())
    throw std::invalid_argument("option initial_displacement must be finite");
  if (initial_state && initial_displacement)
    throw std::invalid_argument("options initial_state and initial_displacement: give one");
}

void RunOptions::validate(const Params& p) const {
  validate();
  p.check_flow(flow_gpm);
}

}  // namespace vadsim
