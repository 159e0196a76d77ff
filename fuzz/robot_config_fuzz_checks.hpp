// The invariants the robot description loader's fuzzer checks on every input
// (fuzz_robot_config.cpp), shared with the replay of the saved corpus in the normal tests
// (tests/core/test_config_fuzz_corpus.cpp).
//
// A description either loads or is refused with an error that starts with its source name
// (and, for TOML syntax, the line and column). No exception escapes. A description that loads
// is a robot the rest of the twin can use: every joint limit finite and ordered, the home pose
// inside them, the forward kinematics at home and at the limits' corners finite, every
// stepper's conversion finite and non-zero. Loading it twice gives the same robot.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/kinematics.hpp"

namespace scaratwin::fuzz {

inline bool finite_pose(const ToolPose& p) {
  return std::isfinite(p.x_m) && std::isfinite(p.y_m) && std::isfinite(p.z_m) &&
         std::isfinite(p.yaw_rad);
}

inline std::string check_robot_config(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  Result<RobotModel> loaded = Error{ConfigError::kInvalid, "not parsed"};
  try {
    loaded = parse_robot_config(text, "fuzz.toml");
  } catch (const std::exception& e) {
    return std::string("an exception escaped the loader: ") + e.what();
  }
  if (!loaded) {
    const std::string& m = loaded.error().message;
    if (m.rfind("fuzz.toml", 0) != 0) return "error without the source's name: " + m;
    if (m.size() < 12) return "error with no message: " + m;
    return {};
  }
  const RobotModel& r = *loaded;
  for (int j = 0; j < kNumJoints; ++j) {
    const JointLimit& l = r.limits[j];
    if (!std::isfinite(l.min) || !std::isfinite(l.max) || !(l.min < l.max)) {
      return "joint " + std::to_string(j + 1) + ": limits not finite and ordered";
    }
    if (!(r.home[j] >= l.min && r.home[j] <= l.max)) {
      return "joint " + std::to_string(j + 1) + ": home outside the limits";
    }
  }
  if (!finite_pose(forward(r, r.home))) return "forward kinematics at home not finite";
  for (int corner = 0; corner < 16; ++corner) {
    JointVector q{};
    for (int j = 0; j < kNumJoints; ++j) {
      q[j] = (corner >> j) & 1 ? r.limits[j].max : r.limits[j].min;
    }
    if (!finite_pose(forward(r, q)))
      return "forward kinematics at a corner of the limits not finite";
  }
  for (const StepperAxis* a : {&r.motors.z, &r.motors.j2, &r.motors.j3}) {
    if (!std::isfinite(a->steps_per_unit) || a->steps_per_unit == 0.0) {
      return "a stepper's steps per unit is zero or not finite";
    }
  }
  const auto again = parse_robot_config(text, "fuzz.toml");
  if (!again) return "loads once, refused the second time: " + again.error().message;
  if (again->name != r.name || again->home != r.home ||
      again->motors.z.steps_per_unit != r.motors.z.steps_per_unit) {
    return "loading twice gives two robots";
  }
  return {};
}

}  // namespace scaratwin::fuzz
