// Kinematics: FK against hand-computed poses, IK round trips over random reachable targets,
// both elbow branches, every failure mode, the Jacobian against finite differences and the
// joint <-> motor conversion.
#include <cmath>
#include <random>
#include <string>
#include <utility>

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

// The failure messages in full: the target, the distance or the d1 it needs, and the limit.
TEST(Ik, FailureMessagesNameTheTargetAndTheLimit) {
  const auto message_of = [](const ToolPose& p) {
    auto r = inverse(model(), p, model().home);
    return r ? std::string("(solved)") : r.error().message;
  };
  // 0.40 - 0.067 = 0.333 m from the shoulder; reach 0.092 + 0.095 = 0.187 m
  EXPECT_EQ(message_of({0.40, 0.0, 0.0, 0.0}),
            "target (0.400000, 0.000000) m is 0.333000 m from the shoulder axis, beyond the "
            "reach of 0.187000 m");
  // (0.0005, 0.0005) from the shoulder: sqrt(2) x 0.0005 = 0.000707 m; |0.092 - 0.095| = 0.003
  EXPECT_EQ(message_of({0.0675, 0.0005, 0.0, 0.0}),
            "target (0.067500, 0.000500) m is 0.000707 m from the shoulder axis, inside the dead "
            "zone of radius 0.003000 m");
  // the d offsets sum to -0.017 - 0.010 - 0.040 = -0.067 m: z = 0.2 needs d1 = 0.267, and the
  // travel [0.01, 0.12] gives tool z in [-0.057, 0.053]
  EXPECT_EQ(message_of({0.2, 0.0, 0.2, 0.0}),
            "z = 0.200000 m needs d1 = 0.267000 m, outside the Z travel [0.01, 0.12] m (tool z "
            "from -0.0570 to 0.0530 m)");
  EXPECT_EQ(message_of({0.2, 0.0, NAN, 0.0}), "target (0.2, 0, nan, 0) is not finite");
  // inverse_branches reports the same failures
  auto b = inverse_branches(model(), {0.40, 0.0, 0.0, 0.0});
  ASSERT_FALSE(b);
  EXPECT_EQ(b.error().code, static_cast<int>(IkError::kBeyondReach));
  EXPECT_EQ(b.error().message, message_of({0.40, 0.0, 0.0, 0.0}));
}

// Limit failures name the joint, its value on the elbow nearer the seed and its limits.
TEST(Ik, LimitMessagesGiveTheJointValueAndLimits) {
  // the arm stretched backwards (x = 0.067 - 0.187): q2 = 180 deg on both elbows
  auto r2 = inverse(model(), {0.067 - 0.187, 0.0, -0.02, 0.0}, model().home);
  ASSERT_FALSE(r2);
  EXPECT_EQ(r2.error().code, static_cast<int>(IkError::kJ2Limit));
  EXPECT_EQ(r2.error().message,
            "no elbow solution within the joint limits: j2 = 180.000 deg is outside [-105.0, "
            "115.0] deg (other elbow: j2 out of limits)");
  // stretched forwards (q2 = q3 = 0) with yaw -90 deg: q4 = -90 deg on both elbows
  auto r4 = inverse(model(), {0.067 + 0.187, 0.0, -0.02, deg_to_rad(-90)}, model().home);
  ASSERT_FALSE(r4);
  EXPECT_EQ(r4.error().code, static_cast<int>(IkError::kJ4Limit));
  EXPECT_EQ(r4.error().message,
            "no elbow solution within the joint limits: j4 = -90.000 deg is outside [0.0, 180.0] "
            "deg (other elbow: j4 out of limits)");
  // r^2 = a2^2 + a3^2 puts the elbow at +-90 deg; the elbow limited to +-10 deg refuses both,
  // and the message gives the branch nearer the seed (elbow down)
  RobotModel narrow = model();
  narrow.limits[2] = {deg_to_rad(-10), deg_to_rad(10)};
  const double r = std::sqrt(0.092 * 0.092 + 0.095 * 0.095);
  auto r3 = inverse_all(narrow, {0.067 + r, 0.0, -0.02, 0.0}, {0.05, 0.8, -1.5, 0.8});
  ASSERT_FALSE(r3);
  EXPECT_EQ(r3.error().code, static_cast<int>(IkError::kJ3Limit));
  EXPECT_EQ(r3.error().message,
            "no elbow solution within the joint limits: j3 = -90.000 deg is outside [-10.0, 10.0] "
            "deg (other elbow: j3 out of limits)");
}

