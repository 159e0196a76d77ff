// The model of a workcell: one robot's is byte for byte the robot's own model (the simulator and
// every physics test depend on it); two_arms.toml loads in MuJoCo with each robot's names
// prefixed and its tool where the base pose puts it; the URDF fixes each arm to the world; the
// scene seen from a turned robot keeps the camera's image.
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin::sim {
namespace {

namespace fs = std::filesystem;

const fs::path kTwoArms = fs::path(SCARATWIN_CONFIG_FILE).parent_path() / "two_arms.toml";

TEST(WorkcellModel, OneRobotIsByteForByteTheRobotsOwnModel) {
  auto robot = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(robot.ok());
  MjcfOptions with_pattern;
  with_pattern.pattern = true;
  with_pattern.cubes_per_color = 2;
  for (const MjcfOptions& o : {MjcfOptions{}, with_pattern}) {
    auto alone = make_mjcf(*robot, o);
    auto cell = make_mjcf(single_robot_workcell(*robot), o);
    ASSERT_TRUE(alone.ok() && cell.ok());
    EXPECT_EQ(*cell, *alone);
  }
  auto urdf_alone = make_urdf(*robot);
  auto urdf_cell = make_urdf(single_robot_workcell(*robot));
  ASSERT_TRUE(urdf_alone.ok() && urdf_cell.ok());
  EXPECT_EQ(*urdf_cell, *urdf_alone);
}

struct MjModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct MjDataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};

TEST(WorkcellModel, TwoArmsLoadInMujocoWithEachToolWhereItsBasePutsIt) {
  auto cell = load_workcell_config(kTwoArms);
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  auto xml = make_mjcf(*cell);
  ASSERT_TRUE(xml.ok()) << xml.error().message;
  const fs::path file =
      fs::temp_directory_path() / ("scaratwin-workcell-" + std::to_string(getpid()) + ".xml");
  std::ofstream(file) << *xml;
  char err[1000] = "";
  std::unique_ptr<mjModel, MjModelDeleter> m(mj_loadXML(file.c_str(), nullptr, err, sizeof err));
  fs::remove(file);
  ASSERT_TRUE(m) << err;
  std::unique_ptr<mjData, MjDataDeleter> d(mj_makeData(m.get()));

  // every name of each robot prefixed; the scene once, unprefixed
  for (const char* j : {"left/j1", "left/j4", "right/j1", "right/finger_r"}) {
    EXPECT_GE(mj_name2id(m.get(), mjOBJ_JOINT, j), 0) << j;
  }
  EXPECT_LT(mj_name2id(m.get(), mjOBJ_JOINT, "j1"), 0);
  for (const char* b : {"left/base_frame", "right/base_frame", "right/wrist", "tray_red"}) {
    EXPECT_GE(mj_name2id(m.get(), mjOBJ_BODY, b), 0) << b;
  }
  EXPECT_GE(mj_name2id(m.get(), mjOBJ_EQUALITY, "right/hold_cube_blue_3"), 0);
  EXPECT_GE(mj_name2id(m.get(), mjOBJ_ACTUATOR, "left/finger_l"), 0);
  EXPECT_GE(mj_name2id(m.get(), mjOBJ_CAMERA, "overhead"), 0);
  EXPECT_EQ(m->ncam, 1);
  EXPECT_EQ(m->nu, 12);       // 6 per robot
  EXPECT_EQ(m->neq, 2 * 12);  // one weld per robot and cube

  // both at home (d1 = 120 mm, the arm stretched along its base's x axis): the tool is
  // 67 + 92 + 95 = 254 mm ahead of the base and 120 - 67 = 53 mm above it
  for (const char* r : {"left", "right"}) {
    const int j1 = mj_name2id(m.get(), mjOBJ_JOINT, (std::string(r) + "/j1").c_str());
    d->qpos[m->jnt_qposadr[j1]] = 0.12;
  }
  mj_kinematics(m.get(), d.get());
  struct Want {
    const char* site;
    std::array<double, 3> pos;
    double x_axis_x;  // the tool's x axis along W's x: +1 facing +x, -1 facing back
  };
  for (const Want& w : {Want{"left/tool", {0.254, 0.0, 0.053}, 1.0},
                        Want{"right/tool", {0.400 - 0.254, 0.2, 0.053}, -1.0}}) {
    const int id = mj_name2id(m.get(), mjOBJ_SITE, w.site);
    ASSERT_GE(id, 0) << w.site;
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(d->site_xpos[3 * id + a], w.pos[a], 1e-9) << w.site;
    EXPECT_NEAR(d->site_xmat[9 * id + 0], w.x_axis_x, 1e-9) << w.site;
  }
}

TEST(WorkcellModel, UrdfFixesEachArmToTheWorld) {
  auto cell = load_workcell_config(kTwoArms);
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  auto urdf = make_urdf(*cell);
  ASSERT_TRUE(urdf.ok()) << urdf.error().message;
  for (const char* want :
       {"<robot name=\"workcell\">", "<link name=\"world\"/>", "<link name=\"left/base_link\"/>",
        "<joint name=\"right/j2\" type=\"revolute\">", "<parent link=\"right/link1\"/>",
        "<joint name=\"right/base_fixed\" type=\"fixed\">\n    <parent link=\"world\"/>\n"
        "    <child link=\"right/base_link\"/>\n"
        "    <origin xyz=\"0.40000000000000002 0.20000000000000001 0\" "
        "rpy=\"0 0 3.1415926535897931\"/>"}) {
    EXPECT_NE(urdf->find(want), std::string::npos) << want;
  }
}

TEST(WorkcellModel, RefusesAnInvalidWorkcell) {
  Workcell w = single_robot_workcell(paper_robot());
  w.robots.push_back(w.robots[0]);
  auto xml = make_mjcf(w);
  ASSERT_FALSE(xml.ok());
  EXPECT_EQ(xml.error().code, static_cast<int>(ConfigError::kInvalid));
  EXPECT_NE(xml.error().message.find("'robot' is used twice"), std::string::npos);
  EXPECT_FALSE(make_urdf(w).ok());
}

// The camera seen from a turned base shows the same picture: its axes, turned back into W, are
// the world camera's.
TEST(WorkcellModel, SceneInBaseKeepsTheCameraImage) {
  for (const double yaw_deg : {180.0, 30.0, -75.0}) {
    for (const bool straight_down : {true, false}) {
      Workcell w = single_robot_workcell(paper_robot());
      w.robots[0].name = "left";
      if (!straight_down) w.scene.camera.look_at_m = {0.25, 0.05, -0.03};
      w.scene.camera.roll_rad = 0.2;
      const double yaw = yaw_deg / 180.0 * M_PI;
      w.robots.push_back(RobotInstance{"right", BasePose{0.5, 0.3, 0.0, yaw}, paper_robot(), {}});
      const CameraAxes world = camera_axes(w.scene.camera);
      const CameraAxes base = camera_axes(scene_in_base(w, 1).scene.camera);
      const BasePose turn{0.0, 0.0, 0.0, yaw};
      const auto x = base_to_world(turn, base.x);
      const auto y = base_to_world(turn, base.y);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(x[i], world.x[i], 1e-12) << yaw_deg << " " << straight_down;
        EXPECT_NEAR(y[i], world.y[i], 1e-12) << yaw_deg << " " << straight_down;
      }
    }
  }
}

}  // namespace
}  // namespace scaratwin::sim
