// Trajectories: the quintic golden file, limits on every planner over random moves,
// continuity of position and velocity, Cartesian lines and pick-and-place.
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {
namespace {

const RobotModel& model() {
  static const RobotModel m = paper_robot();
  return m;
}

JointVector random_joints(std::mt19937_64& rng) {
  JointVector q;
  for (int j = 0; j < kNumJoints; ++j) {
    std::uniform_real_distribution<double> d(model().limits[j].min, model().limits[j].max);
    q[j] = d(rng);
  }
  return q;
}

// Motor positions (steps, deg) of a joint state.
std::array<double, 4> motor_pos(const JointVector& q) { return motor_rates(model(), q); }

// Positions and velocities are continuous: between two samples no motor moves faster than its
// speed limit or changes speed faster than its acceleration limit, and the positions agree
// with the velocities.
void expect_continuous(const JointTrajectory& t, double slack) {
  const double vmax[] = {model().motors.z.max_speed_steps_s, model().motors.j2.max_speed_steps_s,
                         model().motors.j3.max_speed_steps_s, model().motors.wrist.max_speed_deg_s};
  const double amax[] = {model().motors.z.max_accel_steps_s2, model().motors.j2.max_accel_steps_s2,
                         model().motors.j3.max_accel_steps_s2, INFINITY};
  for (size_t k = 0; k + 1 < t.samples.size(); ++k) {
    const JointSample& a = t.samples[k];
    const JointSample& b = t.samples[k + 1];
    const double dt = b.t_s - a.t_s;
    ASSERT_GT(dt, 0.0);
    const auto pa = motor_pos(a.q), pb = motor_pos(b.q);
    const auto va = motor_rates(model(), a.qd), vb = motor_rates(model(), b.qd);
    for (int i = 0; i < 4; ++i) {
      ASSERT_LE(std::abs(pb[i] - pa[i]), vmax[i] * dt * (1 + slack) + 1e-9)
          << "motor " << i << " sample " << k;
      if (i < 3) {
        ASSERT_LE(std::abs(vb[i] - va[i]), amax[i] * dt * (1 + slack) + 1e-9)
            << "motor " << i << " sample " << k;
        ASSERT_LE(std::abs(pb[i] - pa[i] - 0.5 * (va[i] + vb[i]) * dt),
                  amax[i] * dt * dt * (1 + slack) + 1e-6)
            << "motor " << i << " sample " << k;
      }
    }
  }
}

TEST(Quintic, MatchesGoldenFile) {
  // 60 samples over 6 s between two poses of the paper's robot.
  const JointVector q0{0.12, 0.0, 0.0, 0.0};
  const JointVector q1{0.1, deg_to_rad(30), deg_to_rad(45), deg_to_rad(10)};
  const JointTrajectory t = quintic(q0, q1, 6.0, 60);
  ASSERT_EQ(t.samples.size(), 60u);
  std::ifstream in(std::string(SCARATWIN_TEST_DATA) + "/golden/quintic_60.csv");
  ASSERT_TRUE(in) << "golden file missing";
  std::string line;
  std::getline(in, line);  // header
  size_t k = 0;
  while (std::getline(in, line)) {
    ASSERT_LT(k, t.samples.size());
    std::stringstream ss(line);
    std::vector<double> v;
    std::string f;
    while (std::getline(ss, f, ',')) v.push_back(std::stod(f));
    ASSERT_EQ(v.size(), 13u);
    const JointSample& s = t.samples[k];
    EXPECT_NEAR(v[0], s.t_s, 1e-12);
    for (int j = 0; j < kNumJoints; ++j) {
      const double scale = j == 0 ? 1.0 : kDegPerRad;
      EXPECT_NEAR(v[1 + j], s.q[j] * scale, 1e-10) << "sample " << k;
      EXPECT_NEAR(v[5 + j], s.qd[j] * scale, 1e-10) << "sample " << k;
      EXPECT_NEAR(v[9 + j], s.qdd[j] * scale, 1e-10) << "sample " << k;
    }
    ++k;
  }
  EXPECT_EQ(k, 60u);
}

TEST(Quintic, IntoBufferMatchesAllocatingForm) {
  const JointVector q0{0.1, -0.5, 1.0, 0.2}, q1{0.05, 1.0, -1.0, 2.0};
  for (int n : {2, 3, 7, 60, 61}) {
    const JointTrajectory t = quintic(q0, q1, 1.5, n);
    std::vector<JointSample> buf(static_cast<size_t>(n));
    quintic_into(q0, q1, 1.5, buf);
    for (int k = 0; k < n; ++k) {
      const JointSample& a = t.samples[static_cast<size_t>(k)];
      const JointSample& b = buf[static_cast<size_t>(k)];
      EXPECT_EQ(a.t_s, b.t_s);
      EXPECT_EQ(a.q, b.q);
      EXPECT_EQ(a.qd, b.qd);
      EXPECT_EQ(a.qdd, b.qdd);
    }
    EXPECT_EQ(buf.back().q, q1);
  }
}

TEST(Quintic, StartsAndEndsAtRest) {
  const JointTrajectory t = quintic({0.1, 0, 0, 0}, {0.05, 1, -1, 2}, 2.0, 60);
  for (int j = 0; j < kNumJoints; ++j) {
    EXPECT_EQ(t.samples.front().qd[j], 0.0);
    EXPECT_EQ(t.samples.back().qd[j], 0.0);
    EXPECT_NEAR(t.samples.back().qdd[j], 0.0, 1e-12);
  }
  EXPECT_EQ(t.samples.back().q[2], -1.0);
}

TEST(Quintic, RefusesDurationTooShortForTheMotors) {
  auto r = plan_quintic(model(), model().home, {0.02, 1.5, -1.0, 2.0}, {60, 0.1});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(PlanError::kMotorLimit));
  EXPECT_NE(r.error().message.find("at least"), std::string::npos);
}

TEST(Planners, RefuseGoalsOutsideTheLimits) {
  auto r = plan_trapezoid(model(), model().home, {0.2, 0, 0, 0});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(PlanError::kJointLimit));
  EXPECT_NE(r.error().message.find("j1"), std::string::npos);
}

