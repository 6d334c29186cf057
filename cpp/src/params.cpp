#include "vadsim/params.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vadsim {

namespace {
using R = ParamInfo::Rule;
}  // namespace

const std::vector<ParamInfo>& param_table() {
  static const std::vector<ParamInfo> table = {
      {"m1", "m*", "bit assembly mass", R::Positive, &Params::m1},
      {"m2", "m*", "anvil mass", R::Positive, &Params::m2},
      {"m3", "m*", "housing mass", R::Positive, &Params::m3},
      {"m4", "m*", "PDM mass", R::Positive, &Params::m4},
      {"m5", "m*", "measurement sub mass", R::Positive, &Params::m5},
      {"m6", "m*", "LWD mass", R::Positive, &Params::m6},
      {"m7", "m*", "MWD mass", R::Positive, &Params::m7},
      {"k3", "N/m/kg", "housing-PDM stiffness", R::NonNegative, &Params::k3},
      {"k4", "N/m/kg", "PDM-sub stiffness", R::NonNegative, &Params::k4},
      {"k5", "N/m/kg", "sub-LWD stiffness", R::NonNegative, &Params::k5},
      {"k6", "N/m/kg", "LWD-MWD stiffness", R::NonNegative, &Params::k6},
      {"k7", "N/m/kg", "MWD-support stiffness", R::NonNegative, &Params::k7},
      {"kS", "N/m/kg", "recoil spring stiffness (#1)", R::NonNegative, &Params::kS},
      {"kI", "N/m/kg", "impact face stiffness (#2)", R::NonNegative, &Params::kI},
      {"kOn", "N/m/kg", "on-bottom shoulder stiffness (#4)", R::NonNegative, &Params::kOn},
      {"kOff", "N/m/kg", "off-bottom shoulder stiffness (#3)", R::NonNegative, &Params::kOff},
      {"kR", "N/m/kg", "rock stiffness", R::NonNegative, &Params::kR},
      {"c3", "N s/m/kg", "housing-PDM damping", R::NonNegative, &Params::c3},
      {"c4", "N s/m/kg", "PDM-sub damping", R::NonNegative, &Params::c4},
      {"c5", "N s/m/kg", "sub-LWD damping", R::NonNegative, &Params::c5},
      {"c6", "N s/m/kg", "LWD-MWD damping", R::NonNegative, &Params::c6},
      {"c7", "N s/m/kg", "MWD-support damping", R::NonNegative, &Params::c7},
      {"cS", "N s/m/kg", "recoil spring damping", R::NonNegative, &Params::cS},
      {"cI", "N s/m/kg", "impact face damping", R::NonNegative, &Params::cI},
      {"cOn", "N s/m/kg", "on-bottom shoulder damping", R::NonNegative, &Params::cOn},
      {"cOff", "N s/m/kg", "off-bottom shoulder damping", R::NonNegative, &Params::cOff},
      {"cR", "N s/m/kg", "rock damping", R::NonNegative, &Params::cR},
      {"cD", "N s^2/m^2/kg", "anvil fluid drag coefficient", R::NonNegative, &Params::cD},
      {"Fo", "N/kg", "excitation force amplitude", R::NonNegative, &Params::Fo},
      {"alpha", "(rad/s)/(gal/min)", "flow to excitation angular frequency", R::Positive,
       &Params::alpha},
      {"beta", "1/m", "displacement to phase", R::Finite, &Params::beta},
      {"phi", "rad", "excitation phase", R::Finite, &Params::phi},
      {"psi", "rad", "position phase", R::Finite, &Params::psi},
      {"L1", "l0", "top to bit", R::Finite, &Params::L1},
      {"L2", "l0", "anvil length above its impact face", R::Finite, &Params::L2},
      {"L3", "l0", "housing length to shoulders", R::Finite, &Params::L3},
      {"LS", "l0", "recoil spring length", R::Finite, &Params::LS},
      {"LI", "l0", "distance between surfaces #2 and #3", R::Finite, &Params::LI},
      {"LOn", "l0", "travel between on- and off-bottom shoulders", R::NonNegative,
       &Params::LOn},
      {"LR", "l0", "support to rock", R::Finite, &Params::LR},
      {"l0", "m", "standard length", R::Positive, &Params::l0},
      {"wob", "N/kg", "weight on bit per unit reference mass", R::NonNegative, &Params::wob},
      {"hc_n", "-", "Hunt-Crossley exponent", R::Exponent, &Params::hc_n},
      {"hc_alpha", "s/m", "Hunt-Crossley damping factor", R::NonNegative, &Params::hc_alpha},
  };
  return table;
}

double Params::excitation_hz(double flow_gpm) const {
  return alpha * flow_gpm / (2.0 * M_PI);
}

void Params::validate() const {
  for (const auto& info : param_table()) {
    const double v = this->*info.member;
    const char* why = nullptr;
    if (!std::isfinite(v)) {
      why = "must be finite";
    } else {
      switch (info.rule) {
        case R::Positive:
          if (!(v > 0)) why = "must be > 0";
          break;
        case R::NonNegative:
          if (v < 0) why = "must be >= 0";
          break;
        case R::Exponent:
          if (v < 1.0 || v > 3.0) why = "must be in [1, 3]";
          break;
        case R::Finite:
          break;
      }
    }
    // The static on-bottom state needs every support in the load path to carry the WOB.
    if (!why && v == 0 && wob > 0) {
      const std::string n = info.name;
      if (n == "kR" || n == "kOn" || n == "k3" || n == "k4" || n == "k5" || n == "k6" || n == "k7")
        why = "gives no static on-bottom equilibrium under wob > 0";
    }
    if (why) {
      std::ostringstream os;
      os << "parameter " << info.name << " = " << v << " " << why << " (" << info.meaning << ", "
         << info.unit << ")";
      throw std::invalid_argument(os.str());
    }
  }
}

double get_param(const Params& p, const std::string& name) {
  for (const auto& info : param_table())
    if (name == info.name) return p.*info.member;
  throw std::invalid_argument("unknown parameter '" + name + "'");
}

void set_param(Params& p, const std::string& name, double value) {
  for (const auto& info : param_table()) {
    if (name == info.name) {
      p.*info.member = value;
      return;
    }
  }
  throw std::invalid_argument("unknown parameter '" + name + "'");
}

}  // namespace vadsim
