#include "vadsim/errors.hpp"

#include <sstream>

namespace vadsim {

SolverError::SolverError(const std::string& call, double t, int flag, const std::string& why)
    : std::runtime_error([&] {
        std::ostringstream os;
        os << call << " failed at t = " << t << " s";
        if (flag != 0) os << " (flag " << flag << ")";
        if (!why.empty()) os << ": " << why;
        return os.str();
      }()),
      t_(t),
      flag_(flag) {}

Interrupted::Interrupted(double t, double t_end, long steps)
    : std::runtime_error([&] {
        std::ostringstream os;
        os << "simulation interrupted at t = " << t << " s of t_end = " << t_end << " s, after "
           << steps << " steps";
        return os.str();
      }()),
      t_(t),
      t_end_(t_end),
      steps_(steps) {}

void fail_option(const char* name, double value, const char* why) {
  std::ostringstream os;
  os << "option " << name << " = " << value << " " << why;
  throw std::invalid_argument(os.str());
}

}  // namespace vadsim
