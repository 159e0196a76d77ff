// The firmware's compiled-in defaults (firmware/src/fw_config.h) against the robot description
// (config/scara.toml): one source of truth, checked rather than copied by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "fw_config.h"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/motor.hpp"

namespace {

TEST(FirmwareDefaults, AgreeWithTheRobotDescription) {
  auto model = scaratwin::load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model.ok()) << model.error().message;
  const auto& m = model->motors;
  for (const auto* axis : {&m.z, &m.j2, &m.j3}) {
    EXPECT_EQ(fw::kDefaultMaxSpeed, std::lround(axis->max_speed_steps_s));
    EXPECT_EQ(fw::kDefaultMaxAccel, std::lround(axis->max_accel_steps_s2));
  }
  EXPECT_EQ(fw::kDefaultCouplingPermille, std::lround(m.j3_per_j2_coupling * 1000));
  EXPECT_EQ(fw::kDefaultServoMinUs, std::lround(m.wrist.pulse_min_us));
  EXPECT_EQ(fw::kDefaultServoMaxUs, std::lround(m.wrist.pulse_max_us));
  EXPECT_EQ(fw::kDefaultGripOpenCdeg, std::lround(m.gripper_open_deg * 100));
  EXPECT_EQ(fw::kDefaultGripClosedCdeg, std::lround(m.gripper_closed_deg * 100));
  const auto home = scaratwin::joints_to_steps(*model, model->home);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(fw::kDefaultHome[i], home[i]) << "axis " << i;
}

TEST(FirmwareDefaults, EndstopsSitJustBeyondTheJointLimits) {
  auto model = scaratwin::load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model.ok());
  const auto& lim = model->limits;
  const double z_m = fw::kDefaultEndstop[0] / model->motors.z.steps_per_unit;
  const double q2 = fw::kDefaultEndstop[1] / model->motors.j2.steps_per_unit;
  const double q3 = fw::kDefaultEndstop[2] / model->motors.j3.steps_per_unit;
  EXPECT_GT(z_m, lim[0].max);
  EXPECT_LT(z_m, lim[0].max + 0.005);
  EXPECT_GT(q2, lim[1].max);
  EXPECT_LT(q2, lim[1].max + 5 * M_PI / 180);
  EXPECT_LT(q3, lim[2].min);
  EXPECT_GT(q3, lim[2].min - 5 * M_PI / 180);
  EXPECT_EQ(fw::kDefaultHomingDir[0], +1);
  EXPECT_EQ(fw::kDefaultHomingDir[1], +1);
  EXPECT_EQ(fw::kDefaultHomingDir[2], -1);
}

}  // namespace
