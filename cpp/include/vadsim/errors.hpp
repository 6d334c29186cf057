#pragma once
/// @file errors.hpp
/// @brief The ways a run can stop early (two failures and an interrupt), kept apart from the
/// solver and the options so that every layer (CVODE wrapper, event loop, recorder, bindings)
/// reports them the same way.

#include <stdexcept>
#include <string>

namespace vadsim {

/// @brief A failed SUNDIALS call or an exhausted budget: names the call, the time and why, so
/// that a failed sweep point can be reproduced from its message alone.
class SolverError : public std::runtime_error {
 public:
  SolverError(const std::string& call, double t, int flag, const std::string& why);
  double t() const { return t_; }
  int flag() const { return flag_; }

 private:
  double t_;
  int flag_;
};

/// @brief A run stopped because its interrupt check asked for it (Ctrl-C in Python): not a
/// failure of the solver or of the input. Says how far the run got, in time and steps.
class Interrupted : public std::runtime_error {
 public:
  Interrupted(double t, double t_end, long steps);
  double t() const { return t_; }
  double t_end() const { return t_end_; }
  long steps() const { return steps_; }

 private:
  double t_, t_end_;
  long steps_;
};

/// @brief Throws std::invalid_argument "option NAME = VALUE WHY": a bad option is the caller's
/// mistake (ValueError in Python), not a solver failure.
[[noreturn]] void fail_option(const char* name, double value, const char* why);

}  // namespace vadsim
