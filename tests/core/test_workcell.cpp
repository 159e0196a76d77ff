// The workcell: its refusals (each with its code and a message naming the robots and the
// figures), the base frame transforms against points computed by hand, the arms at home in the
// world frame, and the workcell file loader.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "arm_oracle.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;

const fs::path kConfigDir = fs::path(SCARATWIN_SOURCE_DIR) / "config";

Workcell two_robots(double x_mm, double y_mm, double yaw_deg) {
  return test::two_robots(x_mm, y_mm, yaw_deg, "right.toml");
}

// The refusal's code is ConfigError::kInvalid and its message holds every one of `parts`.
void expect_refused(const Workcell& w, std::initializer_list<const char*> parts) {
  const Status s = validate(w);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, static_cast<int>(ConfigError::kInvalid));
  for (const char* p : parts) {
    EXPECT_NE(s.error().message.find(p), std::string::npos)
        << "'" << p << "' not in: " << s.error().message;
  }
}

void expect_near3(const std::array<double, 3>& got, const std::array<double, 3>& want,
                  const char* what) {
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[i], want[i], 1e-12) << what << " [" << i << "]";
}

TEST(Workcell, SingleRobotIsThePapersSetup) {
  const RobotModel m = paper_robot();
  const Workcell w = single_robot_workcell(m);
  ASSERT_TRUE(validate(w).ok());
  ASSERT_EQ(w.robots.size(), 1u);
  EXPECT_EQ(w.robots[0].name, "robot");
  EXPECT_EQ(w.robots[0].base.x_m, 0.0);
  EXPECT_EQ(w.robots[0].base.yaw_rad, 0.0);
  EXPECT_EQ(w.scene.trays[0].x_m, m.scene.trays[0].x_m);
  // the world frame is the robot's base frame: its view of the scene is the scene
  const RobotModel seen = scene_in_base(w, 0);
  EXPECT_EQ(seen.scene.table_z_m, m.scene.table_z_m);
  EXPECT_EQ(seen.scene.trays[2].y_m, m.scene.trays[2].y_m);
  EXPECT_EQ(seen.scene.camera.roll_rad, m.scene.camera.roll_rad);
  // one robot may keep any name (no prefix is written for it)
  Workcell named = w;
  named.robots[0].name = "Paper Robot";
  EXPECT_TRUE(validate(named).ok());
}

TEST(Workcell, TheTwoArmsFileValidates) {
  auto w = load_workcell_config(kConfigDir / "two_arms.toml");
  ASSERT_TRUE(w.ok()) << w.error().message;
  ASSERT_EQ(w->robots.size(), 2u);
  EXPECT_EQ(w->robots[0].name, "left");
  EXPECT_EQ(w->robots[1].name, "right");
  EXPECT_NEAR(w->robots[1].base.x_m, 0.4, 1e-15);
  EXPECT_NEAR(w->robots[1].base.y_m, 0.2, 1e-15);
  EXPECT_NEAR(w->robots[1].base.yaw_rad, kPi, 1e-15);
  EXPECT_EQ(w->robots[1].model.dh[1].a_m, 0.092);
  // the scene is the first robot's description's
  auto paper = load_robot_config(kConfigDir / "scara.toml");
  ASSERT_TRUE(paper.ok());
  EXPECT_EQ(w->scene.trays[1].x_m, paper->scene.trays[1].x_m);
  EXPECT_EQ(w->scene.table_z_m, paper->scene.table_z_m);
  EXPECT_TRUE(validate(*w).ok());
}

TEST(Workcell, RefusesANameUsedTwice) {
  Workcell w = two_robots(400, 200, 180);
  w.robots[1].name = "left";
  expect_refused(w, {"'left' is used twice", "robots 0 and 1"});
}

TEST(Workcell, RefusesABadNameWhenThereAreSeveralRobots) {
  for (const char* bad : {"Right", "right/arm", "", "a-name-of-thirty-three-characters"}) {
    Workcell w = two_robots(400, 200, 180);
    w.robots[1].name = bad;
    expect_refused(w, {"robot 1 name", "1..32 characters of a-z, 0-9"});
  }
  Workcell ok = two_robots(400, 200, 180);
  ok.robots[1].name = "arm_2-b";
  EXPECT_TRUE(validate(ok).ok());
}

TEST(Workcell, RefusesAFirstRobotAwayFromTheOrigin) {
  Workcell w = two_robots(400, 200, 180);
  w.robots[0].base.y_m = -0.3;
  expect_refused(w, {"robot 'left' (the first) is at (0.0, -300.0, 0.0) mm", "origin with yaw 0"});
  Workcell turned = two_robots(400, 200, 180);
  turned.robots[0].base.yaw_rad = deg_to_rad(90.0);
  expect_refused(turned, {"yaw 90.0 deg"});
}

