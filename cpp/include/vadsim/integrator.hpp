#pragma once
/// @file integrator.hpp
/// @brief CVODE with one root function per contact: every contact switch is located, the
/// contact mode flipped and the integrator re-initialised, so that between events CVODE
/// only ever sees a smooth right-hand side.

#include <functional>

#include "vadsim/errors.hpp"
#include "vadsim/model.hpp"
#include "vadsim/results.hpp"
#include "vadsim/run_options.hpp"

namespace vadsim {

/// @brief Asked now and then during a run whether to stop it: true stops the run with
/// Interrupted. It may also throw, and its exception then leaves simulate() as it is.
using InterruptCheck = std::function<bool()>;

/// @brief How many CVODE steps pass between two interrupt checks: a few milliseconds of
/// integration, so that a stop request is honoured at once while the check costs nothing.
constexpr long kInterruptCheckEvery = 2000;

/// @brief Run the model from its static state (or initial_state) with the flow switched on
/// at t = 0. Thread-safe: each call owns its CVODE memory. interrupted, when given, is called
/// every kInterruptCheckEvery steps (the Python binding checks for Ctrl-C there); an empty
/// check (the default) costs nothing and needs no Python.
RunResult simulate(const Model& model, const RunOptions& opts,
                   const InterruptCheck& interrupted = {});

}  // namespace vadsim
