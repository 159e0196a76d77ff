// Robot description: the shipped file is the paper's robot; bad keys and values are named.
#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

TEST(Config, ShippedFileIsThePapersRobot) {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(m) << m.error().message;
  const RobotModel p = paper_robot();
  for (int i = 0; i < kNumJoints; ++i) {
    EXPECT_EQ(m->dh[i].type, p.dh[i].type);
    EXPECT_DOUBLE_EQ(m->dh[i].a_m, p.dh[i].a_m);
    EXPECT_DOUBLE_EQ(m->dh[i].d_m, p.dh[i].d_m);
    EXPECT_NEAR(m->limits[i].min, p.limits[i].min, 1e-15);
    EXPECT_NEAR(m->limits[i].max, p.limits[i].max, 1e-15);
    EXPECT_DOUBLE_EQ(m->home[i], p.home[i]);
  }
  EXPECT_DOUBLE_EQ(m->motors.z.steps_per_unit, 205560.0);
  EXPECT_DOUBLE_EQ(m->motors.j2.steps_per_unit, 945.0);
  EXPECT_DOUBLE_EQ(m->motors.j3.steps_per_unit, 1455.0);
  EXPECT_DOUBLE_EQ(m->motors.j3_per_j2_coupling, 0.8);
  EXPECT_DOUBLE_EQ(m->motors.z.max_speed_steps_s, 5000.0);
  EXPECT_DOUBLE_EQ(m->motors.z.max_accel_steps_s2, 1500.0);
  EXPECT_DOUBLE_EQ(m->scene.trays[1].x_m, p.scene.trays[1].x_m);
  EXPECT_EQ(m->scene.camera.width_px, 640);
}

TEST(Config, KeysLeftOutTakeThePapersDefaults) {
  auto m = parse_robot_config("name = \"mini\"\n[motors.z]\nsteps_per_m = 1000.0\n", "mini.toml");
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->name, "mini");
  EXPECT_DOUBLE_EQ(m->motors.z.steps_per_unit, 1000.0);
  EXPECT_DOUBLE_EQ(m->dh[1].a_m, 0.092);
}

TEST(Config, UnknownKeyIsNamed) {
  auto m = parse_robot_config("[motors.z]\nsteps_per_mm = 205.0\n", "x.toml");
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("motors.z.steps_per_mm: unknown key"), std::string::npos)
      << m.error().message;
  EXPECT_NE(m.error().message.find("steps_per_m"), std::string::npos);  // lists valid keys
}

TEST(Config, WrongTypeIsNamed) {
  auto m = parse_robot_config("[dh.j2]\na_m = \"long\"\n", "x.toml");
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("dh.j2.a_m: expected a number, found string"), std::string::npos)
      << m.error().message;
}

TEST(Config, BadValueNamesKeyValueAndValidRange) {
  auto m = parse_robot_config("[limits]\nj2_deg = [100.0, -100.0]\n", "x.toml");
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("limits.j2_deg = [100, -100]"), std::string::npos)
      << m.error().message;
  auto n = parse_robot_config("[motors.j3]\nmax_speed_steps_s = -5.0\n", "x.toml");
  ASSERT_FALSE(n);
  EXPECT_NE(n.error().message.find("motors.j3.max_speed_steps_s = -5"), std::string::npos)
      << n.error().message;
  auto h = parse_robot_config("[home]\nd1_m = 0.5\n", "x.toml");
  ASSERT_FALSE(h);
  EXPECT_NE(h.error().message.find("home.d1_m = 0.5"), std::string::npos) << h.error().message;
  auto c = parse_robot_config("[scene.camera]\nwidth_px = 9\n", "x.toml");
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("scene.camera.width_px = 9: must be between 16 and 4096"),
            std::string::npos)
      << c.error().message;
}

TEST(Config, SyntaxErrorGivesFileAndLine) {
  auto m = parse_robot_config("name = \"a\"\n[dh\n", "broken.toml");
  ASSERT_FALSE(m);
  EXPECT_EQ(m.error().message.rfind("broken.toml:2:", 0), 0u) << m.error().message;
}

TEST(Config, MissingFileSaysSo) {
  auto m = load_robot_config("/nonexistent/robot.toml");
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("/nonexistent/robot.toml"), std::string::npos);
}

}  // namespace
}  // namespace scaratwin
