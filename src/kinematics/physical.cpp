#include "scaratwin/kinematics/physical.hpp"

#include <cmath>
#include <numbers>

namespace scaratwin {

const std::array<AsBuiltKey, kAsBuiltCount>& as_built_keys() {
  constexpr double kMm = 1e-3;
  constexpr double kDeg = std::numbers::pi / 180.0;
  constexpr double kPercent = 1e-2;
  // Tolerances sized like a printed desktop robot (docs/physical.md): printed link lengths
  // to about 1 mm, endstops glued where they fit, a servo horn on a 25-tooth spline (14.4 deg
  // per tooth, set by eye), a camera on a printed arm.
  static const std::array<AsBuiltKey, kAsBuiltCount> keys{{
      {"a2_mm", kMm, 1.0, false},
      {"a3_mm", kMm, 1.0, false},
      {"z_zero_mm", kMm, 1.0, false},
      {"j2_zero_deg", kDeg, 1.0, false},
      {"j3_zero_deg", kDeg, 1.0, false},
      {"z_lead_percent", kPercent, 0.5, false},
      {"wrist_offset_deg", kDeg, 3.0, false},
      {"wrist_gain_percent", kPercent, 3.0, false},
      {"gripper_gain_percent", kPercent, 3.0, false},
      {"jaw_offset_mm", kMm, 0.5, false},
      {"camera_x_mm", kMm, 3.0, false},
      {"camera_y_mm", kMm, 3.0, false},
      {"camera_z_mm", kMm, 3.0, false},
      {"camera_tilt_x_deg", kDeg, 1.0, false},
      {"camera_tilt_y_deg", kDeg, 1.0, false},
      {"camera_roll_deg", kDeg, 1.0, false},
      {"z_backlash_mm", kMm, 0.05, true},
      {"j2_backlash_deg", kDeg, 0.3, true},
      {"j3_backlash_deg", kDeg, 0.3, true},
      {"servo_deadband_deg", kDeg, 1.0, true},
  }};
  return keys;
}

AsBuiltProfile::AsBuiltProfile() {
  const auto& keys = as_built_keys();
  for (int i = 0; i < kAsBuiltCount; ++i) tolerance[i] = keys[i].default_tolerance * keys[i].to_si;
}

namespace {

// splitmix64: a fixed, documented generator, so that a seed names the same robot everywhere
std::uint64_t next(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// uniform in [0, 1) from the top 53 bits
double unit(std::uint64_t& state) { return static_cast<double>(next(state) >> 11) * 0x1.0p-53; }

}  // namespace

AsBuilt draw_as_built(const AsBuiltProfile& profile) {
  const auto& keys = as_built_keys();
  AsBuilt out;
  std::uint64_t state = profile.seed;
  for (int i = 0; i < kAsBuiltCount; ++i) {
    // one draw per parameter whether or not it is fixed, so that fixing one parameter does
    // not change the others
    const double u = unit(state);
    const double tol = profile.tolerance[i];
    const double drawn = keys[i].magnitude ? tol * (0.5 + 0.5 * u) : tol * (2.0 * u - 1.0);
    out.v[i] = profile.fixed[i] ? profile.value[i] : drawn;
  }
  return out;
}

}  // namespace scaratwin