TEST(Workcell, RefusesBasesCloserThan120Mm) {
  // 100 mm along x and 50 along y: 111.8 mm apart
  expect_refused(two_robots(100, 50, 90),
                 {"robots 'left' and 'right'", "111.8 mm apart", "at least 120 mm"});
}

TEST(Workcell, RefusesArmsCloserThan50MmAtHome) {
  // facing each other 402 mm apart, the arms (254 mm each) side by side 40 mm apart
  expect_refused(two_robots(400, 40, 180), {"robots 'left' and 'right'", "40.0 mm close",
                                            "wrists at (254.0, 0.0) mm and "
                                            "(146.0, 40.0) mm",
                                            "at least 50 mm"});
  // 60 mm apart is enough
  EXPECT_TRUE(validate(two_robots(400, 60, 180)).ok());
  // arms that cross: 0 mm
  expect_refused(two_robots(150, -200, 90), {"0.0 mm close"});
}

TEST(Workcell, RefusesABaseInsideATray) {
  // on the red tray's centre (130, -136) mm, the arm pointing away along -y
  expect_refused(two_robots(130, -136, -90),
                 {"robot 'right'", "inside the red tray", "(130.0, -136.0) mm", "56.0 mm across"});
}

TEST(Workcell, RefusesAnInvalidDescriptionOrPoseNamingTheRobot) {
  Workcell w = two_robots(400, 200, 180);
  w.robots[1].model.limits[0] = {0.2, 0.1};
  expect_refused(w, {"robot 'right' (right.toml)"});
  Workcell nan = two_robots(400, 200, 180);
  nan.robots[1].base.z_m = NAN;
  expect_refused(nan, {"robot 'right'", "not finite"});
  expect_refused(Workcell{}, {"no robot"});
}

TEST(Workcell, RobotIndexFindsANameOrListsTheRobots) {
  const Workcell w = two_robots(400, 200, 180);
  auto right = robot_index(w, "right");
  ASSERT_TRUE(right.ok());
  EXPECT_EQ(*right, 1);
  auto middle = robot_index(w, "middle");
  ASSERT_FALSE(middle.ok());
  EXPECT_EQ(middle.error().code, static_cast<int>(ConfigError::kUnknownRobot));
  EXPECT_EQ(middle.error().code, 23);
  EXPECT_EQ(middle.error().message,
            "no robot named 'middle' in the workcell (robots: 'left', 'right')");
}

TEST(BaseFrame, TransformsMatchPointsComputedByHand) {
  // a base at (400, 200, 10) mm facing W's +y: its x axis is W's y, its y axis W's -x
  const BasePose b{0.4, 0.2, 0.01, deg_to_rad(90.0)};
  // 100 mm ahead of the robot and 20 mm to its left, 30 mm below its base
  expect_near3(base_to_world(b, {0.1, 0.02, -0.03}), {0.38, 0.3, -0.02}, "ahead");
  // a point 100 mm further along W's x than the base is on the robot's right (its -y)
  expect_near3(world_to_base(b, {0.5, 0.2, 0.0}), {0.0, -0.1, -0.01}, "right");
  // facing back along -x (the right arm of two_arms.toml)
  const BasePose back{0.4, 0.2, 0.0, kPi};
  expect_near3(base_to_world(back, {0.254, 0.0, 0.053}), {0.146, 0.2, 0.053}, "tool");
  expect_near3(world_to_base(back, {0.13, -0.136, 0.0}), {0.27, 0.336, 0.0}, "red tray");
}

TEST(Workcell, ArmsAtHomeInTheWorldFrame) {
  const Workcell w = two_robots(400, 200, 180);
  const auto left = home_arm_points(w, 0);
  const auto right = home_arm_points(w, 1);
  // home: d1 = 120 mm, the arm stretched along the base's x axis (67 + 92 + 95 mm)
  expect_near3(left[1], {0.067, 0.0, 0.12}, "left shoulder");
  expect_near3(left[3], {0.254, 0.0, 0.093}, "left wrist");
  expect_near3(left[4], {0.254, 0.0, 0.053}, "left tool");
  expect_near3(right[0], {0.4, 0.2, 0.0}, "right base");
  expect_near3(right[2], {0.241, 0.2, 0.103}, "right elbow");
  expect_near3(right[4], {0.146, 0.2, 0.053}, "right tool");
}

