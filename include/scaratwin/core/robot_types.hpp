// Plain value types that the robot description (kinematics/robot_model.hpp) and the wire
// messages (protocol/messages.hpp) share: the joint vector and the cube colours. Kept apart
// so that the protocol does not depend on the kinematics library.
#pragma once

#include <array>

namespace scaratwin {

inline constexpr int kNumJoints = 4;

// Joint state of the SCARA in joint order: d1 (prismatic, m), q2, q3, q4 (revolute, rad).
using JointVector = std::array<double, kNumJoints>;

enum class CubeColor { kRed = 0, kGreen = 1, kBlue = 2 };
inline constexpr int kNumColors = 3;

// "red", "green", "blue" (the names of the wire, the CLI and the description).
constexpr const char* color_name(CubeColor c) {
  switch (c) {
    case CubeColor::kRed:
      return "red";
    case CubeColor::kGreen:
      return "green";
    case CubeColor::kBlue:
      return "blue";
  }
  return "?";
}

}  // namespace scaratwin
