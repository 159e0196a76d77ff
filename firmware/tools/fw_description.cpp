// scaratwin-fw-description: generates the firmware's header of robot constants
// (fw_description.h) from the robot description at build time, so that the firmware's
// compiled-in defaults come from the same file as the kinematics, the emulator and the UI.
// It loads the description with scaratwin's own loader (so it is validated exactly as
// everywhere else) and converts it with the motor conversions of scaratwin/kinematics/motor.hpp;
// it fails, naming the key, where the firmware cannot represent the description (one speed
// limit for every stepper, one pulse range for both servos, a 0..180 deg servo map).
// The firmware checks the ranges of its own settings with static_asserts (fw_config.h).
//
// usage: scaratwin-fw-description DESCRIPTION.toml OUTPUT.h
// OUTPUT.h is rewritten only when its text changes, so an edit of the description that does not
// change a constant rebuilds nothing.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/result.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"

namespace {

using scaratwin::Error;
using scaratwin::Result;
using scaratwin::RobotModel;

// Nearest integer of a value in a firmware unit.
long nearest(double v) { return std::lround(v); }

Result<std::string> header_text(const RobotModel& m, const std::string& source) {
  const auto& mo = m.motors;
  // the firmware has one speed and one acceleration limit for all steppers
  struct Axis {
    const char* key;
    const scaratwin::StepperAxis* axis;
  };
  const Axis axes[] = {{"motors.z", &mo.z}, {"motors.j2", &mo.j2}, {"motors.j3", &mo.j3}};
  for (const Axis& a : axes) {
    if (a.axis->max_speed_steps_s != mo.z.max_speed_steps_s ||
        a.axis->max_accel_steps_s2 != mo.z.max_accel_steps_s2) {
      return Error{1, fmt::format("{}: max_speed_steps_s = {} and max_accel_steps_s2 = {} differ "
                                  "from motors.z's {} and {}: the firmware has one speed and one "
                                  "acceleration limit for every stepper; give all three the same",
                                  a.key, a.axis->max_speed_steps_s, a.axis->max_accel_steps_s2,
                                  mo.z.max_speed_steps_s, mo.z.max_accel_steps_s2)};
    }
  }
  // one pulse range and one slew rate for both servos, which map 0..180 deg
  const auto& w = mo.wrist;
  const auto& g = mo.gripper;
  if (w.pulse_min_us != g.pulse_min_us || w.pulse_max_us != g.pulse_max_us ||
      w.max_speed_deg_s != g.max_speed_deg_s) {
    return Error{1, fmt::format("servos.wrist and servos.gripper: pulse_min_us, pulse_max_us and "
                                "max_speed_deg_s must agree (the firmware has one setting for "
                                "both servos): wrist {}/{}/{}, gripper {}/{}/{}",
                                w.pulse_min_us, w.pulse_max_us, w.max_speed_deg_s, g.pulse_min_us,
                                g.pulse_max_us, g.max_speed_deg_s)};
  }
  for (const auto& [key, s] : {std::pair{"servos.wrist", &w}, std::pair{"servos.gripper", &g}}) {
    if (s->min_deg != 0.0 || s->max_deg != 180.0) {
      return Error{1, fmt::format("{}: min_deg = {}, max_deg = {}: the firmware maps the pulse "
                                  "range onto 0..180 deg; use min_deg = 0 and max_deg = 180",
                                  key, s->min_deg, s->max_deg)};
    }
  }

  const auto endstop = scaratwin::endstop_steps(m);
  const auto home = scaratwin::joints_to_steps(m, m.home);
  const auto& e = m.endstops;
  std::string h;
  h += fmt::format(
      "// Generated at build time by scaratwin-fw-description from the robot description\n"
      "// {}\n"
      "// (robot \"{}\"). Do not edit: change the description and rebuild.\n"
      "// Every constant is in the firmware's units (steps, microseconds, centidegrees); the\n"
      "// firmware takes its defaults from them in fw_config.h.\n"
      "#pragma once\n\n"
      "#include <stdint.h>\n\n"
      "namespace fw {{\n"
      "namespace desc {{\n\n",
      source, m.name);
  h += fmt::format(
      "// [motors]: steps/s and steps/s^2, every stepper\n"
      "constexpr int32_t kMaxSpeedStepsS = {};\n"
      "constexpr int32_t kMaxAccelStepsS2 = {};\n"
      "// J3 motor steps per 1000 J2 motor steps (belt coupling {})\n"
      "constexpr int32_t kCouplingPermille = {};\n\n",
      nearest(mo.z.max_speed_steps_s), nearest(mo.z.max_accel_steps_s2), mo.j3_per_j2_coupling,
      nearest(mo.j3_per_j2_coupling * 1000.0));
  h += fmt::format(
      "// [servos]: pulse widths (us) at 0 and 180 deg, slew rate (cdeg/s), gripper angles (cdeg)\n"
      "constexpr int32_t kServoMinUs = {};\n"
      "constexpr int32_t kServoMaxUs = {};\n"
      "constexpr int32_t kServoSpeedCdegS = {};\n"
      "constexpr int32_t kGripOpenCdeg = {};\n"
      "constexpr int32_t kGripClosedCdeg = {};\n\n",
      nearest(w.pulse_min_us), nearest(w.pulse_max_us), nearest(w.max_speed_deg_s * 100.0),
      nearest(mo.gripper_open_deg * 100.0), nearest(mo.gripper_closed_deg * 100.0));
  h += fmt::format(
      "// [endstops]: the count each axis takes when its switch closes (Z at d1 = {} m, J2 at\n"
      "// q2 = {} deg, J3 at q3 = {} deg as a joint count: the firmware adds the J2 motor's\n"
      "// coupling share), the direction homing seeks it, the steps backed off it\n"
      "constexpr int32_t kEndstopZ = {};\n"
      "constexpr int32_t kEndstopJ2 = {};\n"
      "constexpr int32_t kEndstopJ3 = {};\n"
      "constexpr int8_t kHomingDirZ = {};\n"
      "constexpr int8_t kHomingDirJ2 = {};\n"
      "constexpr int8_t kHomingDirJ3 = {};\n"
      "constexpr int32_t kPulloffSteps = {};\n\n",
      e.closes_at[0], scaratwin::rad_to_deg(e.closes_at[1]), scaratwin::rad_to_deg(e.closes_at[2]),
      endstop[0], endstop[1], endstop[2], e.homing_dir[0], e.homing_dir[1], e.homing_dir[2],
      e.pulloff_steps);
  // joint limits as counts, rounded inwards (Z and J2 motor counts, J3 a joint count)
  long lim_lo[3], lim_hi[3];
  for (int i = 0; i < 3; ++i) {
    const double k = scaratwin::steps_per_unit(m, i);
    const double a = m.limits[i].min * k, b = m.limits[i].max * k;
    lim_lo[i] = static_cast<long>(std::ceil(std::min(a, b) - 1e-9));
    lim_hi[i] = static_cast<long>(std::floor(std::max(a, b) + 1e-9));
  }
  h += fmt::format(
      "// [limits]: the joint limits as counts, rounded inwards (Z {}..{} m, J2 {}..{} deg as "
      "motor\n"
      "// counts; J3 {}..{} deg as a joint count: the firmware adds the J2 motor's coupling "
      "share).\n"
      "// The companion dialect refuses targets beyond them.\n"
      "constexpr int32_t kLimitMinZ = {};\n"
      "constexpr int32_t kLimitMaxZ = {};\n"
      "constexpr int32_t kLimitMinJ2 = {};\n"
      "constexpr int32_t kLimitMaxJ2 = {};\n"
      "constexpr int32_t kLimitMinJ3 = {};\n"
      "constexpr int32_t kLimitMaxJ3 = {};\n\n",
      m.limits[0].min, m.limits[0].max, scaratwin::rad_to_deg(m.limits[1].min),
      scaratwin::rad_to_deg(m.limits[1].max), scaratwin::rad_to_deg(m.limits[2].min),
      scaratwin::rad_to_deg(m.limits[2].max), lim_lo[0], lim_hi[0], lim_lo[1], lim_hi[1], lim_lo[2],
      lim_hi[2]);
  h += fmt::format(
      "// [home]: motor counts of the home pose (d1 = {} m, q2 = {} deg, q3 = {} deg; J3 with\n"
      "// the coupling share), where homing leaves the robot\n"
      "constexpr int32_t kHomeZ = {};\n"
      "constexpr int32_t kHomeJ2 = {};\n"
      "constexpr int32_t kHomeJ3 = {};\n\n"
      "// the description's hash (scaratwin::description_hash(), docs/protocol.md section 11),\n"
      "// which the firmware's hello carries so that a hub built for another description\n"
      "// refuses it\n"
      "constexpr char kDescriptionHash[] = \"{}\";\n\n"
      "}}  // namespace desc\n"
      "}}  // namespace fw\n",
      m.home[0], scaratwin::rad_to_deg(m.home[1]), scaratwin::rad_to_deg(m.home[2]), home[0],
      home[1], home[2], scaratwin::description_hash(m));
  return h;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: scaratwin-fw-description DESCRIPTION.toml OUTPUT.h\n");
    return 2;
  }
  const std::string source = argv[1];
  const std::string output = argv[2];
  auto model = scaratwin::load_robot_config(source);
  if (!model) {
    std::fprintf(stderr, "scaratwin-fw-description: %s\n", model.error().message.c_str());
    return 1;
  }
  auto text = header_text(*model, source);
  if (!text) {
    std::fprintf(stderr, "scaratwin-fw-description: %s: %s\n", source.c_str(),
                 text.error().message.c_str());
    return 1;
  }
  {
    std::ifstream old(output, std::ios::binary);
    std::stringstream s;
    if (old) s << old.rdbuf();
    if (old && s.str() == *text) return 0;
  }
  std::ofstream out(output, std::ios::binary | std::ios::trunc);
  out << *text;
  out.close();
  if (!out) {
    std::fprintf(stderr, "scaratwin-fw-description: cannot write %s\n", output.c_str());
    return 1;
  }
  return 0;
}