TEST(Planners, NeverExceedALimitOnRandomMoves) {
  std::mt19937_64 rng(42);
  for (int i = 0; i < 300; ++i) {
    const JointVector a = random_joints(rng), b = random_joints(rng);
    auto q = plan_quintic(model(), a, b);
    ASSERT_TRUE(q) << q.error().message;
    ASSERT_TRUE(check_limits(model(), *q)) << check_limits(model(), *q).error().message;
    expect_continuous(*q, 1e-6);
    auto t = plan_trapezoid(model(), a, b);
    ASSERT_TRUE(t) << t.error().message;
    ASSERT_TRUE(check_limits(model(), *t)) << check_limits(model(), *t).error().message;
    expect_continuous(*t, 1e-6);
    EXPECT_EQ(t->samples.back().q, b);
    auto v = plan_via_points(model(), {a, b, random_joints(rng)});
    ASSERT_TRUE(v) << v.error().message;
    ASSERT_TRUE(check_limits(model(), *v));
    expect_continuous(*v, 1e-6);
  }
}

TEST(Trapezoid, AllJointsStartAndArriveTogether) {
  const JointVector a{0.12, 0, 0, 0}, b{0.03, 1.2, -0.5, 1.0};
  auto t = plan_trapezoid(model(), a, b);
  ASSERT_TRUE(t);
  // every joint is at the same fraction of its move at every sample.
  for (const JointSample& s : t->samples) {
    const double f = (s.q[0] - a[0]) / (b[0] - a[0]);
    for (int j = 1; j < kNumJoints; ++j) EXPECT_NEAR((s.q[j] - a[j]) / (b[j] - a[j]), f, 1e-12);
  }
  // and the slowest motor is at its limit somewhere (time-optimal for a synchronised move).
  double peak = 0.0;
  for (const JointSample& s : t->samples) {
    const auto v = motor_rates(model(), s.qd);
    peak = std::max(peak, std::abs(v[0]) / model().motors.z.max_speed_steps_s);
    const auto acc = motor_rates(model(), s.qdd);
    peak = std::max(peak, std::abs(acc[0]) / model().motors.z.max_accel_steps_s2);
  }
  EXPECT_NEAR(peak, 1.0, 1e-9);
}

