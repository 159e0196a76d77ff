// The generated MuJoCo model against the DH kinematics, and MuJoCo errors as our errors.
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "mj_guard.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/sim/simulation.hpp"

namespace scaratwin::sim {
namespace {

RobotModel config_robot() {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  EXPECT_TRUE(m.ok());
  return m.ok() ? *m : paper_robot();
}

void expect_site_matches_dh(const RobotModel& robot, int count, unsigned seed) {
  auto sim = Simulation::create(robot);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  std::mt19937_64 rng(seed);
  double worst_m = 0.0, worst_yaw = 0.0;
  for (int i = 0; i < count; ++i) {
    JointVector q{};
    for (int j = 0; j < kNumJoints; ++j) {
      // a margin beyond the limits: the model must agree everywhere
      const double lo = robot.limits[j].min, hi = robot.limits[j].max, span = hi - lo;
      q[j] = std::uniform_real_distribution<double>(lo - 0.1 * span, hi + 0.1 * span)(rng);
    }
    ASSERT_TRUE((*sim)->set_joints(q).ok());
    const Eigen::Matrix4d x_bt = forward_transform(robot, q);
    const ToolPose site = (*sim)->tool_pose();
    const ToolPose dh = forward(robot, q);
    worst_m = std::max({worst_m, std::abs(site.x_m - x_bt(0, 3)), std::abs(site.y_m - x_bt(1, 3)),
                        std::abs(site.z_m - x_bt(2, 3))});
    worst_yaw = std::max(worst_yaw, std::abs(wrap_angle(site.yaw_rad - dh.yaw_rad)));
    const double* r =
        (*sim)->data()->site_xmat + 9 * mj_name2id((*sim)->model(), mjOBJ_SITE, kToolSite);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) ASSERT_NEAR(r[3 * a + b], x_bt(a, b), 1e-9) << i;
    }
    // both markers where marker_position() and flag_marker_position() say
    const std::array<double, 3> want[2] = {marker_position(robot, q),
                                           flag_marker_position(robot, q)};
    const char* geoms[2] = {kMarkerGeom, kFlagMarkerGeom};
    for (int k = 0; k < 2; ++k) {
      const int id = mj_name2id((*sim)->model(), mjOBJ_GEOM, geoms[k]);
      ASSERT_GE(id, 0) << geoms[k];
      const double* p = (*sim)->data()->geom_xpos + 3 * id;
      for (int a = 0; a < 3; ++a) ASSERT_NEAR(p[a], want[k][a], 1e-9) << geoms[k] << " " << i;
    }
  }
  EXPECT_LT(worst_m, 1e-9);
  EXPECT_LT(worst_yaw, 1e-9);
}

TEST(SimModel, ToolSiteMatchesDhForwardKinematics) {
  expect_site_matches_dh(config_robot(), 2000, 7);
}

TEST(SimModel, ToolSiteMatchesDhWithOffsets) {
  // a description with joint offsets and a different geometry still agrees
  RobotModel robot = paper_robot();
  robot.dh[0].theta_rad = 0.3;
  robot.dh[0].d_m = 0.01;
  robot.dh[1].theta_rad = -0.2;
  robot.dh[2].theta_rad = 0.5;
  robot.dh[3].theta_rad = 0.25;
  robot.dh[1].a_m = 0.15;
  robot.dh[3].a_m = 0.01;
  expect_site_matches_dh(robot, 500, 11);
}

TEST(SimModel, NamesTheJointsSiteAndCamera) {
  auto sim = Simulation::create(paper_robot());
  ASSERT_TRUE(sim.ok());
  const mjModel* m = (*sim)->model();
  EXPECT_EQ(m->jnt_type[mj_name2id(m, mjOBJ_JOINT, "j1")], mjJNT_SLIDE);
  for (const char* j : {"j2", "j3", "j4"}) {
    EXPECT_EQ(m->jnt_type[mj_name2id(m, mjOBJ_JOINT, j)], mjJNT_HINGE) << j;
  }
  EXPECT_GE(mj_name2id(m, mjOBJ_SITE, "tool"), 0);
  EXPECT_GE(mj_name2id(m, mjOBJ_CAMERA, "overhead"), 0);
  for (const char* t : {"tray_red", "tray_green", "tray_blue"}) {
    EXPECT_GE(mj_name2id(m, mjOBJ_BODY, t), 0) << t;
  }
}

TEST(SimModel, RejectsBadOptionsNamingTheValue) {
  MjcfOptions o;
  o.cubes_per_color = 0;
  auto x = make_mjcf(paper_robot(), o);
  ASSERT_FALSE(x.ok());
  EXPECT_NE(x.error().message.find("cubes_per_color = 0"), std::string::npos);
}

