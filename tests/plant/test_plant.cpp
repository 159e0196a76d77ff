// The physical robot as built (src/plant): stepper physics, backlash, the as-built draw and a
// physical pick-and-place. Oracles are written out here from the motor's data sheet figures
// and the description, not taken from the plant's own functions.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "plant_driver.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/physical.hpp"
#include "scaratwin/plant/plant.hpp"
#include "scaratwin/plant/stepper.hpp"

namespace scaratwin::plant {
namespace {

constexpr double kPi = std::numbers::pi;

// Runs a lone motor (no load but its own friction) up a ramp to `rate` microsteps/s and on
// at that rate for `hold_s`; returns the microsteps lost.
std::int64_t run_at_rate(double rate, double hold_s) {
  const StepperDrive drive;  // NEMA 17 on an A4988, 1/8 steps
  StepperMotor m(drive, 12.0);
  const double h = 10e-6;
  double t = 0.0, v = 0.0, acc_steps = 0.0;
  const double accel = 20000.0;  // microsteps/s^2: a gentle ramp
  while (t < rate / accel + hold_s) {
    v = std::min(rate, v + accel * h);
    acc_steps += v * h;
    while (acc_steps >= 1.0) {
      m.step(+1);
      acc_steps -= 1.0;
    }
    m.advance(h, 0.0);
    t += h;
  }
  // let it settle where it will
  for (int i = 0; i < 20000; ++i) m.advance(h, 0.0);
  return m.lost_microsteps();
}

TEST(Stepper, BelowThePullOutCurveNoStepIsLost) {
  // 5,000 microsteps/s at 1/8: 19.6 rad/s, back EMF 0.235 V s/rad x 19.6 = 4.6 V of 12 V
  EXPECT_EQ(run_at_rate(5000.0, 0.5), 0);
  EXPECT_EQ(run_at_rate(9000.0, 0.5), 0);
}

TEST(Stepper, AboveThePullOutCurveStepsAreLost) {
  // the back EMF reaches the 12 V supply at 12 / (0.40 / 1.7) = 51 rad/s, i.e.
  // 51 x 1600 / (2 pi) = 12,990 microsteps/s: beyond it the phases give no torque at all
  const std::int64_t lost = run_at_rate(15000.0, 0.5);
  EXPECT_GT(lost, 1000);
  // a slipped rotor settles a whole number of electrical cycles (4 full steps = 32 microsteps)
  EXPECT_EQ(lost % 32, 0);
}

TEST(Stepper, PullOutTorqueFollowsTheDriverAndTheSupply) {
  const StepperDrive drive;
  StepperMotor m(drive, 12.0);
  // at rest: the current limit, 1.2 A x 0.40 N m / 1.7 A
  EXPECT_NEAR(m.pull_out_torque_nm(0.0), 1.2 * 0.40 / 1.7, 1e-12);
  // 40 rad/s: (12 - 0.2353 x 40) V / |1.5 + j 50 x 40 x 0.0028| ohm
  const double kt = 0.40 / 1.7;
  const double i40 = (12.0 - kt * 40.0) / std::hypot(1.5, 50 * 40 * 0.0028);
  EXPECT_NEAR(m.pull_out_torque_nm(40.0), kt * i40, 1e-12);
  EXPECT_EQ(m.pull_out_torque_nm(60.0), 0.0);
}

TEST(AsBuilt, SameSeedSameRobot) {
  AsBuiltProfile p;
  p.seed = 42;
  const AsBuilt a = draw_as_built(p), b = draw_as_built(p);
  for (int i = 0; i < kAsBuiltCount; ++i) EXPECT_EQ(a.v[i], b.v[i]) << i;
  p.seed = 43;
  const AsBuilt c = draw_as_built(p);
  int differ = 0;
  for (int i = 0; i < kAsBuiltCount; ++i) differ += a.v[i] != c.v[i];
  EXPECT_EQ(differ, kAsBuiltCount);
}

TEST(AsBuilt, DrawsStayWithinTheirTolerancesAndFixedValuesWin) {
  AsBuiltProfile p;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    p.seed = seed;
    const AsBuilt a = draw_as_built(p);
    for (int i = 0; i < kAsBuiltCount; ++i) {
      const double tol = p.tolerance[i];
      if (as_built_keys()[i].magnitude) {
        EXPECT_GE(a.v[i], 0.5 * tol);
        EXPECT_LE(a.v[i], tol);
      } else {
        EXPECT_LE(std::abs(a.v[i]), tol);
      }
    }
  }
  // the default link tolerance: 1 mm (docs/physical.md)
  EXPECT_DOUBLE_EQ(p.tolerance[static_cast<int>(AsBuiltParam::kA2)], 0.001);
  p.seed = 7;
  const AsBuilt free = draw_as_built(p);
  p.fixed[static_cast<int>(AsBuiltParam::kJ2Zero)] = true;
  p.value[static_cast<int>(AsBuiltParam::kJ2Zero)] = 0.01;
  const AsBuilt pinned = draw_as_built(p);
  EXPECT_EQ(pinned[AsBuiltParam::kJ2Zero], 0.01);
  EXPECT_EQ(pinned[AsBuiltParam::kA3], free[AsBuiltParam::kA3]);  // the others unchanged
}

AsBuilt with(std::initializer_list<std::pair<AsBuiltParam, double>> values) {
  AsBuilt a;
  for (const auto& [k, v] : values) a.v[static_cast<int>(k)] = v;
  return a;
}

TEST(AsBuilt, TheCameraMountIsShiftedTiltedAndTurned) {
  const RobotModel nominal = paper_robot();
  const RobotModel built = as_built_robot(nominal, with({{AsBuiltParam::kCameraZ, 0.002},
                                                         {AsBuiltParam::kCameraTiltY, 0.01},
                                                         {AsBuiltParam::kCameraRoll, -0.015}}));
  const CameraModel& c = built.scene.camera;
  EXPECT_DOUBLE_EQ(c.pos_m[2], nominal.scene.camera.pos_m[2] + 0.002);
  // the aim moves along x by the distance to the aim point times tan(tilt)
  EXPECT_NEAR(c.look_at_m[0] - nominal.scene.camera.look_at_m[0], 0.48 * std::tan(0.01), 1e-12);
  EXPECT_DOUBLE_EQ(c.roll_rad, -0.015);
}

TEST(Plant, AReversalShowsExactlyTheBacklash) {
  // The elbow: its motor alone moves it (turning the J2 motor alone would also turn the
  // elbow through the belt coupling, whose reaction nudges a free shoulder)
  const RobotModel model = paper_robot();
  const double backlash = deg_to_rad(2.0);  // 51 J3 steps of dead band
  auto p = Plant::create(model, with({{AsBuiltParam::kJ3Backlash, backlash}}));
  ASSERT_TRUE(p.ok()) << p.error().message;
  testing::Driver d(**p);
  auto target = d.count();
  // as with a dial indicator: drive forward and settle, then step back one step at a time
  // until the joint starts to follow; the steps taken are the dead band
  target[2] += 300;
  d.move_to(target, 300, 300);
  d.wait(0.5);
  // the arm may have coasted into the dead band: step on until it is pushed again
  auto creep = [&](int dir, double from) {
    int n = 0;
    while (n < 300 && std::abs((*p)->joints()[2] - from) < 2e-4) {
      target[2] += dir;
      d.move_to(target, 300, 30000);
      d.wait(0.01);
      ++n;
    }
    return n;
  };
  (void)creep(+1, (*p)->joints()[2]);
  d.wait(0.3);
  const double q_fwd = (*p)->joints()[2];
  const int steps_back = creep(-1, q_fwd);
  // 1455 steps/rad: the dead band to within 5 %, plus the one step that shows the joint
  // moving (a lone step rings the light rotor, which takes up a little of the band early)
  const double band_steps = backlash * 1455.0;
  EXPECT_NEAR(steps_back, band_steps, 0.05 * band_steps + 1.0);
  EXPECT_EQ((*p)->lost_microsteps()[2], 0);
}

TEST(Plant, WithoutDeviationsTheJointsGoWhereTheStepsSay) {
  const RobotModel model = paper_robot();
  auto p = Plant::create(model, ideal_as_built());
  ASSERT_TRUE(p.ok()) << p.error().message;
  testing::Driver d(**p);
  const JointVector q{0.07, deg_to_rad(40.0), deg_to_rad(-60.0), 0.0};
  d.move_joints(model, q, 5000, 1500);
  d.wait(0.5);
  const JointVector got = (*p)->joints();
  // within one step (and Z's sag under gravity: 0.8 kg x 9.81 / 2e5 N/m = 0.04 mm)
  EXPECT_NEAR(got[0], q[0], 1.0 / 205560 + 0.06e-3);
  EXPECT_NEAR(got[1], q[1], 1.0 / 945);
  EXPECT_NEAR(got[2], q[2], 1.0 / 1455);
  for (auto l : (*p)->lost_microsteps()) EXPECT_EQ(l, 0);
}

TEST(Plant, EndstopsCloseWhereTheyWereReallyMounted) {
  const RobotModel model = paper_robot();
  const double off = deg_to_rad(1.5);
  auto p = Plant::create(model, with({{AsBuiltParam::kJ2Zero, off}}));
  ASSERT_TRUE(p.ok()) << p.error().message;
  testing::Driver d(**p);
  EXPECT_EQ((*p)->endstops() & 2, 0);
  // creep J2 towards its switch (117 deg + 1.5 deg as built) one step at a time
  auto target = d.count();
  double closed_at = 0.0;
  for (int i = 0; i < 2200 && closed_at == 0.0; ++i) {
    target[1] += 1;
    d.move_to(target, 500, 5000);
    d.wait(0.004);
    if ((*p)->endstops() & 2) closed_at = (*p)->joints()[1];
  }
  ASSERT_NE(closed_at, 0.0) << "the J2 switch never closed";
  EXPECT_NEAR(rad_to_deg(closed_at), 117.0 + 1.5, 0.1);
}

// Physical pick-and-place: the plant's own cube, picked by its own gripper.
double pick_and_place(const AsBuilt& built, bool* held) {
  const RobotModel model = paper_robot();
  auto p = Plant::create(model, built);
  EXPECT_TRUE(p.ok()) << p.error().message;
  Plant& plant = **p;
  const double cx = 0.19, cy = 0.06;
  EXPECT_TRUE(plant.place_cube(CubeColor::kBlue, cx, cy, 0.0).ok());
  testing::Driver d(plant);
  d.wait(0.3);
  auto ik = [&](double x, double y, double z) {
    auto r = inverse(model, ToolPose{x, y, z, deg_to_rad(90.0)}, model.home);
    EXPECT_TRUE(r.ok());
    return r.ok() ? r.value() : model.home;
  };
  const double hi = model.scene.grasp_z_m + model.scene.approach_height_m;
  d.set_gripper(model, false);
  d.move_joints(model, ik(cx, cy, hi), 4000, 1500);
  d.move_joints(model, ik(cx, cy, model.scene.grasp_z_m), 4000, 1500);
  d.wait(0.4);
  d.set_gripper(model, true);
  d.wait(0.6);
  *held = plant.held_cube() >= 0;
  const Tray& tray = model.scene.trays[static_cast<int>(CubeColor::kBlue)];
  d.move_joints(model, ik(cx, cy, hi), 4000, 1500);
  d.move_joints(model, ik(tray.x_m, tray.y_m, hi), 4000, 1500);
  d.move_joints(model, ik(tray.x_m, tray.y_m, model.scene.grasp_z_m + 0.003), 4000, 1500);
  d.set_gripper(model, false);
  d.wait(0.8);
  const auto cubes = plant.cubes();
  EXPECT_EQ(cubes.size(), 1u);
  return std::hypot(cubes[0].pos_m[0] - tray.x_m, cubes[0].pos_m[1] - tray.y_m);
}

TEST(Plant, PicksAPhysicalCubeAndPlacesItInItsTray) {
  bool held = false;
  const double off_centre = pick_and_place(ideal_as_built(), &held);
  EXPECT_TRUE(held);
  EXPECT_LT(off_centre, 0.5 * 0.05 - 0.01);  // inside the 5 cm tray, cube and all
}

TEST(Plant, AToolTooFarOffMissesTheCube) {
  // link 3 printed 25 mm too long: a jaw comes down on the cube and pushes it away (15 mm
  // off, the open jaw pushes the cube between the jaws, and the grasp succeeds)
  bool held = true;
  (void)pick_and_place(with({{AsBuiltParam::kA3, 0.025}}), &held);
  EXPECT_FALSE(held);
}

TEST(Plant, TheToolIsWhereTheAsBuiltKinematicsPutIt) {
  // Oracle: the kinematics library's FK of the as-built DH table, not the plant's MuJoCo
  // model. Dead bands fixed at zero so that the joints sit exactly on their drives.
  const RobotModel model = paper_robot();
  AsBuiltProfile prof;
  prof.seed = 3;
  for (AsBuiltParam k : {AsBuiltParam::kZBacklash, AsBuiltParam::kJ2Backlash,
                         AsBuiltParam::kJ3Backlash, AsBuiltParam::kServoDeadband}) {
    prof.fixed[static_cast<int>(k)] = true;
    prof.value[static_cast<int>(k)] = 0.0;
  }
  const AsBuilt a = draw_as_built(prof);
  auto p = Plant::create(model, a);
  ASSERT_TRUE(p.ok()) << p.error().message;
  testing::Driver d(**p);
  // the as-built DH table written out here (not as_built_robot(): the oracle must not share
  // the plant's code)
  RobotModel built = model;
  built.dh[1].a_m += a[AsBuiltParam::kA2];
  built.dh[2].a_m += a[AsBuiltParam::kA3];
  built.dh[3].a_m += a[AsBuiltParam::kJawOffset];
  for (const JointVector& q :
       {JointVector{0.06, deg_to_rad(30.0), deg_to_rad(50.0), deg_to_rad(40.0)},
        JointVector{0.09, deg_to_rad(-60.0), deg_to_rad(100.0), deg_to_rad(120.0)}}) {
    d.move_joints(model, q, 4000, 1500);
    d.wait(1.0);
    // what the motors were told, through the lead error and the wrist servo's gain and horn
    const auto steps = joints_to_steps(model, q);
    JointVector t{};
    t[0] = steps[0] / model.motors.z.steps_per_unit * (1.0 + a[AsBuiltParam::kZLead]);
    t[1] = steps[1] / model.motors.j2.steps_per_unit;
    t[2] = (steps[2] - model.motors.j3_per_j2_coupling * steps[1]) / model.motors.j3.steps_per_unit;
    t[3] = q[3] * (1.0 + a[AsBuiltParam::kWristGain]) + a[AsBuiltParam::kWristOffset];
    const ToolPose want = forward(built, t);
    const ToolPose got = (*p)->tool_pose();
    // 0.1 mm: Z sags under gravity (0.04 mm), the belts stretch under the bearing friction
    EXPECT_NEAR(got.x_m, want.x_m, 1e-4);
    EXPECT_NEAR(got.y_m, want.y_m, 1e-4);
    EXPECT_NEAR(got.z_m, want.z_m, 1e-4);
    EXPECT_NEAR(got.yaw_rad, want.yaw_rad, deg_to_rad(0.5));
    // and the as-built robot is not the description: millimetres apart
    const ToolPose nominal = forward(model, q);
    EXPECT_GT(std::hypot(got.x_m - nominal.x_m, got.y_m - nominal.y_m), 2e-4);
  }
}

TEST(Plant, SameInputsSameTruth) {
  const RobotModel model = paper_robot();
  AsBuiltProfile prof;
  prof.seed = 5;
  auto run = [&] {
    auto p = Plant::create(model, draw_as_built(prof));
    testing::Driver d(**p);
    d.move_joints(model, {0.05, 0.6, -0.9, 0.3}, 6000, 3000);
    d.wait(0.2);
    return std::make_pair((*p)->joints(), (*p)->rotor_microsteps());
  };
  const auto a = run(), b = run();
  for (int j = 0; j < kNumJoints; ++j) EXPECT_EQ(a.first[j], b.first[j]);
  for (int i = 0; i < kSteppers; ++i) EXPECT_EQ(a.second[i], b.second[i]);
}

}  // namespace
}  // namespace scaratwin::plant
