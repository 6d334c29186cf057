#pragma once
/// @file types.hpp
/// @brief Fixed-size Eigen types of the 7-DOF model: sizes are known, so nothing allocates.

#include <Eigen/Dense>
#include <array>
#include <cstdint>

namespace vadsim {

constexpr int kDof = 7;        ///< bit, anvil, housing, motor, sub, LWD, MWD
constexpr int kState = 14;     ///< positions then velocities
constexpr int kSurfaces = 5;   ///< spring #1, impact face #2, off-bottom #3, on-bottom #4, rock

using Vec7 = Eigen::Matrix<double, kDof, 1>;
using Mat7 = Eigen::Matrix<double, kDof, kDof>;
using State = Eigen::Matrix<double, kState, 1>;
using Mat14 = Eigen::Matrix<double, kState, kState>;
/// @brief A read-only view of 7 contiguous doubles (a Vec7, or the u or v half of a State):
/// callees see the caller's storage instead of a copy.
using Vec7CRef = Eigen::Ref<const Vec7>;

/// @brief Surface indices, in the order of MODEL.md's table (the rock last).
enum Surface : int { kSpring = 0, kImpact = 1, kOffBottom = 2, kOnBottom = 3, kRock = 4 };

/// @brief What a contact does between two events. Held constant while CVODE integrates, so the
/// right-hand side is smooth between roots.
enum class ContactMode : std::uint8_t {
  Open = 0,     ///< surfaces apart (d <= 0)
  Pushing = 1,  ///< overlapping and the law's force acts
  Lifted = 2    ///< overlapping, but a pushes-only law has reached zero force
};

using Modes = std::array<ContactMode, kSurfaces>;

}  // namespace vadsim