// arm_half_width_m against the compiled model: at random poses, every corner and rim point
// of the swinging parts' geoms (the links, the wrist and its fingers) lies within that
// distance of the arm's centre line (workcell.hpp's base -> shoulder -> elbow -> wrist ->
// tool polyline) seen from above, and some point reaches it: with the paper's 20 mm cube the
// marker flag (25 mm out, 5 mm radius: 30 mm); with a 40 mm cube the palm's corner
// (hypot(0.5 * 41 + 16 + 8, 0.6 * 32) = 48.47 mm).
void expect_half_width(const RobotModel& robot, double want_m) {
  const double w = arm_half_width_m(robot);
  EXPECT_NEAR(w, want_m, 1e-5);
  auto sim = Simulation::create(robot);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  const mjModel* m = (*sim)->model();
  const mjData* d = (*sim)->data();
  std::vector<bool> swinging(static_cast<std::size_t>(m->nbody), false);
  for (const char* b : {"link1", "link2", kGripperBody, "finger_l_body", "finger_r_body"}) {
    const int id = mj_name2id(m, mjOBJ_BODY, b);
    ASSERT_GE(id, 0) << b;
    swinging[static_cast<std::size_t>(id)] = true;
  }
  const Workcell cell = single_robot_workcell(robot);
  std::mt19937_64 rng(7);
  double reach = 0.0;
  for (int i = 0; i < 50; ++i) {
    JointVector q{};
    for (int j = 0; j < kNumJoints; ++j) {
      q[j] = std::uniform_real_distribution<double>(robot.limits[j].min, robot.limits[j].max)(rng);
    }
    ASSERT_TRUE((*sim)->set_joints(q).ok());
    const auto line = arm_points(cell, 0, q);
    for (int g = 0; g < m->ngeom; ++g) {
      if (!swinging[static_cast<std::size_t>(m->geom_bodyid[g])]) continue;
      const double* c = d->geom_xpos + 3 * g;
      const double* r = d->geom_xmat + 9 * g;  // the geom's axes in W, row-major
      const double* sz = m->geom_size + 3 * g;
      // the geom's extreme points in its own frame
      std::vector<std::array<double, 3>> local;
      if (m->geom_type[g] == mjGEOM_BOX) {
        for (int k = 0; k < 8; ++k) {
          local.push_back(
              {(k & 1 ? 1 : -1) * sz[0], (k & 2 ? 1 : -1) * sz[1], (k & 4 ? 1 : -1) * sz[2]});
        }
      } else {  // cylinder or capsule along its z axis: rims at both ends (capsule: the caps)
        const double h = sz[1] + (m->geom_type[g] == mjGEOM_CAPSULE ? sz[0] : 0.0);
        for (int k = 0; k < 64; ++k) {
          const double a = 2 * M_PI * k / 64;
          for (double z : {-h, h, -sz[1], sz[1]}) {
            local.push_back({sz[0] * std::cos(a), sz[0] * std::sin(a), z});
          }
        }
      }
      for (const auto& p : local) {
        std::array<double, 3> x{};
        for (int a = 0; a < 3; ++a) {
          x[a] = c[a] + r[3 * a] * p[0] + r[3 * a + 1] * p[1] + r[3 * a + 2] * p[2];
        }
        double off = INFINITY;
        for (std::size_t k = 0; k + 1 < line.size(); ++k) {
          off = std::min(off, distance_to_segment_xy(x, line[k], line[k + 1]));
        }
        reach = std::max(reach, off);
      }
    }
  }
  EXPECT_LE(reach, w + 1e-9);
  EXPECT_GT(reach, w - 2e-4) << "some part reaches the half width";
}

TEST(SimModel, ArmHalfWidthIsTheFarthestSwingingPartFromTheCentreLine) {
  RobotModel robot = config_robot();
  ASSERT_NEAR(robot.scene.cube_size_m, 0.020, 1e-12);
  expect_half_width(robot, 0.030);
  robot.scene.cube_size_m = 0.040;
  expect_half_width(robot, std::hypot(0.5 * 0.041 + 0.016 + 0.008, 0.6 * 0.032));
}

TEST(SimModel, UrdfHasTheFourJoints) {
  auto u = make_urdf(paper_robot());
  ASSERT_TRUE(u.ok());
  for (const char* j : {"name=\"j1\" type=\"prismatic\"", "name=\"j2\" type=\"revolute\"",
                        "name=\"j3\" type=\"revolute\"", "name=\"j4\" type=\"revolute\""}) {
    EXPECT_NE(u->find(j), std::string::npos) << j;
  }
}

TEST(SimModel, MujocoErrorsBecomeErrorsNotExits) {
  auto sim = Simulation::create(paper_robot());
  ASSERT_TRUE(sim.ok());
  // a stack request far beyond the arena makes MuJoCo call mju_error, which would exit
  struct Overflow {
    mjData* d;
    void operator()() { mj_stackAlloc(d, 2'000'000'000); }
  } overflow{(*sim)->mutable_data()};
  Status st = detail::mj_guarded(error_code(SimError::kMujoco), "test", overflow);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, error_code(SimError::kMujoco));
  EXPECT_NE(st.error().message.find("Stack overflow"), std::string::npos) << st.error().message;
  // and the simulation still works afterwards
  (*sim)->mutable_data()->pstack = 0;
  EXPECT_TRUE((*sim)->step(10).ok());
  // nested guards unwind to the innermost one
  struct Inner {
    Status result = Ok{};
    void operator()() {
      struct Boom {
        void operator()() { mju_error("boom"); }
      } boom;
      result = detail::mj_guarded(1, "inner", boom);
    }
  } inner;
  EXPECT_TRUE(detail::mj_guarded(2, "outer", inner).ok());
  ASSERT_FALSE(inner.result.ok());
  EXPECT_EQ(inner.result.error().message, "inner: MuJoCo error: boom");
}

}  // namespace
}  // namespace scaratwin::sim
