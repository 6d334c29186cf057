#include "vadsim/params.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vadsim {

namespace {
using R = ParamInfo::Rule;

// Physical ranges. Wide (the presets sit orders of magnitude inside them, and the fuzz scales
// every parameter by up to 10^3 each way), but they keep out the numbers that break the
// arithmetic rather than the physics: subnormal masses or stiffnesses (1/m overflows,
// k/m is inf or 0) and values near the limits of double precision.
constexpr double kMass[2] = {1e-6, 1e6};        // m*
constexpr double kStiff[2] = {1e-6, 1e15};      // N/m/kg, or 0
constexpr double kDamp[2] = {1e-9, 1e12};       // N s/m/kg, or 0
constexpr double kDrag[2] = {1e-12, 1e9};       // N s^2/m^2/kg, or 0
constexpr double kForce[2] = {1e-9, 1e9};       // N/kg, or 0 (1e9 N/kg is 1e8 g)
constexpr double kAlpha[2] = {1e-6, 1e4};       // (rad/s)/(gal/min)
constexpr double kBeta[2] = {-1e6, 1e6};        // 1/m
constexpr double kPhase[2] = {-1e6, 1e6};       // rad
constexpr double kLength[2] = {-1e6, 1e6};      // l0 (and |L| l0 <= kMaxLengthM)
constexpr double kTravel[2] = {0.0, 1e6};       // l0
constexpr double kL0[2] = {1e-6, 1e3};          // m
constexpr double kExponent[2] = {1.0, 3.0};     // -
constexpr double kHcAlpha[2] = {1e-12, 1e6};    // s/m, or 0
constexpr double kPdFactor[2] = {1e-9, 1e6};    // -, or 0 (on a damping of at most 1e12)
// s = 0 is Kelvin-Voigt without tension, s = 1 Hunt-Crossley's damping on a linear spring,
// s = 1.5 its Hertzian form's (lambda d^1.5); 2 leaves room above that. Beyond it the
// damping is negligible over most of a contact and the law a spring in disguise.
constexpr double kPdShape[2] = {0.0, 2.0};      // -
// m = 1 is a linear spring, 1.5 Hertz's curved faces, 10/9 a line contact; 2 leaves room.
constexpr double kPdSpring[2] = {1.0, 2.0};     // -
// The indentation scale: from a micrometre (machined faces in hard contact) to a metre (far
// beyond any tool's travel; (d / pd_dc)^s stays a normal number for d within kMaxLengthM).
constexpr double kPdDc[2] = {1e-6, 1.0};        // m

/// A length in metres beyond which a model is not a drilling tool (1 km).
constexpr double kMaxLengthM = 1e3;

std::string range_text(const ParamInfo& info) {
  std::ostringstream os;
  if (info.rule == R::NonNegative && info.lo > 0) os << "0 or ";
  if (info.rule == R::Optional) os << "nan (unset) or ";
  os << "in [" << info.lo << ", " << info.hi << "] " << info.unit;
  return os.str();
}

bool in_range(const ParamInfo& info, double v) {
  if (info.rule == R::NonNegative && v == 0) return true;
  return v >= info.lo && v <= info.hi;  // false for NaN
}
}  // namespace