TEST(Line, StaysOnTheLineWithinLimits) {
  auto q0 = inverse(model(), {0.15, 0.08, -0.02, deg_to_rad(150)}, model().home);
  ASSERT_TRUE(q0);
  const ToolPose goal{0.22, -0.05, 0.0, deg_to_rad(60)};
  auto t = plan_line(model(), *q0, goal);
  ASSERT_TRUE(t) << t.error().message;
  ASSERT_TRUE(check_limits(model(), *t)) << check_limits(model(), *t).error().message;
  expect_continuous(*t, 0.02);
  const ToolPose p0 = forward(model(), *q0);
  const Eigen::Vector3d a(p0.x_m, p0.y_m, p0.z_m), b(goal.x_m, goal.y_m, goal.z_m);
  for (const JointSample& s : t->samples) {
    const ToolPose p = forward(model(), s.q);
    const Eigen::Vector3d x(p.x_m, p.y_m, p.z_m);
    const double dist = (x - a).cross(b - a).norm() / (b - a).norm();
    EXPECT_LE(dist, 1e-9);
  }
  const ToolPose end = forward(model(), t->samples.back().q);
  EXPECT_NEAR(end.x_m, goal.x_m, 1e-12);
  EXPECT_NEAR(end.y_m, goal.y_m, 1e-12);
  EXPECT_NEAR(end.yaw_rad, goal.yaw_rad, 1e-12);
}

TEST(Line, FailsCleanlyWhenASampleIsUnreachable) {
  // from one side of the shoulder to the other, through the dead zone near (0.067, 0).
  auto q0 = inverse(model(), {0.067, 0.1, -0.02, deg_to_rad(180)}, model().home);
  ASSERT_TRUE(q0);
  auto t = plan_line(model(), *q0, {0.067, -0.1, -0.02, deg_to_rad(180)});
  ASSERT_FALSE(t);
  EXPECT_TRUE(t.error().code == static_cast<int>(PlanError::kUnreachable) ||
              t.error().code == static_cast<int>(PlanError::kDiscontinuous))
      << t.error().message;
  EXPECT_NE(t.error().message.find("sample"), std::string::npos);
}

TEST(PickPlace, GripsAtPickAndReleasesAtPlace) {
  PickPlaceRequest r;
  r.pick = {0.18, 0.08, -0.02, deg_to_rad(90)};
  r.place = {0.17, -0.11, -0.02, deg_to_rad(90)};
  auto t = plan_pick_place(model(), model().home, r);
  ASSERT_TRUE(t) << t.error().message;
  ASSERT_TRUE(check_limits(model(), *t)) << check_limits(model(), *t).error().message;
  expect_continuous(*t, 0.02);
  ASSERT_EQ(t->events.size(), 2u);
  EXPECT_EQ(t->events[0].action, GripperAction::kGrip);
  EXPECT_EQ(t->events[1].action, GripperAction::kRelease);
  const ToolPose at_grip = forward(model(), sample_at(*t, t->events[0].t_s));
  const ToolPose at_release = forward(model(), sample_at(*t, t->events[1].t_s));
  EXPECT_NEAR(at_grip.x_m, r.pick.x_m, 1e-9);
  EXPECT_NEAR(at_grip.y_m, r.pick.y_m, 1e-9);
  EXPECT_NEAR(at_grip.z_m, r.pick.z_m, 1e-9);
  EXPECT_NEAR(at_release.x_m, r.place.x_m, 1e-9);
  EXPECT_NEAR(at_release.z_m, r.place.z_m, 1e-9);
  // standing still while the gripper closes.
  const JointVector before = sample_at(*t, t->events[0].t_s);
  const JointVector after = sample_at(*t, t->events[0].t_s + r.grip_dwell_s);
  EXPECT_EQ(before, after);
  const ToolPose end = forward(model(), t->samples.back().q);
  EXPECT_NEAR(end.z_m, r.place.z_m + r.approach_height_m, 1e-9);
}