TEST(Workcell, SceneInBaseIsTheSceneSeenFromTheRobot) {
  Workcell w = two_robots(400, 200, 180);
  w.robots[1].base.z_m = 0.01;
  w.scene.pattern.yaw_rad = deg_to_rad(10.0);
  const RobotModel seen = scene_in_base(w, 1);
  EXPECT_EQ(seen.dh[1].a_m, 0.092);  // the robot's own description
  EXPECT_NEAR(seen.scene.table_z_m, -0.04, 1e-15);
  EXPECT_NEAR(seen.scene.grasp_z_m, -0.03, 1e-15);
  const Tray& red = seen.scene.trays[static_cast<int>(CubeColor::kRed)];
  EXPECT_NEAR(red.x_m, 0.27, 1e-12);
  EXPECT_NEAR(red.y_m, 0.336, 1e-12);
  // the camera (150, 0, 450) mm looking straight down: from the robot at (250, 200) mm
  // behind it, its image turned half a turn
  expect_near3(seen.scene.camera.pos_m, {0.25, 0.2, 0.44}, "camera");
  EXPECT_NEAR(std::abs(seen.scene.camera.roll_rad), kPi, 1e-12);
  EXPECT_NEAR(seen.scene.pattern.yaw_rad, deg_to_rad(-170.0), 1e-12);
}

// A workcell file in a fresh folder; descriptions given by absolute path.
struct WorkcellFile {
  fs::path dir;
  fs::path path;
  explicit WorkcellFile(const std::string& text) {
    dir = fs::temp_directory_path() / ("scaratwin-workcell-" + std::to_string(getpid()));
    fs::create_directories(dir);
    path = dir / "cell.toml";
    std::ofstream(path) << text;
  }
  ~WorkcellFile() { fs::remove_all(dir); }
};

std::string robot_table(const std::string& name, const std::string& extra) {
  return "[[robot]]\nname = \"" + name + "\"\ndescription = \"" +
         (kConfigDir / "scara.toml").string() + "\"\n" + extra + "\n";
}

TEST(WorkcellConfig, ErrorsNameTheFileAndTheKey) {
  struct Case {
    std::string text;
    std::string want;
    int code;
  };
  const Case cases[] = {
      {robot_table("left", "") + robot_table("right", "x_mm = 400\ny_mm = 200\nroll_deg = 1"),
       "robot[1].roll_deg: unknown key (valid keys: name, description, x_mm, y_mm, z_mm, yaw_deg)",
       20},
      {robot_table("left", "") + robot_table("right", "x_mm = \"400\""),
       "robot[1] ('right').x_mm: expected a finite number, found string", 20},
      {robot_table("left", "") + "[[robot]]\ndescription = \"scara.toml\"\n",
       "robot[1].name: missing", 20},
      {robot_table("left", "") + "[[robot]]\nname = \"right\"\ndescription = \"nowhere.toml\"\n",
       "robot[1] ('right').description: cannot read robot description", 21},
      {robot_table("left", "") + robot_table("right", "x_mm = 400\nyaw_deg = 400"),
       "robot[1] ('right').yaw_deg = 400: must be in [-360, 360]", 20},
      {robot_table("left", "") + robot_table("right", "x_mm = 100"),
       "robots 'left' and 'right': bases at", 20},
      {"[robots]\n", "robots: unknown key", 20},
      {"", "no [[robot]] table", 20},
  };
  for (const Case& c : cases) {
    WorkcellFile f(c.text);
    auto w = load_workcell_config(f.path);
    ASSERT_FALSE(w.ok()) << c.text;
    EXPECT_EQ(w.error().code, c.code) << w.error().message;
    EXPECT_EQ(w.error().message.rfind(f.path.string() + ": ", 0), 0u) << w.error().message;
    EXPECT_NE(w.error().message.find(c.want), std::string::npos)
        << "'" << c.want << "' not in: " << w.error().message;
  }
  auto missing = load_workcell_config(kConfigDir / "no_such_workcell.toml");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, static_cast<int>(ConfigError::kNotFound));
  EXPECT_NE(missing.error().message.find("no_such_workcell.toml"), std::string::npos);
}

TEST(WorkcellConfig, DescriptionsAreRelativeToTheWorkcellFile) {
  WorkcellFile f("[[robot]]\nname = \"solo\"\ndescription = \"arm.toml\"\n");
  std::ofstream(f.dir / "arm.toml") << "name = \"longer\"\n[dh.j2]\na_m = 0.1\n";
  auto w = load_workcell_config(f.path);
  ASSERT_TRUE(w.ok()) << w.error().message;
  EXPECT_EQ(w->robots[0].model.name, "longer");
  EXPECT_EQ(w->robots[0].model.dh[1].a_m, 0.1);
  EXPECT_EQ(w->robots[0].description_file, (f.dir / "arm.toml").string());
}

}  // namespace
}  // namespace scaratwin
