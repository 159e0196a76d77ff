// Trajectories: the quintic golden file, limits on every planner over random moves,
// continuity of position and velocity, Cartesian lines and pick-and-place.
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
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

}  // namespace
}  // namespace scaratwin