TEST(PickPlace, NamesTheStageThatFails) {
  PickPlaceRequest r;
  r.pick = {0.18, 0.08, -0.02, deg_to_rad(90)};
  r.place = {0.5, 0.0, -0.02, deg_to_rad(90)};  // out of reach
  auto t = plan_pick_place(model(), model().home, r);
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().message.find("place point"), std::string::npos) << t.error().message;
}

// One sample at rest at time t with joints q (the paper robot's home unless given).
JointSample at_rest(double t, JointVector q = {0.12, 0.0, 0.0, 0.0}) {
  return JointSample{t, q, {}, {}};
}

// What check_limits says of a trajectory: "ok" or "<code>: <message>".
std::string verdict(const JointTrajectory& t) {
  const Status s = check_limits(model(), t);
  return s ? std::string("ok") : std::to_string(s.error().code) + ": " + s.error().message;
}

// check_limits names the sample, its time, the joint or motor and the limit, with the rates
// computed by hand from config/scara.toml (steps/m 205560, steps/rad 945 and 1455, coupling
// 0.8, 5000 steps/s, 1500 steps/s^2, wrist 300 deg/s).
TEST(CheckLimits, NamesTheSampleTheMotorAndTheLimit) {
  JointTrajectory t;
  t.samples = {at_rest(0.0), at_rest(0.5), at_rest(0.5)};
  EXPECT_EQ(verdict(t), "10: sample 2: time 0.5 s does not increase");

  t.samples = {at_rest(0.0), at_rest(0.25, {0.125, 0.0, 0.0, 0.0})};
  EXPECT_EQ(verdict(t), "11: sample 1 (t = 0.250 s): j1 = 0.125 outside [0.01, 0.12]");

  // Z: 0.03 m/s x 205560 steps/m = 6166.8 steps/s
  JointSample s = at_rest(0.0);
  s.qd[0] = 0.03;
  t.samples = {s};
  EXPECT_EQ(verdict(t),
            "12: sample 0 (t = 0.000 s): motor Z at 6166.8 steps/s exceeds its speed limit "
            "5000.0 steps/s");
  // J3 alone at 1 rad/s is 1455 steps/s, but J2 at 5 rad/s (4725 steps/s, inside its limit)
  // drags the J3 motor 0.8 x 4725 = 3780 steps/s more: 5235 steps/s
  s = at_rest(0.0);
  s.qd[1] = 5.0;
  s.qd[2] = 1.0;
  t.samples = {s};
  EXPECT_EQ(verdict(t),
            "12: sample 0 (t = 0.000 s): motor J3 at 5235.0 steps/s exceeds its speed limit "
            "5000.0 steps/s");
  // J2 the other way: the coupling takes 3780 off the J3 motor, 1455 - 3780 = -2325 steps/s
  s.qd[1] = -5.0;
  t.samples = {s};
  EXPECT_EQ(verdict(t), "ok");
  // J2: 2 rad/s^2 x 945 steps/rad = 1890 steps/s^2
  s = at_rest(1.0);
  s.qdd[1] = 2.0;
  t.samples = {at_rest(0.0), s};
  EXPECT_EQ(verdict(t),
            "12: sample 1 (t = 1.000 s): motor J2 at 1890.0 steps/s^2 exceeds its acceleration "
            "limit 1500.0 steps/s^2");
  // the wrist servo at 301 deg/s
  s = at_rest(0.0);
  s.qd[3] = deg_to_rad(301.0);
  t.samples = {s};
  EXPECT_EQ(verdict(t),
            "12: sample 0 (t = 0.000 s): wrist servo at 301.0 deg/s exceeds its speed limit "
            "300.0 deg/s");
  // exactly at every limit is within them: 5000 steps/s on Z, 1500 steps/s^2 on J2, 300 deg/s
  s = at_rest(0.0);
  s.qd[0] = 5000.0 / 205560.0;
  s.qdd[1] = 1500.0 / 945.0;
  s.qd[3] = deg_to_rad(300.0);
  t.samples = {s};
  EXPECT_EQ(verdict(t), "ok");
}