// A stretched arm has one elbow solution, not two equal ones.
TEST(Ik, StretchedArmHasOneSolution) {
  auto all = inverse_all(model(), {0.067 + 0.187, 0.0, -0.02, deg_to_rad(45)}, model().home);
  ASSERT_TRUE(all) << all.error().message;
  EXPECT_EQ(all->count, 1);
  const JointVector& q = all->solutions[0];
  EXPECT_NEAR(q[0], -0.02 + 0.067, 1e-15);
  EXPECT_NEAR(q[1], 0.0, 1e-7);  // acos near 1 loses half the digits
  EXPECT_NEAR(q[2], 0.0, 1e-7);
  EXPECT_NEAR(q[3], deg_to_rad(45), 1e-7);
}

// When only the other elbow fits the limits, it is the one solution, whatever the seed.
TEST(Ik, OnlyTheElbowInsideTheLimitsIsReturned) {
  // elbow down at q2 = q3 = -60 deg; the elbow-up twin needs q2 = -60 - 2 atan2(a3 sin 60,
  // a2 + a3 cos 60) = -121.1 deg, past the shoulder's -105
  const JointVector down{0.06, deg_to_rad(-60), deg_to_rad(-60), deg_to_rad(30)};
  const double twin_q2 =
      -60.0 - 2.0 * rad_to_deg(std::atan2(0.095 * std::sin(deg_to_rad(60)),
                                          0.092 + 0.095 * std::cos(deg_to_rad(60))));
  ASSERT_LT(twin_q2, -105.0);
  // the pose by hand: links at -60 and -120 deg, yaw -90 deg
  const ToolPose p{0.067 + 0.092 * 0.5 - 0.095 * 0.5,
                   -0.092 * std::sqrt(3.0) / 2 - 0.095 * std::sqrt(3.0) / 2, 0.06 - 0.067,
                   deg_to_rad(-90)};
  const JointVector up_seed{0.06, deg_to_rad(-120), deg_to_rad(60), deg_to_rad(0)};
  auto all = inverse_all(model(), p, up_seed);
  ASSERT_TRUE(all) << all.error().message;
  EXPECT_EQ(all->count, 1);
  for (int j = 0; j < kNumJoints; ++j) EXPECT_NEAR(all->solutions[0][j], down[j], 1e-12) << j;
  auto one = inverse(model(), p, up_seed);
  ASSERT_TRUE(one);
  EXPECT_EQ(*one, all->solutions[0]);
}

// A joint whose travel holds more than one turn takes the turn nearest the seed.
TEST(Ik, WideJointTakesTheTurnNearestTheSeed) {
  RobotModel wide = model();
  wide.limits[1] = {deg_to_rad(-190), deg_to_rad(190)};  // 6.63 rad: 175 and -185 deg both fit
  // elbow up at q2 = 175, q3 = 20, q4 = 90 deg: links at 175 and 195 deg, yaw 285 = -75 deg
  const double l2 = deg_to_rad(175), l3 = deg_to_rad(195);
  const ToolPose p{0.067 + 0.092 * std::cos(l2) + 0.095 * std::cos(l3),
                   0.092 * std::sin(l2) + 0.095 * std::sin(l3), -0.02, deg_to_rad(-75)};
  for (const auto& [seed_q2, want_q2] : {std::pair{3.0, 175.0}, std::pair{-3.0, -185.0}}) {
    const JointVector seed{0.05, seed_q2, deg_to_rad(20), deg_to_rad(90)};
    auto one = inverse(wide, p, seed);
    auto all = inverse_all(wide, p, seed);
    ASSERT_TRUE(one && all) << seed_q2;
    EXPECT_NEAR((*one)[1], deg_to_rad(want_q2), 1e-12) << seed_q2;
    EXPECT_NEAR((*one)[2], deg_to_rad(20), 1e-12) << seed_q2;
    EXPECT_NEAR((*one)[3], deg_to_rad(90), 1e-12) << seed_q2;
    EXPECT_EQ(*one, all->solutions[0]) << seed_q2;
  }
}

