// Clearance between two arms along their paths (trajectory/clearance.hpp), against an oracle of
// its own: the arms' points from the paper's closed-form planar kinematics (DESIGN.md: x = a1 +
// a2 cos q2 + a3 cos(q2 + q3), ...), their distance by clamped segment parameters and by clouds
// of points, and the motions looked at every 0.1 ms. Random cases with a fixed seed
// (SCARATWIN_TEST_CASES sets how many).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <random>
#include <vector>

#include <fmt/format.h>

#include "arm_oracle.hpp"
#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/trajectory/clearance.hpp"

namespace scaratwin {
namespace {

using test::oracle_arm;
using test::oracle_distance;
using test::P;
using test::two_robots;

// The links as points every 0.5 mm or closer; the least distance between the two clouds.
std::vector<P> cloud(const std::array<P, 4>& arm) {
  std::vector<P> out;
  for (int i = 0; i < 3; ++i) {
    const double len = std::hypot(arm[i + 1][0] - arm[i][0], arm[i + 1][1] - arm[i][1]);
    const int n = std::max(1, static_cast<int>(std::ceil(len / 0.0005)));
    for (int k = 0; k <= n; ++k) {
      const double f = static_cast<double>(k) / n;
      out.push_back({arm[i][0] + f * (arm[i + 1][0] - arm[i][0]),
                     arm[i][1] + f * (arm[i + 1][1] - arm[i][1])});
    }
  }
  return out;
}
double cloud_distance(const Workcell& w, const JointVector& qa, const JointVector& qb) {
  const auto a = cloud(oracle_arm(w.robots[0].base, qa));
  const auto b = cloud(oracle_arm(w.robots[1].base, qb));
  double d2 = INFINITY;
  for (const P& p : a) {
    for (const P& r : b) {
      d2 = std::min(d2, (p[0] - r[0]) * (p[0] - r[0]) + (p[1] - r[1]) * (p[1] - r[1]));
    }
  }
  return std::sqrt(d2);
}

int cases(int fallback) {
  const char* e = std::getenv("SCARATWIN_TEST_CASES");
  return e != nullptr ? std::atoi(e) : fallback;
}

JointVector random_q(std::mt19937& rng) {
  const RobotModel m = paper_robot();
  JointVector q{};
  for (int j = 0; j < kNumJoints; ++j) {
    q[j] = std::uniform_real_distribution<double>(m.limits[j].min, m.limits[j].max)(rng);
  }
  return q;
}

TEST(Clearance, ArmDistanceIsTheClosedFormArmsClosestApproach) {
  const Workcell w = two_robots(300.0, 100.0, 180.0);
  std::mt19937 rng(7);
  for (int i = 0; i < cases(300); ++i) {
    const JointVector qa = random_q(rng), qb = random_q(rng);
    const double got = arm_distance(w, 0, qa, 1, qb);
    EXPECT_NEAR(got, oracle_distance(w, qa, qb), 1e-12) << i;
    // and the links as clouds of points (0.25 mm from any point of their links at most)
    if (i % 10 == 0) {
      const double clouds = cloud_distance(w, qa, qb);
      EXPECT_LE(got, clouds + 1e-12) << i;
      EXPECT_GE(got, clouds - 0.0005 - 1e-12) << i;
    }
  }
}

// Random moves of both arms, each a quintic with a random start: what the check says against
// the motion looked at every 0.1 ms by the oracle.
TEST(Clearance, TheCheckNeverMissesAnApproachAndIsTightToItsStep) {
  const Workcell w = two_robots(300.0, 100.0, 180.0);
  std::mt19937 rng(11);
  ClearanceOptions o;
  o.clearance_m = 0.020;
  o.max_step_m = 0.001;
  int refused = 0, accepted = 0;
  for (int i = 0; i < cases(40); ++i) {
    const JointTrajectory ta = quintic(random_q(rng), random_q(rng), 1.0, 30);
    const JointTrajectory tb = quintic(random_q(rng), random_q(rng), 1.0, 30);
    const double start_b = std::uniform_real_distribution<double>(-0.5, 0.5)(rng);
    auto report = check_clearance(w, {RobotMotion{&ta, 0.0}, RobotMotion{&tb, start_b}}, o);
    ASSERT_TRUE(report.ok()) << report.error().message;
    // the oracle: the same linear pieces between samples, looked at every 0.1 ms
    double least = INFINITY;
    const double t0 = std::min(0.0, start_b), t1 = std::max(1.0, start_b + 1.0);
    for (double t = t0; t <= t1 + 1e-12; t += 1e-4) {
      least = std::min(least, oracle_distance(w, sample_at(ta, t), sample_at(tb, t - start_b)));
    }
    // never looser than the truth, and no tighter than both arms' step
    EXPECT_LE(report->closest.bound_m, least + 1e-9) << i;
    EXPECT_GE(report->closest.bound_m, least - 2 * o.max_step_m - 0.0003) << i;
    if (least < o.clearance_m) {
      EXPECT_TRUE(report->first.has_value())
          << i << ": the arms came " << least * 1e3 << " mm close";
    }
    if (!report->first) {
      EXPECT_GE(least, o.clearance_m) << i;
    }
    (report->first ? refused : accepted)++;
  }
  // both verdicts were met
  EXPECT_GT(refused, 0);
  EXPECT_GT(accepted, 0);
}

// The workcell of config/two_arms.toml's shape: both arms reaching into the gap between them
// meet; one reaching there while the other turns away does not.
TEST(Clearance, ArmsReachingIntoTheSameGapAreRefusedNamingThem) {
  const Workcell w = two_robots(400.0, 200.0, 180.0);
  const RobotModel m = paper_robot();
  // left at q2 = 30 deg (forearm (147, 46) -> (229, 94) mm), right (turned by 180 deg) at
  // q2 = 45 deg (forearm (268, 135) -> (201, 68) mm): the forearms cross near (223, 91) mm
  const JointVector home = m.home;
  JointVector left_reach = home, right_reach = home;
  left_reach[1] = deg_to_rad(30.0);
  right_reach[1] = deg_to_rad(45.0);
  const JointTrajectory la = quintic(home, left_reach, 2.0);
  const JointTrajectory rb = quintic(home, right_reach, 2.0);
  auto report = check_clearance(w, {RobotMotion{&la, 0.0}, RobotMotion{&rb, 0.0}});
  ASSERT_TRUE(report.ok());
  ASSERT_TRUE(report->first.has_value());
  const double least = oracle_distance(w, left_reach, right_reach);
  EXPECT_LT(least, 1e-9);  // they cross
  const Status s = clearance_status(w, *report);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, static_cast<int>(PlanError::kCollision));
  EXPECT_EQ(s.error().message,
            fmt::format("robots 'left' and 'right' would come closer than the clearance of 20.0 "
                        "mm at {:.2f} s of their paths ({:.1f} mm apart there and moving, "
                        "possibly {:.1f} mm before the next look): nothing was sent",
                        report->first->t_s, report->first->distance_m * 1e3,
                        std::max(0.0, report->first->bound_m) * 1e3));
  EXPECT_LT(report->first->bound_m, 0.020);
  EXPECT_GT(report->first->distance_m, report->first->bound_m);