TEST(Trajectory, AppendShiftsTimesAndEventsAndDropsTheRepeatedStart) {
  JointTrajectory t;
  append(t, JointTrajectory{{at_rest(0.0), at_rest(1.0)}, {{0.5, GripperAction::kGrip}}});
  ASSERT_EQ(t.samples.size(), 2u) << "nothing to repeat in an empty trajectory";
  JointTrajectory seg{{at_rest(0.0), at_rest(2.0, {0.1, 0.0, 0.0, 0.0})},
                      {{2.0, GripperAction::kRelease}}};
  append(t, seg);
  ASSERT_EQ(t.samples.size(), 3u);
  EXPECT_EQ(t.samples[2].t_s, 3.0);
  EXPECT_EQ(t.samples[2].q[0], 0.1);
  ASSERT_EQ(t.events.size(), 2u);
  EXPECT_EQ(t.events[0].t_s, 0.5);
  EXPECT_EQ(t.events[1].t_s, 3.0);
  EXPECT_EQ(t.events[1].action, GripperAction::kRelease);
  // a segment that does not start at t = 0 keeps its first sample
  append(t, JointTrajectory{{at_rest(0.5)}, {}});
  ASSERT_EQ(t.samples.size(), 4u);
  EXPECT_EQ(t.samples[3].t_s, 3.5);
}

TEST(Trajectory, DwellStandsStillAndSampleAtInterpolates) {
  JointSample moving = at_rest(1.0, {0.1, 0.4, 0.0, 0.0});
  moving.qd = {0.01, 0.2, 0.0, 0.0};
  moving.qdd = {0.0, -0.1, 0.0, 0.0};
  JointTrajectory t{{at_rest(0.0, {0.08, 0.0, 0.0, 0.0}), moving}, {}};
  append_dwell(t, 0.0);
  EXPECT_EQ(t.samples.size(), 2u) << "no dwell, no sample";
  append_dwell(t, 0.5);
  ASSERT_EQ(t.samples.size(), 3u);
  EXPECT_EQ(t.samples[2].t_s, 1.5);
  EXPECT_EQ(t.samples[2].q, moving.q);
  EXPECT_EQ(t.samples[2].qd, (JointVector{}));
  EXPECT_EQ(t.samples[2].qdd, (JointVector{}));
  EXPECT_EQ(t.duration_s(), 1.5);
  // before the start and after the end: the end points; in between: linear
  EXPECT_EQ(sample_at(t, -1.0)[0], 0.08);
  EXPECT_EQ(sample_at(t, 9.0), moving.q);
  const JointVector q = sample_at(t, 0.25);
  EXPECT_NEAR(q[0], 0.08 + 0.25 * 0.02, 1e-15);
  EXPECT_NEAR(q[1], 0.1, 1e-15);
  EXPECT_EQ(sample_at(t, 1.25), moving.q);
}

TEST(Quintic, RefusesBadArgumentsByName) {
  const JointVector home = model().home;
  const auto error_of = [&](const JointVector& a, const JointVector& b, QuinticOptions o) {
    auto r = plan_quintic(model(), a, b, o);
    return r ? std::string("ok") : std::to_string(r.error().code) + ": " + r.error().message;
  };
  const JointVector goal{0.1, 0.5, 0.5, 0.5};
  EXPECT_EQ(error_of(home, goal, {1, 0.0}), "10: samples = 1: must be between 2 and 1000000");
  EXPECT_EQ(error_of(home, goal, {1000001, 0.0}),
            "10: samples = 1000001: must be between 2 and 1000000");
  EXPECT_EQ(error_of(home, goal, {60, -1.0}), "10: duration = -1 s: must be >= 0 (0 = shortest)");
  EXPECT_EQ(error_of(home, goal, {60, NAN}), "10: duration = nan s: must be >= 0 (0 = shortest)");
  EXPECT_EQ(error_of(home, {0.1, 0.5, NAN, 0.5}, {}), "10: j3 is not finite");
  EXPECT_EQ(error_of({0.1, deg_to_rad(-106), 0.0, 0.0}, goal, {}),
            "11: start j2 = -1.8500490071139892 is outside its limits [-1.832595714594046, "
            "2.007128639793479]");
  EXPECT_EQ(error_of(home, {0.12, 0.0, 0.0, -0.5}, {}),
            "11: goal j4 = -0.5 is outside its limits [0, 3.141592653589793]");
}

