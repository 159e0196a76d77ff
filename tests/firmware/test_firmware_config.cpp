// The firmware's compiled-in defaults (firmware/src/fw_config.h, from the header the build
// generates out of the robot description) against the description itself: the same file,
// loaded here and converted with the rounding formulas written out again, independently of the
// generator and of scaratwin's motor conversions.
#include <gtest/gtest.h>

#include <cmath>

#include "fw_config.h"
#include "scaratwin/config/robot_config.hpp"

namespace {

// The description the header was generated from (SCARATWIN_ROBOT_DESCRIPTION).
scaratwin::RobotModel description() {
  auto model = scaratwin::load_robot_config(SCARATWIN_CONFIG_FILE);
  if (!model) ADD_FAILURE() << model.error().message;
  return model ? *model : scaratwin::paper_robot();
}

long nearest(double v) { return std::lround(v); }

TEST(FirmwareDefaults, MotorLimitsServosAndCouplingAreTheDescriptions) {
  const scaratwin::RobotModel model = description();
  const auto& m = model.motors;
  for (const auto* axis : {&m.z, &m.j2, &m.j3}) {
    EXPECT_EQ(fw::kDefaultMaxSpeed, nearest(axis->max_speed_steps_s));
    EXPECT_EQ(fw::kDefaultMaxAccel, nearest(axis->max_accel_steps_s2));
  }
  EXPECT_EQ(fw::kDefaultCouplingPermille, nearest(m.j3_per_j2_coupling * 1000));
  for (const auto* servo : {&m.wrist, &m.gripper}) {
    EXPECT_EQ(fw::kDefaultServoMinUs, nearest(servo->pulse_min_us));
    EXPECT_EQ(fw::kDefaultServoMaxUs, nearest(servo->pulse_max_us));
    EXPECT_EQ(fw::kDefaultServoSpeed, nearest(servo->max_speed_deg_s * 100));
  }
  EXPECT_EQ(fw::kDefaultGripOpenCdeg, nearest(m.gripper_open_deg * 100));
  EXPECT_EQ(fw::kDefaultGripClosedCdeg, nearest(m.gripper_closed_deg * 100));
}

// The hash the firmware's hello carries is the description's (docs/protocol.md section 11),
// so a hub on the same description accepts the firmware and one on another refuses it.
TEST(FirmwareDefaults, HelloCarriesTheDescriptionsHash) {
  EXPECT_STREQ(fw::desc::kDescriptionHash, scaratwin::description_hash(description()).c_str());
}

TEST(FirmwareDefaults, EndstopAndHomeCountsAreTheDescriptions) {
  const scaratwin::RobotModel model = description();
  const double kz = model.motors.z.steps_per_unit;   // steps per metre
  const double k2 = model.motors.j2.steps_per_unit;  // steps per radian
  const double k3 = model.motors.j3.steps_per_unit;
  const double c = model.motors.j3_per_j2_coupling;
  const auto& e = model.endstops;
  // switches: nearest count of the switch position; J3's a joint count (no coupling share)
  EXPECT_EQ(fw::kDefaultEndstop[0], nearest(e.closes_at[0] * kz));
  EXPECT_EQ(fw::kDefaultEndstop[1], nearest(e.closes_at[1] * k2));
  EXPECT_EQ(fw::kDefaultEndstop[2], nearest(e.closes_at[2] * k3));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(fw::kDefaultHomingDir[i], e.homing_dir[i]) << "axis " << i;
  EXPECT_EQ(fw::kDefaultPulloff, e.pulloff_steps);
  // home: motor counts, J3 with the J2 motor's share (before rounding, as the hub computes it)
  const auto& h = model.home;
  EXPECT_EQ(fw::kDefaultHome[0], nearest(h[0] * kz));
  EXPECT_EQ(fw::kDefaultHome[1], nearest(h[1] * k2));
  EXPECT_EQ(fw::kDefaultHome[2], nearest(h[2] * k3 + c * h[1] * k2));
}

// The joint limits the companion dialect enforces: the description's, as whole counts inside.
TEST(FirmwareDefaults, LimitCountsAreTheDescriptionsRoundedInwards) {
  const scaratwin::RobotModel model = description();
  const double k[3] = {model.motors.z.steps_per_unit, model.motors.j2.steps_per_unit,
                       model.motors.j3.steps_per_unit};
  for (int i = 0; i < 3; ++i) {
    const auto& lim = model.limits[i];
    EXPECT_EQ(fw::kLimitMin[i], static_cast<long>(std::ceil(lim.min * k[i]))) << "axis " << i;
    EXPECT_EQ(fw::kLimitMax[i], static_cast<long>(std::floor(lim.max * k[i]))) << "axis " << i;
  }
  // the paper's robot, written out: d1 0.01..0.12 m, q2 -105..115 deg, q3 -75..205 deg
  if (model.name == "paper-scara") {
    EXPECT_EQ(fw::kLimitMin[0], 2056);
    EXPECT_EQ(fw::kLimitMax[0], 24667);
    EXPECT_EQ(fw::kLimitMin[1], -1731);
    EXPECT_EQ(fw::kLimitMax[1], 1896);
    EXPECT_EQ(fw::kLimitMin[2], -1904);
    EXPECT_EQ(fw::kLimitMax[2], 5205);
  }
}

// Whatever the description, homing seeks each switch beyond the travel: the counts lie past the
// limits, on the side of the homing direction.
TEST(FirmwareDefaults, EndstopsSitBeyondTheJointLimitsWhereHomingSeeksThem) {
  const scaratwin::RobotModel model = description();
  const double k[3] = {model.motors.z.steps_per_unit, model.motors.j2.steps_per_unit,
                       model.motors.j3.steps_per_unit};
  for (int i = 0; i < 3; ++i) {
    const auto& lim = model.limits[i];
    if (fw::kDefaultHomingDir[i] > 0) {
      EXPECT_GT(fw::kDefaultEndstop[i], lim.max * k[i]) << "axis " << i;
    } else {
      EXPECT_LT(fw::kDefaultEndstop[i], lim.min * k[i]) << "axis " << i;
    }
  }
}

}  // namespace
