#pragma once
/// @file integrator.hpp
/// @brief CVODE with one root function per contact: every contact switch is located, the
/// contact mode flipped and the integrator re-initialised, so that between events CVODE
/// only ever sees a smooth right-hand side.

#include "vadsim/errors.hpp"
#include "vadsim/model.hpp"
#include "vadsim/results.hpp"
#include "vadsim/run_options.hpp"

namespace vadsim {

/// @brief Run the model from its static state (or initial_state) with the flow switched on
/// at t = 0. Thread-safe: each call owns its CVODE memory.
RunResult simulate(const Model& model, const RunOptions& opts);

}  // namespace vadsim