// The shortest quintic from the peak speed 15/8 d/T and acceleration 10/sqrt(3) d/T^2 of the
// polynomial: 1 rad of J2 is 945 J2 motor steps and 0.8 x 945 = 756 J3 motor steps; the J2
// motor's acceleration limit decides: T = sqrt(10/sqrt(3) x 945 / 1500) = 1.90717 s.
TEST(Quintic, ShortestDurationFromTheMotorLimitsByHand) {
  const JointVector a{0.1, 0.0, 0.0, 0.0}, b{0.1, 1.0, 0.0, 0.0};
  const double t_j2 = std::sqrt(10.0 / std::sqrt(3.0) * 945.0 / 1500.0);
  EXPECT_NEAR(quintic_min_duration(model(), a, b), t_j2, 1e-8);
  auto q = plan_quintic(model(), a, b);
  ASSERT_TRUE(q) << q.error().message;
  EXPECT_NEAR(q->duration_s(), t_j2, 1e-8);
  EXPECT_EQ(q->samples.size(), 60u);
  auto short_one = plan_quintic(model(), a, b, {60, 1.9});
  ASSERT_FALSE(short_one);
  EXPECT_EQ(short_one.error().code, static_cast<int>(PlanError::kMotorLimit));
  EXPECT_EQ(short_one.error().message,
            "duration 1.9000 s is too short for the motor limits: this move needs at least "
            "1.9072 s");
  // the wrist alone, 90 deg at 300 deg/s: T = 15/8 x 90 / 300 = 0.5625 s
  const JointVector w{0.1, 0.0, 0.0, kPi / 2};
  EXPECT_NEAR(quintic_min_duration(model(), a, w), 0.5625, 1e-8);
  // no motion: one sample at rest
  auto still = plan_quintic(model(), a, a);
  ASSERT_TRUE(still);
  ASSERT_EQ(still->samples.size(), 1u);
  EXPECT_EQ(still->samples[0].q, a);
  EXPECT_EQ(still->duration_s(), 0.0);
}

TEST(Trapezoid, RefusesBadArgumentsByName) {
  const JointVector a = model().home, b{0.1, 0.5, 0.5, 0.5};
  const auto error_of = [&](TrapezoidOptions o) {
    auto r = plan_trapezoid(model(), a, b, o);
    return r ? std::string("ok") : std::to_string(r.error().code) + ": " + r.error().message;
  };
  EXPECT_EQ(error_of({0.0, 1.0, 1.0}), "10: dt = 0 s: must be in (0, 1]");
  EXPECT_EQ(error_of({1.5, 1.0, 1.0}), "10: dt = 1.5 s: must be in (0, 1]");
  EXPECT_EQ(error_of({0.01, 1.5, 1.0}), "10: speed/accel scale 1.5/1: must be in (0, 1]");
  EXPECT_EQ(error_of({0.01, 1.0, 0.0}), "10: speed/accel scale 1/0: must be in (0, 1]");
  EXPECT_EQ(error_of({0.01, 1.0, 1.0}), "ok");
}

// The wrist alone has a speed limit and no acceleration limit: the profile accelerates at 4 v^2
// (a quarter of the move's time on each ramp). 90 deg at 300 deg/s: v = 10/3 per second, ramps
// of 1 / (4 v) = 0.075 s, cruise 0.75 / v = 0.225 s: 0.375 s in all.
TEST(Trapezoid, WristOnlyMoveAndNoMove) {
  const JointVector a{0.1, 0.0, 0.0, 0.0}, b{0.1, 0.0, 0.0, kPi / 2};
  auto t = plan_trapezoid(model(), a, b, {0.001, 1.0, 1.0});
  ASSERT_TRUE(t) << t.error().message;
  EXPECT_NEAR(t->duration_s(), 0.375, 1e-12);
  EXPECT_EQ(t->samples.size(), 376u);
  double peak = 0.0;
  for (const JointSample& s : t->samples) peak = std::max(peak, rad_to_deg(s.qd[3]));
  EXPECT_NEAR(peak, 300.0, 1e-9);
  EXPECT_EQ(t->samples.back().q, b);
  auto still = plan_trapezoid(model(), a, a);
  ASSERT_TRUE(still);
  ASSERT_EQ(still->samples.size(), 1u);
  EXPECT_EQ(still->samples[0].q, a);
}

