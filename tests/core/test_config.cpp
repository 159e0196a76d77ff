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
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(m->endstops.closes_at[i], p.endstops.closes_at[i], 1e-15) << "axis " << i;
    EXPECT_EQ(m->endstops.homing_dir[i], p.endstops.homing_dir[i]) << "axis " << i;
  }
  EXPECT_DOUBLE_EQ(m->endstops.closes_at[0], 0.1225);
  EXPECT_NEAR(rad_to_deg(m->endstops.closes_at[1]), 117.0, 1e-12);
  EXPECT_NEAR(rad_to_deg(m->endstops.closes_at[2]), -77.0, 1e-12);
  EXPECT_EQ(m->endstops.pulloff_steps, 40);
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

TEST(Config, PatternIsReadAndChecked) {
  auto c = parse_robot_config(
      "[scene.pattern]\nx_m = 0.2\nyaw_deg = 90\ntag_size_m = 0.03\ncolumns = 3\n", "x.toml");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_DOUBLE_EQ(c->scene.pattern.x_m, 0.2);
  EXPECT_DOUBLE_EQ(c->scene.pattern.yaw_rad, deg_to_rad(90.0));
  EXPECT_DOUBLE_EQ(c->scene.pattern.tag_size_m, 0.03);
  EXPECT_EQ(c->scene.pattern.columns, 3);
  EXPECT_EQ(c->scene.pattern.rows, paper_robot().scene.pattern.rows);  // the default
  auto tight = parse_robot_config("[scene.pattern]\nspacing_m = 0.005\n", "x.toml");
  ASSERT_FALSE(tight.ok());
  EXPECT_NE(tight.error().message.find("scene.pattern.spacing_m = 0.005: must be at least a "
                                       "quarter of tag_size_m (0.01)"),
            std::string::npos)
      << tight.error().message;
  auto many = parse_robot_config("[scene.pattern]\ncolumns = 30\nrows = 30\n", "x.toml");
  ASSERT_FALSE(many.ok());
  EXPECT_NE(many.error().message.find("587"), std::string::npos) << many.error().message;
  EXPECT_FALSE(parse_robot_config("[scene.pattern]\nsize = 3\n", "x.toml").ok());  // unknown key
}

TEST(Config, CameraRollIsReadInDegreesAndBounded) {
  auto c = parse_robot_config("[scene.camera]\nroll_deg = 2.5\n", "x.toml");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_DOUBLE_EQ(c->scene.camera.roll_rad, deg_to_rad(2.5));
  auto bad = parse_robot_config("[scene.camera]\nroll_deg = 200\n", "x.toml");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("scene.camera.roll_deg = 200: must be in [-180, 180]"),
            std::string::npos)
      << bad.error().message;
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

// Each bad [endstops] entry is named with its value and what would be valid.
TEST(Config, BadEndstopIsNamed) {
  const auto error_of = [](const char* toml) {
    auto m = parse_robot_config(toml, "x.toml");
    return m ? std::string("(accepted)") : m.error().message;
  };
  const std::string inside = error_of("[endstops]\nj2_deg = 100.0\n");
  EXPECT_NE(inside.find("endstops.j2_deg = 100: homing seeks this switch upwards"),
            std::string::npos)
      << inside;
  EXPECT_NE(inside.find("upper joint limit 115 (limits.j2_deg)"), std::string::npos) << inside;
  const std::string wrong_side = error_of("[endstops]\nhoming_dir = [1, 1, 1]\n");
  EXPECT_NE(wrong_side.find("endstops.j3_deg = -77"), std::string::npos) << wrong_side;
  const std::string zero = error_of("[endstops]\nhoming_dir = [1, 0, -1]\n");
  EXPECT_NE(zero.find("endstops.homing_dir[1] = 0: must be 1"), std::string::npos) << zero;
  const std::string big = error_of("[endstops]\nhoming_dir = [1, 2, -1]\n");
  EXPECT_NE(big.find("endstops.homing_dir[1] = 2: must be between -1 and 1"), std::string::npos)
      << big;
  const std::string short_dir = error_of("[endstops]\nhoming_dir = [1, 1]\n");
  EXPECT_NE(short_dir.find("endstops.homing_dir: expected an array of 3 integers"),
            std::string::npos)
      << short_dir;
  const std::string pulloff = error_of("[endstops]\npulloff_steps = 0\n");
  EXPECT_NE(pulloff.find("endstops.pulloff_steps = 0: must be between 1 and 1000"),
            std::string::npos)
      << pulloff;
  const std::string unknown = error_of("[endstops]\nz_mm = 122.5\n");
  EXPECT_NE(unknown.find("endstops.z_mm: unknown key (valid keys: z_m, j2_deg"), std::string::npos)
      << unknown;
}

// A description may move a switch, as long as it stays beyond the travel.
TEST(Config, EndstopsMayMove) {
  auto m =
      parse_robot_config("[endstops]\nz_m = 0.125\nj3_deg = -80.0\npulloff_steps = 25\n", "x.toml");
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_DOUBLE_EQ(m->endstops.closes_at[0], 0.125);
  EXPECT_NEAR(m->endstops.closes_at[2], deg_to_rad(-80.0), 1e-15);
  EXPECT_EQ(m->endstops.pulloff_steps, 25);
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
