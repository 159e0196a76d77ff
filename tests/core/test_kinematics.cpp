// Kinematics: FK against hand-computed poses, IK round trips over random reachable targets,
// both elbow branches, every failure mode, the Jacobian against finite differences and the
// joint <-> motor conversion.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/motor.hpp"

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

double pose_error(const ToolPose& a, const ToolPose& b) {
  return std::max({std::abs(a.x_m - b.x_m), std::abs(a.y_m - b.y_m), std::abs(a.z_m - b.z_m)});
}

TEST(Fk, HomeIsArmStretchedAlongX) {
  const ToolPose p = forward(model(), {0.12, 0, 0, 0});
  EXPECT_NEAR(p.x_m, 0.067 + 0.092 + 0.095, 1e-15);
  EXPECT_NEAR(p.y_m, 0.0, 1e-15);
  EXPECT_NEAR(p.z_m, 0.12 - 0.067, 1e-15);
  EXPECT_NEAR(p.yaw_rad, 0.0, 1e-15);
}

TEST(Fk, MatchesHandComputedPose) {
  // q2 = 90 deg, q3 = -90 deg: link 2 along +y, link 3 back along +x.
  const ToolPose p = forward(model(), {0.05, deg_to_rad(90), deg_to_rad(-90), deg_to_rad(30)});
  EXPECT_NEAR(p.x_m, 0.067 + 0.095, 1e-15);
  EXPECT_NEAR(p.y_m, 0.092, 1e-15);
  EXPECT_NEAR(p.z_m, 0.05 - 0.067, 1e-15);
  EXPECT_NEAR(p.yaw_rad, deg_to_rad(30), 1e-15);
  // the paper's formula x = 0.067 + 0.092 cos q2 + 0.095 cos(q2+q3).
  const double q2 = 0.3, q3 = 1.1;
  const ToolPose r = forward(model(), {0.1, q2, q3, 0.2});
  EXPECT_NEAR(r.x_m, 0.067 + 0.092 * std::cos(q2) + 0.095 * std::cos(q2 + q3), 1e-15);
  EXPECT_NEAR(r.y_m, 0.092 * std::sin(q2) + 0.095 * std::sin(q2 + q3), 1e-15);
  EXPECT_NEAR(r.yaw_rad, q2 + q3 + 0.2, 1e-15);
}

TEST(Fk, ClosedFormAgreesWithDhProduct) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 1000; ++i) {
    const JointVector q = random_joints(rng);
    const ToolPose p = forward(model(), q);
    const Eigen::Matrix4d t = forward_transform(model(), q);
    EXPECT_NEAR(t(0, 3), p.x_m, 1e-15);
    EXPECT_NEAR(t(1, 3), p.y_m, 1e-15);
    EXPECT_NEAR(t(2, 3), p.z_m, 1e-15);
    EXPECT_NEAR(std::atan2(t(1, 0), t(0, 0)), p.yaw_rad, 1e-14);
    EXPECT_NEAR(t(2, 2), 1.0, 1e-15);
  }
}

TEST(Ik, RoundTripsHundredThousandRandomTargets) {
  std::mt19937_64 rng(20241122);
  int solved = 0;
  double worst_pos = 0.0, worst_yaw = 0.0;
  constexpr int kCount = 100000;
  for (int i = 0; i < kCount; ++i) {
    const JointVector q = random_joints(rng);
    const ToolPose target = forward(model(), q);
    auto sol = inverse(model(), target, random_joints(rng));
    ASSERT_TRUE(sol) << sol.error().message;
    ++solved;
    const ToolPose back = forward(model(), *sol);
    worst_pos = std::max(worst_pos, pose_error(back, target));
    worst_yaw = std::max(worst_yaw, std::abs(wrap_angle(back.yaw_rad - target.yaw_rad)));
    ASSERT_EQ(first_joint_outside_limits(model(), *sol), -1);
  }
  EXPECT_EQ(solved, kCount);
  EXPECT_LE(worst_pos, 1e-12);
  EXPECT_LE(worst_yaw, 1e-12);
}

TEST(Ik, InverseIsTheFirstOfInverseAll) {
  // inverse() chooses between the branches without branching; inverse_all() sorts them.
  std::mt19937_64 rng(5);
  RobotModel narrow = model();  // limits that often leave only one elbow valid
  narrow.limits[1] = {deg_to_rad(-60), deg_to_rad(60)};
  for (const RobotModel* m : {&model(), static_cast<const RobotModel*>(&narrow)}) {
    for (int i = 0; i < 20000; ++i) {
      const ToolPose target = forward(*m, random_joints(rng));
      const JointVector seed = random_joints(rng);
      auto one = inverse(*m, target, seed);
      auto all = inverse_all(*m, target, seed);
      ASSERT_EQ(one.ok(), all.ok());
      if (!one) {
        EXPECT_EQ(one.error().code, all.error().code);
        EXPECT_EQ(one.error().message, all.error().message);
        continue;
      }
      EXPECT_EQ(*one, all->solutions[0]);
    }
  }
  // yaws beyond the hot path's range and non-finite ones take the general path.
  for (double yaw : {1e12 + 0.3, -3e15, 1e300, double{NAN}, double{INFINITY}}) {
    const ToolPose p{0.2, 0.05, 0.0, yaw};
    auto one = inverse(model(), p, model().home);
    auto all = inverse_all(model(), p, model().home);
    ASSERT_EQ(one.ok(), all.ok()) << yaw;
    if (one) {
      EXPECT_EQ(*one, all->solutions[0]) << yaw;
    } else {
      EXPECT_EQ(one.error().code, all.error().code) << yaw;
    }
  }
}