const std::vector<ParamInfo>& param_table() {
  static const std::vector<ParamInfo> table = {
      {"m1", "m*", "bit assembly mass", R::Positive, &Params::m1, kMass[0], kMass[1]},
      {"m2", "m*", "anvil mass", R::Positive, &Params::m2, kMass[0], kMass[1]},
      {"m3", "m*", "housing mass", R::Positive, &Params::m3, kMass[0], kMass[1]},
      {"m4", "m*", "PDM mass", R::Positive, &Params::m4, kMass[0], kMass[1]},
      {"m5", "m*", "measurement sub mass", R::Positive, &Params::m5, kMass[0], kMass[1]},
      {"m6", "m*", "LWD mass", R::Positive, &Params::m6, kMass[0], kMass[1]},
      {"m7", "m*", "MWD mass", R::Positive, &Params::m7, kMass[0], kMass[1]},
      {"k3", "N/m/kg", "housing-PDM stiffness", R::NonNegative, &Params::k3, kStiff[0],
       kStiff[1]},
      {"k4", "N/m/kg", "PDM-sub stiffness", R::NonNegative, &Params::k4, kStiff[0], kStiff[1]},
      {"k5", "N/m/kg", "sub-LWD stiffness", R::NonNegative, &Params::k5, kStiff[0], kStiff[1]},
      {"k6", "N/m/kg", "LWD-MWD stiffness", R::NonNegative, &Params::k6, kStiff[0], kStiff[1]},
      {"k7", "N/m/kg", "MWD-support stiffness", R::NonNegative, &Params::k7, kStiff[0],
       kStiff[1]},
      {"kS", "N/m/kg", "recoil spring stiffness (#1)", R::NonNegative, &Params::kS, kStiff[0],
       kStiff[1]},
      {"kI", "N/m/kg", "impact face stiffness (#2)", R::NonNegative, &Params::kI, kStiff[0],
       kStiff[1]},
      {"kOn", "N/m/kg", "on-bottom shoulder stiffness (#4)", R::NonNegative, &Params::kOn,
       kStiff[0], kStiff[1]},
      {"kOff", "N/m/kg", "off-bottom shoulder stiffness (#3)", R::NonNegative, &Params::kOff,
       kStiff[0], kStiff[1]},
      {"kR", "N/m/kg", "rock stiffness", R::NonNegative, &Params::kR, kStiff[0], kStiff[1]},
      {"c3", "N s/m/kg", "housing-PDM damping", R::NonNegative, &Params::c3, kDamp[0], kDamp[1]},
      {"c4", "N s/m/kg", "PDM-sub damping", R::NonNegative, &Params::c4, kDamp[0], kDamp[1]},
      {"c5", "N s/m/kg", "sub-LWD damping", R::NonNegative, &Params::c5, kDamp[0], kDamp[1]},
      {"c6", "N s/m/kg", "LWD-MWD damping", R::NonNegative, &Params::c6, kDamp[0], kDamp[1]},
      {"c7", "N s/m/kg", "MWD-support damping", R::NonNegative, &Params::c7, kDamp[0],
       kDamp[1]},
      {"cS", "N s/m/kg", "recoil spring damping", R::NonNegative, &Params::cS, kDamp[0],
       kDamp[1]},
      {"cI", "N s/m/kg", "impact face damping", R::NonNegative, &Params::cI, kDamp[0], kDamp[1]},
      {"cOn", "N s/m/kg", "on-bottom shoulder damping", R::NonNegative, &Params::cOn, kDamp[0],
       kDamp[1]},
      {"cOff", "N s/m/kg", "off-bottom shoulder damping", R::NonNegative, &Params::cOff,
       kDamp[0], kDamp[1]},
      {"cR", "N s/m/kg", "rock damping", R::NonNegative, &Params::cR, kDamp[0], kDamp[1]},
      {"cD", "N s^2/m^2/kg", "anvil fluid drag coefficient", R::NonNegative, &Params::cD,
       kDrag[0], kDrag[1]},
      {"Fo", "N/kg", "excitation force amplitude", R::NonNegative, &Params::Fo, kForce[0],
       kForce[1]},
      {"alpha", "(rad/s)/(gal/min)", "flow to excitation angular frequency", R::Positive,
       &Params::alpha, kAlpha[0], kAlpha[1]},
      {"beta", "1/m", "displacement to phase", R::Finite, &Params::beta, kBeta[0], kBeta[1]},
      {"phi", "rad", "excitation phase", R::Finite, &Params::phi, kPhase[0], kPhase[1]},
      {"psi", "rad", "position phase", R::Finite, &Params::psi, kPhase[0], kPhase[1]},
      {"L1", "l0", "top to bit", R::Finite, &Params::L1, kLength[0], kLength[1]},
      {"L2", "l0", "anvil length above its impact face", R::Finite, &Params::L2, kLength[0],
       kLength[1]},
      {"L3", "l0", "housing length to shoulders", R::Finite, &Params::L3, kLength[0],
       kLength[1]},
      {"LS", "l0", "recoil spring length", R::Finite, &Params::LS, kLength[0], kLength[1]},
      {"LI", "l0", "distance between surfaces #2 and #3", R::Finite, &Params::LI, kLength[0],
       kLength[1]},
      {"LOn", "l0", "travel between on- and off-bottom shoulders", R::NonNegative,
       &Params::LOn, kTravel[0], kTravel[1]},
      {"LR", "l0", "support to rock", R::Finite, &Params::LR, kLength[0], kLength[1]},
      {"l0", "m", "standard length", R::Positive, &Params::l0, kL0[0], kL0[1]},
      {"wob", "N/kg", "weight on bit per unit reference mass", R::NonNegative, &Params::wob,
       kForce[0], kForce[1]},
      {"theta0", "rad", "excitation phase at rest (nan: from psi)", R::Optional,
       &Params::theta0, kPhase[0], kPhase[1]},
      {"L_gap", "l0", "anvil-spring gap (nan: from LS)", R::Optional, &Params::L_gap,
       kLength[0], kLength[1]},
      {"hc_n", "-", "Hunt-Crossley exponent", R::Exponent, &Params::hc_n, kExponent[0],
       kExponent[1]},
      {"hc_alpha", "s/m", "Hunt-Crossley damping factor", R::NonNegative, &Params::hc_alpha,
       kHcAlpha[0], kHcAlpha[1]},
      {"pd_factor", "-", "power-damping factor on the surface's damping", R::NonNegative,
       &Params::pd_factor, kPdFactor[0], kPdFactor[1]},
      {"pd_shape", "-", "power-damping shape (damping ~ indentation^shape)", R::Exponent,
       &Params::pd_shape, kPdShape[0], kPdShape[1]},
      {"pd_dc", "m", "power-damping characteristic indentation", R::Positive, &Params::pd_dc,
       kPdDc[0], kPdDc[1]},
      {"pd_spring", "-", "power-damping spring exponent (spring ~ indentation^exponent)",
       R::Exponent, &Params::pd_spring, kPdSpring[0], kPdSpring[1]},
  };
  return table;
}