TEST(ViaPoints, RefusesTooFewPointsAndNamesTheFailingSegment) {
  auto one = plan_via_points(model(), {model().home});
  ASSERT_FALSE(one);
  EXPECT_EQ(one.error().code, static_cast<int>(PlanError::kBadArgument));
  EXPECT_EQ(one.error().message, "a via-point path needs at least 2 points, got 1");
  ViaOptions quintic_via;
  quintic_via.profile = Profile::kQuintic;
  auto bad = plan_via_points(
      model(), {model().home, {0.1, 0.5, 0.5, 0.5}, {0.1, 0.5, 0.5, 0.5}, {0.2, 0.5, 0.5, 0.5}},
      quintic_via);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, static_cast<int>(PlanError::kJointLimit));
  EXPECT_EQ(bad.error().message,
            "segment 2 -> 3: goal j1 = 0.2 is outside its limits [0.01, 0.12]");
  // quintic segments stop at each point: each ends at rest exactly on it
  auto ok = plan_via_points(model(), {model().home, {0.1, 0.5, 0.5, 0.5}, {0.05, -0.5, 1.0, 0.2}},
                            quintic_via);
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(ok->samples.size(), 60u + 59u);
  EXPECT_EQ(ok->samples[59].q, (JointVector{0.1, 0.5, 0.5, 0.5}));
  EXPECT_EQ(ok->samples[59].qd, (JointVector{}));
  EXPECT_EQ(ok->samples.back().q, (JointVector{0.05, -0.5, 1.0, 0.2}));
}

TEST(Line, RefusesBadArgumentsByName) {
  const JointVector home = model().home;
  const ToolPose goal{0.2, 0.05, 0.0, 0.3};
  const auto error_of = [&](const JointVector& q0, const ToolPose& g, LineOptions o) {
    auto r = plan_line(model(), q0, g, o);
    return r ? std::string("ok") : std::to_string(r.error().code) + ": " + r.error().message;
  };
  EXPECT_EQ(error_of(home, goal, {0.0, 0.01, 1.0, 1.0}),
            "10: line step 0 m / dt 0.01 s: both must be > 0 (dt <= 1 s)");
  EXPECT_EQ(error_of(home, goal, {0.001, 2.0, 1.0, 1.0}),
            "10: line step 0.001 m / dt 2 s: both must be > 0 (dt <= 1 s)");
  EXPECT_EQ(error_of(home, goal, {0.001, 0.01, 0.0, 1.0}),
            "10: speed/accel scale 0/1: must be in (0, 1]");
  EXPECT_EQ(error_of(home, goal, {0.001, 0.01, 1.0, 2.0}),
            "10: speed/accel scale 1/2: must be in (0, 1]");
  EXPECT_EQ(error_of({0.005, 0.0, 0.0, 0.0}, goal, {}),
            "11: start j1 = 0.005 is outside its limits");
  EXPECT_EQ(error_of(home, {0.2, INFINITY, 0.0, 0.0}, {}), "1: line goal is not finite");
  EXPECT_EQ(error_of(home, {0.2, 0.0, 0.0, NAN}, {}), "1: line goal is not finite");
  // home's tool is at (0.254, 0, 0.053): 10 mm along x in steps of 3 nm is 3333334 samples
  EXPECT_EQ(error_of(home, {0.244, 0.0, 0.053, 0.0}, {3e-9, 0.01, 1.0, 1.0}),
            "10: line needs 3333334 samples: step too small");
}

TEST(Line, ToWhereTheToolAlreadyIsIsOneSample) {
  const JointVector q0{0.08, 0.3, 0.6, 0.9};
  auto t = plan_line(model(), q0, forward(model(), q0));
  ASSERT_TRUE(t) << t.error().message;
  ASSERT_EQ(t->samples.size(), 1u);
  EXPECT_EQ(t->samples[0].q, q0);
  EXPECT_EQ(t->samples[0].t_s, 0.0);
}