TEST(WrapAngle, WrapsIntoMinusPiPi) {
  EXPECT_EQ(wrap_angle(kPi), kPi);
  EXPECT_EQ(wrap_angle(-kPi), kPi);
  EXPECT_EQ(wrap_angle(3 * kPi), kPi);
  EXPECT_EQ(wrap_angle(0.25), 0.25);
  EXPECT_TRUE(std::signbit(wrap_angle(-0.0)));
  EXPECT_NEAR(wrap_angle(2 * kPi + 0.5), 0.5, 1e-15);
  EXPECT_NEAR(wrap_angle(-7 * kPi - 0.5), kPi - 0.5, 1e-14);
  EXPECT_NEAR(wrap_angle(1e6), std::remainder(1e6, 2 * kPi), 1e-9);
  const double huge = wrap_angle(1e300);  // beyond the rounding trick: the floor fallback
  EXPECT_TRUE(huge > -kPi && huge <= kPi);
  EXPECT_TRUE(std::isnan(wrap_angle(NAN)));
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> d(-100.0, 100.0);
  for (int i = 0; i < 100000; ++i) {
    const double a = d(rng), w = wrap_angle(a);
    ASSERT_TRUE(w > -kPi && w <= kPi) << a;
    ASSERT_NEAR(std::remainder(a - w, 2 * kPi), 0.0, 1e-13) << a;
  }
}

TEST(Ik, ReturnsBothElbowBranches) {
  const JointVector q{0.06, deg_to_rad(20), deg_to_rad(60), deg_to_rad(40)};
  const ToolPose p = forward(model(), q);
  auto all = inverse_all(model(), p, q);
  ASSERT_TRUE(all);
  ASSERT_EQ(all->count, 2);
  EXPECT_NEAR(all->solutions[0][2], deg_to_rad(60), 1e-12);  // nearest to the seed first
  EXPECT_LT(all->solutions[1][2], 0.0);                      // the other elbow
  for (int b = 0; b < 2; ++b) {
    EXPECT_LE(pose_error(forward(model(), all->solutions[b]), p), 1e-12);
  }
}

TEST(Ik, PicksNearestElbowSolution) {
  const JointVector up{0.06, deg_to_rad(-10), deg_to_rad(70), deg_to_rad(90)};
  const ToolPose p = forward(model(), up);
  auto branches = inverse_branches(model(), p);
  ASSERT_TRUE(branches);
  const JointVector down = branches->solutions[1];
  ASSERT_LT(down[2], 0.0);
  auto from_up = inverse(model(), p, up);
  auto from_down = inverse(model(), p, down);
  ASSERT_TRUE(from_up && from_down);
  EXPECT_GT((*from_up)[2], 0.0);
  EXPECT_LT((*from_down)[2], 0.0);
}

TEST(Ik, RejectsTargetBeyondReach) {
  auto r = inverse(model(), {0.40, 0.0, 0.0, 0.0}, model().home);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(IkError::kBeyondReach));
  EXPECT_NE(r.error().message.find("beyond the reach"), std::string::npos);
}

TEST(Ik, RejectsTargetInsideDeadZone) {
  auto r = inverse(model(), {0.0675, 0.0005, 0.0, 0.0}, model().home);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(IkError::kInsideDeadZone));
}

TEST(Ik, RejectsZOutsideTravel) {
  auto r = inverse(model(), {0.2, 0.0, 0.2, 0.0}, model().home);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(IkError::kZOutOfTravel));
  EXPECT_NE(r.error().message.find("Z travel"), std::string::npos);
}

