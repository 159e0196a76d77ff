// The robot model's own checks (validate): every rule of a valid description refuses a model
// that breaks it with code 1 and a message naming the key, the bad value and what is valid,
// including the rules the description parser cannot reach (a model built in code). Colour names.
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {
namespace {

// One broken rule: what to change in the paper's robot and the whole message expected.
struct Broken {
  const char* what;
  std::function<void(RobotModel&)> change;
  std::string message;
};

TEST(Validate, ThePapersRobotIsValid) { EXPECT_TRUE(validate(paper_robot())); }

TEST(Validate, EveryRuleIsNamedWithItsValue) {
  const std::vector<Broken> cases = {
      {"j1 revolute", [](RobotModel& m) { m.dh[0].type = JointType::kRevolute; },
       "dh.j1.type: the first joint of a SCARA must be prismatic"},
      {"j3 prismatic", [](RobotModel& m) { m.dh[2].type = JointType::kPrismatic; },
       "dh.j3.type: must be revolute (only j1 is prismatic)"},
      {"j2 d not finite", [](RobotModel& m) { m.dh[1].d_m = NAN; }, "dh.j2: values must be finite"},
      {"j4 theta infinite", [](RobotModel& m) { m.dh[3].theta_rad = INFINITY; },
       "dh.j4: values must be finite"},
      {"j3 alpha", [](RobotModel& m) { m.dh[2].alpha_rad = kPi; },
       "dh.j3.alpha_deg = 180: a SCARA has parallel joint axes, so every alpha must be 0"},
      {"j2 negative length", [](RobotModel& m) { m.dh[1].a_m = -0.092; },
       "dh.j2.a_m = -0.092: link lengths must be >= 0"},
      {"j1 negative length", [](RobotModel& m) { m.dh[0].a_m = -0.5; },
       "dh.j1.a_m = -0.5: link lengths must be >= 0"},
      {"j1 limits reversed",
       [](RobotModel& m) {
         m.limits[0] = {0.12, 0.01};
       },
       "limits.j1_m = [0.12, 0.01]: min must be finite and below max"},
      {"j3 limits empty",
       [](RobotModel& m) {
         m.limits[2] = {0.5, 0.5};
       },
       // 0.5 rad = 28.64788975654116 deg
       "limits.j3_deg = [28.64788975654116, 28.64788975654116]: min must be finite and below max"},
      {"j4 limit not finite", [](RobotModel& m) { m.limits[3].max = NAN; },
       "limits.j4_deg = [0, nan]: min must be finite and below max"},
      {"home d1 above travel", [](RobotModel& m) { m.home[0] = 0.125; },
       "home.d1_m = 0.125: outside the joint limits [0.01, 0.12]"},
      {"home q4 below wrist", [](RobotModel& m) { m.home[3] = -kPi / 2; },
       "home.q4_deg = -90: outside the joint limits [0, 180]"},
      {"j2 link zero", [](RobotModel& m) { m.dh[1].a_m = 0.0; },
       "dh.j2.a_m and dh.j3.a_m must be > 0 (the two arm links)"},
      {"j3 link zero", [](RobotModel& m) { m.dh[2].a_m = 0.0; },
       "dh.j2.a_m and dh.j3.a_m must be > 0 (the two arm links)"},
      {"z steps zero", [](RobotModel& m) { m.motors.z.steps_per_unit = 0.0; },
       "motors.z.steps_per_unit = 0: must be > 0"},
      {"j2 speed not finite", [](RobotModel& m) { m.motors.j2.max_speed_steps_s = INFINITY; },
       "motors.j2.max_speed_steps_s = inf: must be > 0"},
      {"j3 accel negative", [](RobotModel& m) { m.motors.j3.max_accel_steps_s2 = -1500.0; },
       "motors.j3.max_accel_steps_s2 = -1500: must be > 0"},
      {"coupling not finite", [](RobotModel& m) { m.motors.j3_per_j2_coupling = NAN; },
       "motors.j3_per_j2_coupling must be finite"},
      {"wrist range reversed", [](RobotModel& m) { m.motors.wrist.min_deg = 180.0; },
       "motors.wrist: needs min_deg < max_deg, 200 <= pulse_min_us < pulse_max_us <= 3000 and "
       "max_speed_deg_s > 0"},
      {"wrist pulse too short", [](RobotModel& m) { m.motors.wrist.pulse_min_us = 199.0; },
       "motors.wrist: needs min_deg < max_deg, 200 <= pulse_min_us < pulse_max_us <= 3000 and "
       "max_speed_deg_s > 0"},
      {"gripper pulse too long", [](RobotModel& m) { m.motors.gripper.pulse_max_us = 3001.0; },
       "motors.gripper: needs min_deg < max_deg, 200 <= pulse_min_us < pulse_max_us <= 3000 and "
       "max_speed_deg_s > 0"},
      {"gripper pulses reversed", [](RobotModel& m) { m.motors.gripper.pulse_min_us = 2400.0; },
       "motors.gripper: needs min_deg < max_deg, 200 <= pulse_min_us < pulse_max_us <= 3000 and "
       "max_speed_deg_s > 0"},
      {"gripper speed zero", [](RobotModel& m) { m.motors.gripper.max_speed_deg_s = 0.0; },
       "motors.gripper: needs min_deg < max_deg, 200 <= pulse_min_us < pulse_max_us <= 3000 and "
       "max_speed_deg_s > 0"},
      {"j4 beyond the wrist servo", [](RobotModel& m) { m.motors.wrist.max_deg = 170.0; },
       "limits.j4 [0, 180] deg must lie inside the wrist servo range [0, 170] deg"},
      {"gripper closed beyond servo", [](RobotModel& m) { m.motors.gripper_closed_deg = 181.0; },
       "motors.gripper open/closed angle 181 deg is outside the servo range [0, 180]"},
      {"gripper open below servo", [](RobotModel& m) { m.motors.gripper_open_deg = -1.0; },
       "motors.gripper open/closed angle -1 deg is outside the servo range [0, 180]"},
      {"homing dir zero", [](RobotModel& m) { m.endstops.homing_dir[0] = 0; },
       "endstops.homing_dir[0] = 0: must be 1 (the switch is beyond the upper joint limit) or -1 "
       "(beyond the lower)"},
      {"j2 switch not finite", [](RobotModel& m) { m.endstops.closes_at[1] = NAN; },
       "endstops.j2_deg: must be a finite number"},
      {"z switch inside travel", [](RobotModel& m) { m.endstops.closes_at[0] = 0.1; },
       "endstops.z_m = 0.1: homing seeks this switch upwards (endstops.homing_dir[0] = 1), so it "
       "must close beyond the upper joint limit 0.12 (limits.j1_m)"},
      {"z switch below travel seeking down",
       [](RobotModel& m) {
         m.endstops.homing_dir[0] = -1;
         m.endstops.closes_at[0] = 0.02;
       },
       "endstops.z_m = 0.02: homing seeks this switch downwards (endstops.homing_dir[0] = -1), so "
       "it must close beyond the lower joint limit 0.01 (limits.j1_m)"},
      {"pulloff too far", [](RobotModel& m) { m.endstops.pulloff_steps = 1001; },
       "endstops.pulloff_steps = 1001: must be between 1 and 1000"},
      {"cube too big", [](RobotModel& m) { m.scene.cube_size_m = 0.25; },
       "scene.cube_size_m = 0.25: must be in (0, 0.1]"},
      {"cube zero", [](RobotModel& m) { m.scene.cube_size_m = 0.0; },
       "scene.cube_size_m = 0: must be in (0, 0.1]"},
      {"approach zero", [](RobotModel& m) { m.scene.approach_height_m = 0.0; },
       "scene.approach_height_m must be > 0"},
      {"camera too narrow", [](RobotModel& m) { m.scene.camera.width_px = 15; },
       "scene.camera size 15x480: width and height must be 16..4096"},
      {"camera too tall", [](RobotModel& m) { m.scene.camera.height_px = 4097; },
       "scene.camera size 640x4097: width and height must be 16..4096"},
      {"fovy too wide", [](RobotModel& m) { m.scene.camera.fovy_deg = 170.0; },
       "scene.camera.fovy_deg = 170: must be in (1, 170)"},
      {"fovy too narrow", [](RobotModel& m) { m.scene.camera.fovy_deg = 1.0; },
       "scene.camera.fovy_deg = 1: must be in (1, 170)"},
      {"pattern x not finite", [](RobotModel& m) { m.scene.pattern.x_m = NAN; },
       "scene.pattern: x_m and y_m must be finite, yaw_deg in [-360, 360]"},
      {"pattern yaw beyond a turn", [](RobotModel& m) { m.scene.pattern.yaw_rad = 7.0; },
       "scene.pattern: x_m and y_m must be finite, yaw_deg in [-360, 360]"},
      {"tag too small", [](RobotModel& m) { m.scene.pattern.tag_size_m = 0.004; },
       "scene.pattern.tag_size_m = 0.004: must be in [0.005, 0.5]"},
      {"spacing too wide", [](RobotModel& m) { m.scene.pattern.spacing_m = 0.6; },
       "scene.pattern.spacing_m = 0.6: must be at least a quarter of tag_size_m (0.01) so that "
       "each tag keeps its white border, and at most 0.5"},
      {"no rows", [](RobotModel& m) { m.scene.pattern.rows = 0; },
       "scene.pattern 5 x 0 tags: columns and rows must be 1..64 and their product at most 587 "
       "(the tag36h11 family's size)"},
      {"too many columns", [](RobotModel& m) { m.scene.pattern.columns = 65; },
       "scene.pattern 65 x 4 tags: columns and rows must be 1..64 and their product at most 587 "
       "(the tag36h11 family's size)"},
      {"too many rows",
       [](RobotModel& m) {
         m.scene.pattern.columns = 1;
         m.scene.pattern.rows = 65;
       },
       "scene.pattern 1 x 65 tags: columns and rows must be 1..64 and their product at most 587 "
       "(the tag36h11 family's size)"},
      {"sheet too thick", [](RobotModel& m) { m.scene.pattern.thickness_m = 0.006; },
       "scene.pattern.thickness_m = 0.006: must be in [0, 0.005]"},
      {"sheet negative", [](RobotModel& m) { m.scene.pattern.thickness_m = -0.001; },
       "scene.pattern.thickness_m = -0.001: must be in [0, 0.005]"},
      {"camera roll", [](RobotModel& m) { m.scene.camera.roll_rad = -4.0; },
       // -4 rad = -229.1831180523293 deg
       "scene.camera.roll_deg = -229.1831180523293: must be in [-180, 180]"},
  };
  for (const Broken& c : cases) {
    RobotModel m = paper_robot();
    c.change(m);
    const Status s = validate(m);
    ASSERT_FALSE(s) << c.what << ": accepted";
    EXPECT_EQ(s.error().code, error_code(ConfigError::kInvalid)) << c.what;
    EXPECT_EQ(s.error().message, c.message) << c.what;
  }
}

// The limits of validity are inclusive where the messages say so.
TEST(Validate, AcceptsEveryBoundaryItStates) {
  const std::vector<std::pair<const char*, std::function<void(RobotModel&)>>> cases = {
      // the tool's offset off the wrist axis may point backwards
      {"j4 a negative", [](RobotModel& m) { m.dh[3].a_m = -0.01; }},
      {"pulses at 200 and 3000 us",
       [](RobotModel& m) {
         m.motors.wrist.pulse_min_us = 200.0;
         m.motors.wrist.pulse_max_us = 3000.0;
       }},
      {"pulloff 1 step", [](RobotModel& m) { m.endstops.pulloff_steps = 1; }},
      {"pulloff 1000 steps", [](RobotModel& m) { m.endstops.pulloff_steps = 1000; }},
      {"cube 0.1 m", [](RobotModel& m) { m.scene.cube_size_m = 0.1; }},
      {"camera 16 x 4096",
       [](RobotModel& m) {
         m.scene.camera.width_px = 16;
         m.scene.camera.height_px = 4096;
       }},
      {"64 x 9 tags (576 <= 587)",
       [](RobotModel& m) {
         m.scene.pattern.columns = 64;
         m.scene.pattern.rows = 9;
       }},
      {"sheet 0 m", [](RobotModel& m) { m.scene.pattern.thickness_m = 0.0; }},
      {"roll 180 deg", [](RobotModel& m) { m.scene.camera.roll_rad = kPi; }},
      {"yaw -360 deg", [](RobotModel& m) { m.scene.pattern.yaw_rad = -2 * kPi; }},
  };
  for (const auto& [what, change] : cases) {
    RobotModel m = paper_robot();
    change(m);
    const Status s = validate(m);
    EXPECT_TRUE(s) << what << ": " << (s ? "" : s.error().message);
  }
  // 587 tags are the whole family, 588 one too many
  RobotModel m = paper_robot();
  m.scene.pattern.columns = 64;
  m.scene.pattern.rows = 10;  // 640
  ASSERT_FALSE(validate(m));
  EXPECT_EQ(validate(m).error().message,
            "scene.pattern 64 x 10 tags: columns and rows must be 1..64 and their product at "
            "most 587 (the tag36h11 family's size)");
}

TEST(Color, NamesAndParsesTheThreeColours) {
  EXPECT_STREQ(color_name(CubeColor::kRed), "red");
  EXPECT_STREQ(color_name(CubeColor::kGreen), "green");
  EXPECT_STREQ(color_name(CubeColor::kBlue), "blue");
  EXPECT_STREQ(color_name(static_cast<CubeColor>(7)), "?");
  for (CubeColor c : {CubeColor::kRed, CubeColor::kGreen, CubeColor::kBlue}) {
    auto p = parse_color(color_name(c));
    ASSERT_TRUE(p);
    EXPECT_EQ(*p, c);
  }
  auto bad = parse_color("Red");
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, error_code(ConfigError::kUnknownColour));
  EXPECT_EQ(bad.error().message, "unknown colour 'Red': expected red, green or blue");
  EXPECT_EQ(parse_color("").error().message, "unknown colour '': expected red, green or blue");
}

// --- the description's identity and hash (docs/protocol.md section 11) ----------------------

// FNV-1a written out here from its definition, not taken from the library.
std::uint32_t reference_fnv1a(const std::string& s) {
  std::uint32_t h = 2166136261u;
  for (unsigned char c : s) h = (h ^ c) * 16777619u;
  return h;
}

TEST(DescriptionHash, IsTheFnv1aOfTheDocumentedText) {
  // the paper's robot in the canonical text of robot_model.hpp: %.9g numbers, radians
  const std::string text =
      "dh1=p,0,0,0.067,0\n"
      "dh2=r,0,-0.017,0.092,0\n"
      "dh3=r,0,-0.01,0.095,0\n"
      "dh4=r,0,-0.04,0,0\n"
      "limit1=0.01,0.12\n"
      "limit2=-1.83259571,2.00712864\n"
      "limit3=-1.30899694,3.57792497\n"
      "limit4=0,3.14159265\n"
      "home=0.12,0,0,0\n"
      "steps_per_unit=205560,945,1455\n"
      "coupling=0.8\n"
      "servo_wrist=0,180,544,2400\n"
      "servo_gripper=0,180,544,2400\n"
      "endstop_closes_at=0.1225,2.04203522,-1.34390352\n"
      "endstop_homing_dir=1,1,-1\n";
  EXPECT_EQ(description_identity(paper_robot()), text);
  EXPECT_EQ(reference_fnv1a(""), 0x811c9dc5u);
  EXPECT_EQ(fnv1a32(""), 0x811c9dc5u);
  EXPECT_EQ(fnv1a32("a"), 0xe40c292cu);  // the published test vector
  EXPECT_EQ(fnv1a32(text), reference_fnv1a(text));
  EXPECT_EQ(description_hash(paper_robot()), fmt::format("{:08x}", reference_fnv1a(text)));
  EXPECT_EQ(description_hash(paper_robot()), "f062700f");
}

TEST(DescriptionHash, NameSceneAndCalibrationDoNotChangeIt) {
  const RobotModel paper = paper_robot();
  const std::string hash = description_hash(paper);
  RobotModel m = paper;
  m.name = "another";
  m.scene.table_z_m = -0.05;
  m.scene.camera.fovy_deg = 50.0;
  m.motors.z.max_speed_steps_s = 4000.0;
  m.calibration.z_offset_m = 0.001;
  m.calibration.j2_zero_rad = 0.01;
  m.calibration.backlash = {0.0, 0.002, 0.003};
  m.webcam.valid = true;
  m.webcam.f_px = 600.0;
  // what calibration does to the links: a_m and the record of what it added
  m.dh[1].a_m += 0.00031;
  m.calibration.a_delta_m[1] += m.dh[1].a_m - paper.dh[1].a_m;
  m.dh[3].a_m += -0.0007;
  m.calibration.a_delta_m[3] += m.dh[3].a_m - paper.dh[3].a_m;
  EXPECT_EQ(description_hash(m), hash);
}

TEST(DescriptionHash, EveryIdentityFieldChangesIt) {
  const std::string hash = description_hash(paper_robot());
  const std::vector<std::pair<const char*, std::function<void(RobotModel&)>>> changes = {
      {"a2 8 mm longer", [](RobotModel& m) { m.dh[1].a_m += 0.008; }},
      {"d3", [](RobotModel& m) { m.dh[2].d_m = -0.011; }},
      {"q2 limit", [](RobotModel& m) { m.limits[1].max = deg_to_rad(114.0); }},
      {"home", [](RobotModel& m) { m.home[0] = 0.11; }},
      {"j3 steps", [](RobotModel& m) { m.motors.j3.steps_per_unit = 1456.0; }},
      {"coupling", [](RobotModel& m) { m.motors.j3_per_j2_coupling = 0.75; }},
      {"wrist pulse", [](RobotModel& m) { m.motors.wrist.pulse_max_us = 2300.0; }},
      {"gripper range", [](RobotModel& m) { m.motors.gripper.max_deg = 170.0; }},
      {"z switch", [](RobotModel& m) { m.endstops.closes_at[0] = 0.123; }},
      {"j3 homing direction", [](RobotModel& m) { m.endstops.homing_dir[2] = +1; }},
  };
  for (const auto& [what, change] : changes) {
    RobotModel m = paper_robot();
    change(m);
    EXPECT_NE(description_hash(m), hash) << what;
  }
}

}  // namespace
}  // namespace scaratwin
