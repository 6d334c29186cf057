#pragma once
/// @file params.hpp
/// @brief The model's parameters as one plain struct, plus a name table so that every layer
/// (C++, bindings, presets, calibration) addresses a parameter by the same name.

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace vadsim {

/// @brief Which force law the four impact surfaces use (the rock always keeps Kelvin-Voigt).
enum class ContactLawKind {
  KelvinVoigt = 0,           ///< k d + c d' while d > 0, tension kept (the dissertation's law)
  KelvinVoigtNoTension = 1,  ///< max(0, k d + c d'): a contact can only push
  HuntCrossley = 2,          ///< max(0, k d^n + lambda d^n d') with lambda = hc_alpha * k
  PowerDamping = 3,          ///< max(0, k d_c (d/d_c)^pd_spring + pd_factor c (d/d_c)^pd_shape d')
  /// The power-damping law at the impact face only; the other three keep Kelvin-Voigt.
  PowerDampingImpact = 4
};

/// @brief Table 2.1 of the dissertation plus the constants it withholds (l0, wob).
///
/// Units are those of MODEL.md: masses in m*, stiffness in N/m per kg of m*, damping in
/// N s/m per kg, forces in N per kg, lengths in units of l0 (metres = L * l0).
/// Defaults are the 7in tool with the CDE bit, l0 = 0.7 m, wob = 1000 N/kg.
struct Params {
  // masses (m*)
  double m1 = 1.44, m2 = 1.0, m3 = 3.78, m4 = 7.24, m5 = 1.17, m6 = 4.7, m7 = 9.18;
  // string stiffness and damping
  double k3 = 2.18e6, k4 = 5.04e6, k5 = 3.62e7, k6 = 6.14e6, k7 = 2.76e6;
  double c3 = 787, c4 = 866, c5 = 945, c6 = 756, c7 = 7870;
  // contacts: spring #1, impact face #2, off-bottom #3, on-bottom #4, rock
  double kS = 250000, kI = 120000, kOff = 1.34e6, kOn = 1.34e6, kR = 78700;
  double cS = 16.54, cI = 469, cOff = 1280, cOn = 1280, cR = 394;
  // excitation and drag
  double cD = 2.52, Fo = 300.47, alpha = 0.67, beta = 95.2, phi = 0.98, psi = -2.14;
  // geometry (l0)
  double L1 = 1.24, L2 = 2.16, L3 = 4.06, LS = 1.8, LI = 0.07, LOn = 0.01, LR = 5.21;
  // withheld constants
  double l0 = 0.7;     ///< standard length (m)
  double wob = 1000;   ///< weight on bit per unit reference mass (N/kg)
  // The constants the published numbers cannot fix (MODEL.md, last section). Unset (NaN), each
  // is derived from Table 2.1 as the dissertation does; set, it is held whatever l0, wob or the
  // other lengths are, so that l0 is only the waveform's length scale.
  /// Excitation phase at rest theta0 = beta (x2 - x3)_rest + psi (rad). Set, psi is ignored.
  /// theta0 and theta0 + pi give the same steady state (half an excitation cycle apart).
  double theta0 = std::numeric_limits<double>::quiet_NaN();
  /// Anvil-spring gap L3 - (L2 + LS + LI + LOn) (l0). Set, the recoil spring's length LS is
  /// derived from it (the spring end realises the gap, as MODEL.md reads Eq. 5.1).
  double L_gap = std::numeric_limits<double>::quiet_NaN();
  // contact-law options (used when law != KelvinVoigt)
  double hc_n = 1.0;       ///< Hunt-Crossley exponent n
  double hc_alpha = 0.2;   ///< Hunt-Crossley damping factor (s/m): lambda = hc_alpha * k
  double pd_factor = 1.0;  ///< power-damping factor on each surface's own damping c (-)
  double pd_shape = 0.0;   ///< power-damping shape s: damping ~ (d / pd_dc)^s (-)
  /// Power-damping spring exponent m: spring k pd_dc (d / pd_dc)^m, equal to the linear k d at
  /// d = pd_dc (1: linear, 1.5: Hertz's curved faces) (-).
  double pd_spring = 1.0;
  /// Power-damping characteristic indentation (m): the damping is pd_factor * c at d = pd_dc.
  /// 1 mm is the size of the 7in tool's impacts (contact_law.hpp); a preset sets its own.
  double pd_dc = 1e-3;
  ContactLawKind law = ContactLawKind::KelvinVoigt;

  /// @brief Gap between anvil and recoil spring with anvil on bit and bit on the on-bottom
  /// shoulder (dissertation Eq. 5.1), in l0.
  double gap() const { return std::isnan(L_gap) ? L3 - (L2 + LS + LI + LOn) : L_gap; }

  /// @brief The recoil spring's length the model uses (l0): LS, or the one L_gap implies.
  double spring_length() const {
    return std::isnan(L_gap) ? LS : L3 - (L2 + LI + LOn) - L_gap;
  }

  /// @brief Excitation frequency (Hz) at a flow rate (gal/min).
  double excitation_hz(double flow_gpm) const;

  /// @brief The flow rates (gal/min) whose excitation lies in [kMinExcitationHz,
  /// kMaxExcitationHz]: 2 pi f / alpha at both ends.
  std::pair<double, double> flow_range_gpm() const;

  /// @brief Throws std::invalid_argument "option flow_gpm = ... must be in [lo, hi] gal/min"
  /// for a flow outside flow_range_gpm() (or not a number).
  void check_flow(double flow_gpm) const;

  /// @brief Throws std::invalid_argument naming the first value outside its physical range
  /// (param_table()), or a length beyond 1 km (|L| * l0).
  void validate() const;
};

/// The excitation frequencies (Hz) a run can resolve. Below 0.1 Hz a cycle lasts more than
/// 10 s: the default run (400 cycles, a 200-cycle window stored at 20 kHz) would be hours of
/// simulated time and more stored samples than the recorder allows. Above 2 kHz the 20 kHz
/// summary grid has fewer than 10 points per cycle. The 7in tool (alpha = 0.67) covers
/// 0.94 to 18756 gal/min.
constexpr double kMinExcitationHz = 0.1;
constexpr double kMaxExcitationHz = 2000.0;

/// @brief A numeric parameter's name, unit, meaning, and the range it must lie in.
///
/// Positive, Finite, Exponent: lo <= v <= hi. NonNegative: v == 0 or lo <= v <= hi (so a
/// non-zero stiffness, damping or force is a normal number, never subnormal). Optional: NaN
/// (unset: derived from the others) or lo <= v <= hi.
struct ParamInfo {
  const char* name;
  const char* unit;
  const char* meaning;
  enum class Rule { Positive, NonNegative, Finite, Exponent, Optional } rule;
  double Params::*member;
  double lo, hi;  ///< the physical range, in unit
};

/// @brief Every numeric parameter, in a fixed order (the order of Table 2.1, then l0, wob, law
/// options). The contact law kind is not in the table: it is not a number.
const std::vector<ParamInfo>& param_table();

/// @brief Read or write a parameter by name; unknown names throw std::invalid_argument.
double get_param(const Params& p, const std::string& name);
void set_param(Params& p, const std::string& name, double value);

}  // namespace vadsim