double Params::excitation_hz(double flow_gpm) const {
  return alpha * flow_gpm / (2.0 * M_PI);
}

std::pair<double, double> Params::flow_range_gpm() const {
  return {2.0 * M_PI * kMinExcitationHz / alpha, 2.0 * M_PI * kMaxExcitationHz / alpha};
}

void Params::check_flow(double flow_gpm) const {
  const auto [lo, hi] = flow_range_gpm();
  if (flow_gpm >= lo && flow_gpm <= hi) return;  // false for NaN
  std::ostringstream os;
  os << "option flow_gpm = " << flow_gpm << " must be in [" << lo << ", " << hi
     << "] gal/min: with alpha = " << alpha << " (rad/s)/(gal/min) the excitation must be in ["
     << kMinExcitationHz << ", " << kMaxExcitationHz << "] Hz";
  if (std::isfinite(flow_gpm)) os << ", not " << excitation_hz(flow_gpm) << " Hz";
  throw std::invalid_argument(os.str());
}

void Params::validate() const {
  for (const auto& info : param_table()) {
    const double v = this->*info.member;
    std::string why;
    if (info.rule == R::Optional && std::isnan(v)) {
      continue;  // unset: derived from the others
    } else if (!std::isfinite(v)) {
      why = info.rule == R::Optional ? "must be nan (unset) or finite" : "must be finite";
    } else if (!in_range(info, v)) {
      why = "must be " + range_text(info);
    }
    // The static on-bottom state needs every support in the load path to carry the WOB.
    if (why.empty() && v == 0 && wob > 0) {
      const std::string n = info.name;
      if (n == "kR" || n == "kOn" || n == "k3" || n == "k4" || n == "k5" || n == "k6" || n == "k7")
        why = "gives no static on-bottom equilibrium under wob > 0";
    }
    if (!why.empty()) {
      std::ostringstream os;
      os << "parameter " << info.name << " = " << v << " " << why << " (" << info.meaning << ", "
         << info.unit << ")";
      throw std::invalid_argument(os.str());
    }
  }
  // Lengths in metres: the tool's geometry, within a kilometre.
  for (const auto& info : param_table()) {
    if (std::string(info.unit) != "l0") continue;
    const double v = this->*info.member;
    if (std::abs(v) * l0 > kMaxLengthM) {  // false for an unset (NaN) length
      std::ostringstream os;
      os << "parameter " << info.name << " = " << v << " l0 is " << std::abs(v) * l0
         << " m long with l0 = " << l0 << " m: |" << info.name << "| * l0 must be <= "
         << kMaxLengthM << " m (" << info.meaning << ", l0)";
      throw std::invalid_argument(os.str());
    }
  }
  if (!std::isnan(L_gap) && std::abs(spring_length()) * l0 > kMaxLengthM) {
    std::ostringstream os;
    os << "parameter L_gap = " << L_gap << " l0 gives a recoil spring length LS = "
       << spring_length() << " l0, " << std::abs(spring_length()) * l0
       << " m long with l0 = " << l0 << " m: it must be <= " << kMaxLengthM << " m";
    throw std::invalid_argument(os.str());
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