TEST(Ik, NamesTheJointOutOfItsLimit) {
  // behind the robot: the shoulder would have to turn past its limit on both elbows.
  auto r2 = inverse(model(), {-0.05, -0.05, -0.02, deg_to_rad(90)}, model().home);
  ASSERT_FALSE(r2);
  EXPECT_EQ(r2.error().code, static_cast<int>(IkError::kJ2Limit));
  EXPECT_NE(r2.error().message.find("j2"), std::string::npos);
  // reachable position, but a yaw the wrist (0..180 deg) cannot make.
  auto r4 = inverse(model(), {0.22, 0.0, -0.02, deg_to_rad(-90)}, model().home);
  ASSERT_FALSE(r4);
  EXPECT_EQ(r4.error().code, static_cast<int>(IkError::kJ4Limit));
  // elbow beyond 205 deg is needed (folded arm, shoulder rotated).
  RobotModel narrow = model();
  narrow.limits[2] = {deg_to_rad(-10), deg_to_rad(10)};
  auto r3 = inverse(narrow, {0.16, 0.05, -0.02, deg_to_rad(90)}, narrow.home);
  ASSERT_FALSE(r3);
  EXPECT_EQ(r3.error().code, static_cast<int>(IkError::kJ3Limit));
}

TEST(Ik, RejectsNonFiniteTarget) {
  auto r = inverse(model(), {NAN, 0.0, 0.0, 0.0}, model().home);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, static_cast<int>(IkError::kNotFinite));
  for (const ToolPose& p :
       {ToolPose{0.2, NAN, 0.0, 0.0}, ToolPose{0.2, 0.0, NAN, 0.0}, ToolPose{0.2, 0.0, 0.0, NAN},
        ToolPose{INFINITY, 0.0, 0.0, 0.0}, ToolPose{0.2, -INFINITY, 0.0, 0.0},
        ToolPose{0.2, 0.0, 0.0, INFINITY}}) {
    auto e = inverse(model(), p, model().home);
    ASSERT_FALSE(e);
    EXPECT_EQ(e.error().code, static_cast<int>(IkError::kNotFinite));
    EXPECT_NE(e.error().message.find("not finite"), std::string::npos);
  }
}

TEST(Jacobian, MatchesFiniteDifferences) {
  std::mt19937_64 rng(3);
  for (int i = 0; i < 200; ++i) {
    const JointVector q = random_joints(rng);
    const Eigen::Matrix4d j = jacobian(model(), q);
    for (int c = 0; c < kNumJoints; ++c) {
      const double h = 1e-6;
      JointVector a = q, b = q;
      a[c] -= h;
      b[c] += h;
      const ToolPose pa = forward(model(), a), pb = forward(model(), b);
      EXPECT_NEAR(j(0, c), (pb.x_m - pa.x_m) / (2 * h), 1e-8);
      EXPECT_NEAR(j(1, c), (pb.y_m - pa.y_m) / (2 * h), 1e-8);
      EXPECT_NEAR(j(2, c), (pb.z_m - pa.z_m) / (2 * h), 1e-8);
      EXPECT_NEAR(j(3, c), wrap_angle(pb.yaw_rad - pa.yaw_rad) / (2 * h), 1e-8);
    }
  }
}

TEST(Motor, ConvertsJointsToStepsWithBeltCoupling) {
  const JointVector q{0.05, 1.0, 0.5, deg_to_rad(90)};
  const MotorPosition m = joints_to_motors(model(), q);
  EXPECT_DOUBLE_EQ(m.steps[0], 0.05 * 205560.0);
  EXPECT_DOUBLE_EQ(m.steps[1], 945.0);
  EXPECT_DOUBLE_EQ(m.steps[2], 0.5 * 1455.0 + 0.8 * 945.0);
  EXPECT_NEAR(m.wrist_deg, 90.0, 1e-12);
  const JointVector back = motors_to_joints(model(), m.steps, m.wrist_deg);
  for (int j = 0; j < kNumJoints; ++j) EXPECT_NEAR(back[j], q[j], 1e-14);
  // moving J2 alone drives the J3 motor 0.8 step per J2 step so that q3 stays put.
  const auto s0 = joints_to_steps(model(), {0.05, 0.0, 0.3, 0.0});
  const auto s1 = joints_to_steps(model(), {0.05, 0.5, 0.3, 0.0});
  EXPECT_NEAR(s1[2] - s0[2], 0.8 * (s1[1] - s0[1]), 1.0);
}

// The paper's switches in counts: Z 0.1225 m, J2 117 deg, J3 -77 deg as a joint count (no
// coupling share: the J3 switch senses the joint).
TEST(Motor, EndstopStepsAreTheNearestCountsOfTheSwitches) {
  const auto s = endstop_steps(model());
  EXPECT_EQ(s[0], 25181);  // 0.1225 x 205560 = 25181.1
  EXPECT_EQ(s[1], 1930);   // 117 deg = 2.04204 rad x 945 = 1929.7
  EXPECT_EQ(s[2], -1955);  // -77 deg = -1.34390 rad x 1455 = -1955.4
  RobotModel m = model();
  m.motors.j2.steps_per_unit = 2000.0;
  m.motors.j3_per_j2_coupling = 1.5;
  EXPECT_EQ(endstop_steps(m)[1], 4084);   // 2.04204 x 2000 = 4084.07
  EXPECT_EQ(endstop_steps(m)[2], -1955);  // unchanged by the coupling
}

}  // namespace
}  // namespace scaratwin