// A tool off the wrist axis (dh.j4.a) and a base turned about z (dh.j1.theta), by hand.
TEST(Fk, LinkTransformsComposeToTheDhProduct) {
  RobotModel m = model();
  m.dh[0].theta_rad = 0.4;  // offsets and twists the paper's robot has not, to catch an order
  m.dh[1].alpha_rad = 0.1;
  m.dh[2].theta_rad = -0.2;
  m.dh[3].a_m = 0.03;
  std::mt19937_64 rng(11);
  for (int i = 0; i < 200; ++i) {
    const JointVector q = random_joints(rng);
    for (const RobotModel* r : {&model(), static_cast<const RobotModel*>(&m)}) {
      const auto links = link_transforms(*r, q);
      Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
      for (const Eigen::Matrix4d& x : links) t = t * x;
      EXPECT_LT((t - forward_transform(*r, q)).cwiseAbs().maxCoeff(), 1e-14);
    }
    // the elbow (link2's origin) of the paper's robot, by hand
    const auto links = link_transforms(model(), q);
    const Eigen::Matrix4d elbow = links[0] * links[1] * links[2];
    EXPECT_NEAR(elbow(0, 3), 0.067 + 0.092 * std::cos(q[1]), 1e-15);
    EXPECT_NEAR(elbow(1, 3), 0.092 * std::sin(q[1]), 1e-15);
    EXPECT_NEAR(elbow(2, 3), q[0] - 0.017, 1e-15);
    EXPECT_NEAR(std::atan2(elbow(1, 0), elbow(0, 0)), wrap_angle(q[1] + q[2]), 1e-14);
  }
}

TEST(Fk, ToolOffsetAndTurnedBase) {
  RobotModel m = model();
  m.dh[0].theta_rad = kPi / 2;  // j1's link along +y
  m.dh[3].a_m = 0.03;           // jaws 30 mm ahead of the wrist axis
  // q2 = 0, q3 = 90, q4 = 90 deg: link angles 90, 90, 180, 270 deg
  const JointVector q{0.05, 0.0, kPi / 2, kPi / 2};
  const ToolPose p = forward(m, q);
  EXPECT_NEAR(p.x_m, -0.095, 1e-15);
  EXPECT_NEAR(p.y_m, 0.067 + 0.092 - 0.03, 1e-15);
  EXPECT_NEAR(p.z_m, 0.05 - 0.067, 1e-15);
  EXPECT_NEAR(p.yaw_rad, -kPi / 2, 1e-15);
  const Eigen::Matrix4d t = forward_transform(m, q);
  EXPECT_NEAR(t(0, 3), -0.095, 1e-15);
  EXPECT_NEAR(t(1, 3), 0.129, 1e-15);
  // and back: the joints above are the elbow-up solution
  auto back = inverse(m, p, q);
  ASSERT_TRUE(back) << back.error().message;
  for (int j = 0; j < kNumJoints; ++j) EXPECT_NEAR((*back)[j], q[j], 1e-12) << j;
}

// A yaw of billions of radians is whole turns plus the yaw: inverse() takes the turns off on
// its general path (the hot path's angles stay below 1e9 rad).
TEST(Ik, HugeYawIsWholeTurnsOff) {
  const JointVector q{0.06, 0.3, 0.6, 1.0};
  const ToolPose p = forward(model(), q);
  ToolPose spun = p;
  spun.yaw_rad = 1.9 + 2.0 * kPi * 2e9;  // about 1.26e10 rad: a double keeps 2e-6 rad of it
  auto r = inverse(model(), spun, model().home);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_NEAR((*r)[0], 0.06, 1e-15);
  EXPECT_NEAR((*r)[1], 0.3, 1e-12);
  EXPECT_NEAR((*r)[2], 0.6, 1e-12);
  EXPECT_NEAR((*r)[3], 1.0, 1e-5);
}

// Equal links fold onto the shoulder axis: the elbow at 180 deg, any shoulder angle.
TEST(Ik, EqualLinksFoldOntoTheShoulderAxis) {
  RobotModel m = model();
  m.dh[1].a_m = m.dh[2].a_m = 0.09;
  m.limits[3] = {-kPi, kPi};  // q4 = yaw - q2 - 180 deg
  auto all = inverse_all(m, {0.067, 0.0, -0.02, deg_to_rad(60)}, m.home);
  ASSERT_TRUE(all) << all.error().message;
  const JointVector& q = all->solutions[0];
  EXPECT_NEAR(q[0], -0.02 + 0.067, 1e-15);
  EXPECT_NEAR(q[2], kPi, 1e-7);
  EXPECT_NEAR(wrap_angle(q[1] + q[2] + q[3] - deg_to_rad(60)), 0.0, 1e-12);
}