TEST(Line, NamesTheUnreachableSample) {
  // from the home pose straight out along x, beyond the reach 0.067 + 0.187 = 0.254 m
  auto t = plan_line(model(), model().home, {0.300, 0.0, 0.053, 0.0});
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().code, static_cast<int>(PlanError::kUnreachable));
  // 46 mm in 1 mm steps: the first sample, 1 mm out, is already beyond the reach
  EXPECT_EQ(t.error().message.rfind("line sample 1 of 46 at (0.2550, 0.0000, 0.0530) m is "
                                    "unreachable: target (0.255000, 0.000000) m is 0.188000 m "
                                    "from the shoulder axis, beyond the reach of 0.187000 m",
                                    0),
            0u)
      << t.error().message;
}

// When the elbow the line started on leaves the shoulder's travel, the only solution left is
// the other elbow, 2 atan2(a3 sin q3, a2 + a3 cos q3) away in q2 (61 deg at q3 = 60 deg): the
// line refuses to jump.
TEST(Line, RefusesToFlipTheElbowHalfway) {
  const JointVector q0{0.06, deg_to_rad(-100), deg_to_rad(60), deg_to_rad(40)};
  const ToolPose p0 = forward(model(), q0);
  // the same radius about the shoulder (0.067, 0), turned 10 deg clockwise: elbow up would need
  // q2 = -110 deg, past -105
  const double c = std::cos(deg_to_rad(-10)), s = std::sin(deg_to_rad(-10));
  const double dx = p0.x_m - 0.067, dy = p0.y_m;
  const ToolPose goal{0.067 + c * dx - s * dy, s * dx + c * dy, p0.z_m, p0.yaw_rad};
  auto t = plan_line(model(), q0, goal);
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().code, static_cast<int>(PlanError::kDiscontinuous));
  const std::string& m = t.error().message;
  const size_t at = m.find(": j2 would jump by ");
  ASSERT_NE(at, std::string::npos) << m;
  EXPECT_EQ(m.rfind("line sample ", 0), 0u) << m;
  EXPECT_NE(m.find(" deg (singularity or joint wrap); plan a joint move"), std::string::npos) << m;
  const double jump_deg = std::stod(m.substr(at + 19));
  const double q3 = deg_to_rad(60);
  const double expected =
      2.0 * rad_to_deg(std::atan2(0.095 * std::sin(q3), 0.092 + 0.095 * std::cos(q3)));
  EXPECT_NEAR(jump_deg, expected, 1.0) << m;  // q3 changes a little along the chord
}

// A stage's planner refusing its options is named with the stage.
TEST(PickPlace, NamesTheStageWhosePlannerRefuses) {
  PickPlaceRequest r;
  r.pick = {0.18, 0.08, -0.02, deg_to_rad(90)};
  r.place = {0.17, -0.11, -0.02, deg_to_rad(90)};
  r.dt_s = 0.0;
  auto t = plan_pick_place(model(), model().home, r);
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().code, static_cast<int>(PlanError::kBadArgument));
  EXPECT_EQ(t.error().message, "approach above the pick point: dt = 0 s: must be in (0, 1]");
}

TEST(PickPlace, RefusesBadApproachOrDwell) {
  PickPlaceRequest r;
  r.pick = {0.18, 0.08, -0.02, deg_to_rad(90)};
  r.place = {0.17, -0.11, -0.02, deg_to_rad(90)};
  r.approach_height_m = 0.0;
  auto t = plan_pick_place(model(), model().home, r);
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().code, static_cast<int>(PlanError::kBadArgument));
  EXPECT_EQ(t.error().message, "approach height 0 m must be > 0 and dwell 0.4 s >= 0");
  r.approach_height_m = 0.04;
  r.grip_dwell_s = -0.1;
  t = plan_pick_place(model(), model().home, r);
  ASSERT_FALSE(t);
  EXPECT_EQ(t.error().message, "approach height 0.04 m must be > 0 and dwell -0.1 s >= 0");
}

}  // namespace
}  // namespace scaratwin