  // the right robot turned the other way instead (q2 = -45 deg): they stay apart (149 mm)
  JointVector right_away = home;
  right_away[1] = deg_to_rad(-45.0);
  const JointTrajectory rb2 = quintic(home, right_away, 2.0);
  auto ok = check_clearance(w, {RobotMotion{&la, 0.0}, RobotMotion{&rb2, 0.0}});
  ASSERT_TRUE(ok.ok());
  EXPECT_FALSE(ok->first.has_value()) << ok->first->t_s;
  EXPECT_TRUE(clearance_status(w, *ok).ok());
  EXPECT_GE(ok->closest.distance_m, 0.020);
}

// A standing robot is a trajectory of one sample; a single look when nobody moves.
TEST(Clearance, StandingRobotsAreOneLook) {
  const Workcell w = two_robots(400.0, 200.0, 180.0);
  JointTrajectory stand;
  stand.samples.push_back(JointSample{0.0, paper_robot().home, {}, {}});
  auto report = check_clearance(w, {RobotMotion{&stand, 0.0}, RobotMotion{&stand, 0.0}});
  ASSERT_TRUE(report.ok());
  EXPECT_EQ(report->looks, 1);
  EXPECT_NEAR(report->closest.distance_m,
              oracle_distance(w, paper_robot().home, paper_robot().home), 1e-12);
}

TEST(Clearance, BadInputIsRefusedNamingIt) {
  const Workcell w = two_robots(400.0, 200.0, 180.0);
  JointTrajectory empty;
  const JointTrajectory t = quintic(paper_robot().home, paper_robot().home, 1.0);
  auto one = check_clearance(w, {RobotMotion{&t, 0.0}});
  ASSERT_FALSE(one.ok());
  EXPECT_EQ(one.error().code, static_cast<int>(PlanError::kBadArgument));
  EXPECT_EQ(one.error().message, "clearance: 1 motions for a workcell of 2 robots (one each)");
  auto none = check_clearance(w, {RobotMotion{&t, 0.0}, RobotMotion{&empty, 0.0}});
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().message,
            "clearance: robot 'right' has no trajectory (a robot that stands still is one "
            "sample)");
  auto nan = check_clearance(w, {RobotMotion{&t, 0.0}, RobotMotion{&t, std::nan("")}});
  ASSERT_FALSE(nan.ok());
  EXPECT_EQ(nan.error().message, "clearance: robot 'right' starts at nan s");
  ClearanceOptions o;
  o.max_step_m = 0.0;
  auto step = check_clearance(w, {RobotMotion{&t, 0.0}, RobotMotion{&t, 0.0}}, o);
  ASSERT_FALSE(step.ok());
  EXPECT_EQ(step.error().code, static_cast<int>(PlanError::kBadArgument));
}

}  // namespace
}  // namespace scaratwin