TEST(JointName, NamesTheFourJointsAndNothingElse) {
  EXPECT_STREQ(joint_name(0), "j1");
  EXPECT_STREQ(joint_name(3), "j4");
  EXPECT_STREQ(joint_name(4), "j?");
  EXPECT_STREQ(joint_name(-1), "j?");
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

// Homing leaves each joint having moved away from its switch: Z and J2 seek upwards (+1), so
// they rest having moved down (-1); J3 seeks downwards and rests having moved up.
TEST(Motor, HomedDirectionsAreAwayFromTheSwitches) {
  EXPECT_EQ(homed_directions(model()), (MotionDirections{-1, -1, +1}));
  RobotModel m = model();
  m.endstops.homing_dir = {-1, +1, +1};
  EXPECT_EQ(homed_directions(m), (MotionDirections{+1, -1, -1}));
}

// A move sets the direction of each stepper joint that moved (more than 1e-9) and leaves the
// others, and the wrist, alone.
TEST(Motor, TrackDirectionsFollowsTheJointsThatMoved) {
  MotionDirections dir = homed_directions(model());  // {-1, -1, +1}
  track_directions(dir, {0.10, 0.5, 0.2, 0.0}, {0.101, 0.5 + 1e-12, 0.1, 1.0});
  EXPECT_EQ(dir, (MotionDirections{+1, -1, -1}));
  track_directions(dir, {0.10, 0.5, 0.2, 0.0}, {0.10, 0.6, 0.2, -1.0});
  EXPECT_EQ(dir, (MotionDirections{+1, +1, -1}));
  MotionDirections unknown{0, 0, 0};
  track_directions(unknown, {0.10, 0.5, 0.2, 0.0}, {0.10, 0.5, 0.2, 0.0});
  EXPECT_EQ(unknown, (MotionDirections{0, 0, 0})) << "no move, still unknown";
}

// A joint that last moved up rests half its dead band below the middle: -dir x backlash / 2.
TEST(Motor, BacklashShiftIsHalfTheDeadBandAgainstTheLastMove) {
  RobotModel m = model();
  m.calibration.backlash = {0.0002, 0.004, 0.006};
  const JointVector s = backlash_shift(m, {+1, -1, 0});
  EXPECT_DOUBLE_EQ(s[0], -0.0001);
  EXPECT_DOUBLE_EQ(s[1], 0.002);
  EXPECT_EQ(s[2], 0.0) << "direction unknown: the middle";
  EXPECT_EQ(s[3], 0.0) << "the wrist has no dead band here";
  EXPECT_EQ(backlash_shift(model(), {1, 1, 1}), (JointVector{})) << "uncalibrated: none";
}

// A calibrated horn offset may put the wrist's joint limit a little past the servo's travel:
// the command stops at the servo's end (up to 5 deg past it); farther is left as it is.
TEST(Motor, CalibratedWristStopsAtTheServosEnd) {
  RobotModel m = model();
  m.calibration.wrist_offset_rad = deg_to_rad(2.0);  // q4 = q4_fw + 2 deg
  EXPECT_EQ(joints_to_motors(m, {0.1, 0, 0, 0.0}).wrist_deg, 0.0) << "-2 deg: at the end";
  EXPECT_NEAR(joints_to_motors(m, {0.1, 0, 0, deg_to_rad(-10)}).wrist_deg, -12.0, 1e-12);
  EXPECT_NEAR(joints_to_motors(m, {0.1, 0, 0, deg_to_rad(90)}).wrist_deg, 88.0, 1e-12);
  m.calibration.wrist_offset_rad = deg_to_rad(-2.0);
  EXPECT_EQ(joints_to_motors(m, {0.1, 0, 0, kPi}).wrist_deg, 180.0) << "182 deg: at the end";
  EXPECT_EQ(joints_to_motors(m, {0.1, 0, 0, deg_to_rad(182)}).wrist_deg, 180.0) << "184 deg";
  EXPECT_NEAR(joints_to_motors(m, {0.1, 0, 0, deg_to_rad(184)}).wrist_deg, 186.0, 1e-12)
      << "6 deg past the end: not the horn's offset";
  // a gain alone: q4 = 1.1 q4_fw, so 198 deg of joint is 180 deg of servo, 199 deg clamps
  m.calibration.wrist_offset_rad = 0.0;
  m.calibration.wrist_gain = 0.1;
  EXPECT_NEAR(joints_to_motors(m, {0.1, 0, 0, deg_to_rad(198)}).wrist_deg, 180.0, 1e-12);
  EXPECT_EQ(joints_to_motors(m, {0.1, 0, 0, deg_to_rad(199)}).wrist_deg, 180.0);
  // uncalibrated, the conversion is the plain one on both sides
  EXPECT_NEAR(joints_to_motors(model(), {0.1, 0, 0, deg_to_rad(-2)}).wrist_deg, -2.0, 1e-12);
  EXPECT_NEAR(joints_to_motors(model(), {0.1, 0, 0, deg_to_rad(182)}).wrist_deg, 182.0, 1e-12);
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
