// Scene operations, the two motion modes, the gripper and determinism.
#include <cmath>

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/sim/simulation.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin::sim {
namespace {

RobotModel robot() {
  auto m = load_robot_config(SCARATWIN_CONFIG_FILE);
  return m.ok() ? *m : paper_robot();
}

std::unique_ptr<Simulation> make_sim() {
  auto s = Simulation::create(robot());
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  return std::move(*s);
}

// A pick-and-place from the current joints to a point of the tray; tries wrist headings and
// points of the tray (its centre first) until every pose is reachable within the limits.
Result<JointTrajectory> pick_place(const Simulation& sim, double x, double y, const Tray& tray) {
  const RobotModel& r = sim.robot();
  const double room = 0.5 * (tray.size_m - r.scene.cube_size_m) - 0.004;
  Error last{};
  for (double dx : {0.0, room, -room}) {
    for (double dy : {0.0, -room, room}) {
      for (int k = 0; k < 24; ++k) {
        PickPlaceRequest req;
        const double yaw = deg_to_rad(-180.0 + 15.0 * k);
        req.pick = {x, y, r.scene.grasp_z_m, yaw};
        req.place = {tray.x_m + dx, tray.y_m + dy, r.scene.grasp_z_m + 0.004, yaw};
        req.approach_height_m = r.scene.approach_height_m;
        auto t = plan_pick_place(r, sim.joints(), req);
        if (t) return t;
        last = t.error();
      }
    }
  }
  return last;
}

// Joints that put the tool at (x, y, z) with some wrist heading inside the limits.
Result<JointVector> reach(const Simulation& sim, double x, double y, double z) {
  Error last{};
  for (int k = 0; k < 24; ++k) {
    auto q = inverse(sim.robot(), {x, y, z, deg_to_rad(-180.0 + 15.0 * k)}, sim.joints());
    if (q) return q;
    last = q.error();
  }
  return last;
}

TEST(SimScene, SpawnedCubeRestsOnTheTable) {
  auto sim = make_sim();
  auto c = sim->spawn_cube(CubeColor::kGreen, 0.15, 0.05, 0.3);
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(sim->step(500).ok());
  auto now = sim->cube(c->id);
  ASSERT_TRUE(now.ok());
  const RobotModel r = robot();
  EXPECT_NEAR(now->pos_m[0], 0.15, 1e-3);
  EXPECT_NEAR(now->pos_m[1], 0.05, 1e-3);
  EXPECT_NEAR(now->pos_m[2], r.scene.table_z_m + r.scene.cube_size_m / 2, 1e-3);
  EXPECT_EQ(now->color, CubeColor::kGreen);
  EXPECT_FALSE(now->held);
}

TEST(SimScene, SeveralPerColourUntilThePoolIsEmptyThenResetRemovesAll) {
  auto sim = make_sim();
  const int n = sim->cubes_per_color();
  for (int i = 0; i < n; ++i) {
    auto c = sim->spawn_cube(CubeColor::kRed, 0.05 + 0.04 * i, 0.12);
    ASSERT_TRUE(c.ok()) << c.error().message;
  }
  auto blue = sim->spawn_cube(CubeColor::kBlue, 0.2, 0.1);
  ASSERT_TRUE(blue.ok());
  auto extra = sim->spawn_cube(CubeColor::kRed, 0.0, 0.2);
  ASSERT_FALSE(extra.ok());
  EXPECT_EQ(extra.error().code, static_cast<int>(SimError::kPoolExhausted));
  EXPECT_EQ(sim->cubes().size(), static_cast<std::size_t>(n + 1));
  ASSERT_TRUE(sim->step(100).ok());
  sim->reset_scene();
  EXPECT_TRUE(sim->cubes().empty());
  ASSERT_TRUE(sim->step(100).ok());
  EXPECT_TRUE(sim->cubes().empty());
  // the pool is free again
  EXPECT_TRUE(sim->spawn_cube(CubeColor::kRed, 0.1, 0.1).ok());
}

TEST(SimScene, BadSpawnLeavesTheSceneUntouched) {
  auto sim = make_sim();
  ASSERT_TRUE(sim->spawn_cube(CubeColor::kBlue, 0.12, 0.0).ok());
  ASSERT_TRUE(sim->step(50).ok());
  const auto before = sim->cubes();
  const std::vector<double> qpos(sim->data()->qpos, sim->data()->qpos + sim->model()->nq);
  for (auto [x, y] : {std::pair<double, double>{NAN, 0.0}, std::pair<double, double>{0.1, INFINITY},
                      std::pair{5.0, 0.0}, std::pair{0.125, 0.005}}) {
    auto c = sim->spawn_cube(CubeColor::kRed, x, y);
    EXPECT_FALSE(c.ok()) << x << " " << y;
  }
  EXPECT_FALSE(sim->spawn_cube(static_cast<CubeColor>(7), 0.1, 0.1).ok());
  const std::vector<double> after(sim->data()->qpos, sim->data()->qpos + sim->model()->nq);
  EXPECT_EQ(qpos, after);
  EXPECT_EQ(sim->cubes().size(), before.size());
  auto off = sim->spawn_cube(CubeColor::kRed, 5.0, 0.0);
  ASSERT_FALSE(off.ok());
  EXPECT_NE(off.error().message.find("off the table"), std::string::npos) << off.error().message;
}

TEST(SimScene, MirrorAppliesJointsAndWarnsOutsideLimits) {
  auto sim = make_sim();
  const JointVector q{0.08, 0.4, -0.6, 1.0};
  auto w = sim->set_joints(q);
  ASSERT_TRUE(w.ok());
  EXPECT_TRUE(w->empty());
  ASSERT_TRUE(sim->step(100).ok());
  for (int j = 0; j < kNumJoints; ++j) EXPECT_DOUBLE_EQ(sim->joints()[j], q[j]);
  auto bad = sim->set_joints({0.08, deg_to_rad(130.0), 0.0, 0.5});
  ASSERT_TRUE(bad.ok());
  ASSERT_EQ(bad->size(), 1u);
  EXPECT_EQ((*bad)[0].joint, 1);
  EXPECT_EQ(sim->warnings_total(), 1u);
  EXPECT_FALSE(sim->set_joints({NAN, 0, 0, 0}).ok());
  EXPECT_NEAR(sim->joints()[1], deg_to_rad(130.0), 1e-12);  // a NaN changed nothing
}

TEST(SimScene, GraspingNothingIsReportedAndAGraspHoldsTheCube) {
  auto sim = make_sim();
  const RobotModel r = robot();
  auto nothing = sim->grip();
  EXPECT_FALSE(nothing.holding);
  sim->release();
  auto c = sim->spawn_cube(CubeColor::kRed, 0.16, 0.04);
  ASSERT_TRUE(c.ok());
  ASSERT_TRUE(sim->step(200).ok());
  auto q = reach(*sim, 0.16, 0.04, r.scene.grasp_z_m);
  ASSERT_TRUE(q.ok()) << q.error().message;
  ASSERT_TRUE(sim->set_joints(*q).ok());
  auto g = sim->grip();
  ASSERT_TRUE(g.holding);
  EXPECT_EQ(g.cube_id, c->id);
  const auto start = sim->cube(c->id)->pos_m;
  ASSERT_TRUE(sim->step(250).ok());
  const auto held = sim->cube(c->id)->pos_m;
  EXPECT_LT(std::hypot(held[0] - start[0], held[1] - start[1], held[2] - start[2]), 5e-4)
      << "the weld moved the cube";
  // lift: the cube follows the tool
  JointVector up = *q;
  up[0] += 0.05;
  for (int i = 0; i < 50; ++i) {
    JointVector s = *q;
    s[0] += 0.05 * (i + 1) / 50.0;
    ASSERT_TRUE(sim->set_joints(s).ok());
    ASSERT_TRUE(sim->step(10).ok());
  }
  ASSERT_TRUE(sim->step(100).ok());
  const auto lifted = sim->cube(c->id)->pos_m;
  const auto tool = sim->tool_site_pos();
  EXPECT_LT(std::hypot(lifted[0] - tool[0], lifted[1] - tool[1], lifted[2] - tool[2]), 1e-3);
  EXPECT_GT(lifted[2], start[2] + 0.045);
  // release: it falls back onto the table
  sim->release();
  ASSERT_TRUE(sim->step(500).ok());
  const auto fallen = sim->cube(c->id)->pos_m;
  EXPECT_NEAR(fallen[2], r.scene.table_z_m + r.scene.cube_size_m / 2, 1.5e-3);
}

TEST(SimScene, ActuatedPickAndPlacePutsEachColourInItsTray) {
  auto sim = make_sim();
  const RobotModel r = robot();
  sim->set_mode(Mode::kSimulate);
  const double spots[kNumColors][2] = {{0.17, 0.06}, {0.12, 0.11}, {0.2, 0.0}};
  int ids[kNumColors];
  for (int c = 0; c < kNumColors; ++c) {
    auto cube = sim->spawn_cube(CubeColor(c), spots[c][0], spots[c][1]);
    ASSERT_TRUE(cube.ok()) << cube.error().message;
    ids[c] = cube->id;
  }
  ASSERT_TRUE(sim->step(100).ok());
  for (int c = 0; c < kNumColors; ++c) {
    const Tray& tray = r.scene.trays[c];
    auto pos = sim->cube(ids[c])->pos_m;
    auto t = pick_place(*sim, pos[0], pos[1], tray);
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_TRUE(sim->follow(*t).ok());
    ASSERT_TRUE(sim->step_until(sim->time_s() + t->duration_s() + 0.5).ok());
    EXPECT_FALSE(sim->trajectory_active());
    const auto end = sim->cube(ids[c])->pos_m;
    EXPECT_LT(std::abs(end[0] - tray.x_m), tray.size_m / 2 - r.scene.cube_size_m / 2 + 1e-3)
        << color_name(CubeColor(c));
    EXPECT_LT(std::abs(end[1] - tray.y_m), tray.size_m / 2 - r.scene.cube_size_m / 2 + 1e-3)
        << color_name(CubeColor(c));
    EXPECT_NEAR(end[2], r.scene.table_z_m + 0.002 + r.scene.cube_size_m / 2, 2e-3)
        << color_name(CubeColor(c));
    EXPECT_FALSE(sim->cube(ids[c])->held);
  }
}

TEST(SimScene, SameInputsGiveTheSameResult) {
  const auto run = [] {
    auto sim = make_sim();
    EXPECT_TRUE(sim->spawn_cube(CubeColor::kRed, 0.15, 0.02, 0.2).ok());
    EXPECT_TRUE(sim->spawn_cube(CubeColor::kBlue, 0.17, 0.05, 0.9).ok());
    sim->set_mode(Mode::kSimulate);
    EXPECT_TRUE(sim->hold({0.05, 0.3, -0.5, 0.4}).ok());
    EXPECT_TRUE(sim->step(700).ok());
    return std::vector<double>(sim->data()->qpos, sim->data()->qpos + sim->model()->nq);
  };
  EXPECT_EQ(run(), run());
}

TEST(SimScene, StreamedTargetsGiveTheSameRunWhateverTheStepping) {
  // the same timed targets and a grip, stepped in different chunks, end bit-identical
  const auto run = [](int chunk) {
    auto sim = make_sim();
    EXPECT_TRUE(sim->spawn_cube(CubeColor::kGreen, 0.2, 0.05).ok());
    sim->set_mode(Mode::kSimulate);
    for (int i = 0; i <= 100; ++i) {
      const double u = i / 100.0;
      EXPECT_TRUE(
          sim->stream_target(10.0 + 0.02 * i, {0.12 - 0.05 * u, 0.3 * u, -0.4 * u, 0.5}).ok());
      if (i == 50) sim->queue_gripper(GripperAction::kGrip);
      while (sim->time_s() + sim->timestep_s() <= sim->stream_horizon_s() + 1e-9) {
        const int n =
            static_cast<int>((sim->stream_horizon_s() - sim->time_s()) / sim->timestep_s() + 1e-9);
        EXPECT_TRUE(sim->step(std::min(n, chunk)).ok());
      }
    }
    EXPECT_TRUE(sim->stream_open());
    EXPECT_TRUE(sim->gripper_closed());
    EXPECT_NEAR(sim->time_s(), 2.0, 1e-9);
    EXPECT_FALSE(sim->stream_target(10.0, {0.1, 0, 0, 0}).ok());  // not after the last one
    return std::vector<double>(sim->data()->qpos, sim->data()->qpos + sim->model()->nq);
  };
  const auto a = run(1);
  EXPECT_EQ(a, run(7));
  EXPECT_NEAR(a[0], 0.07, 2e-3);  // j1 reached the last target
}

TEST(SimScene, CloneContinuesBitExactly) {
  auto sim = make_sim();
  ASSERT_TRUE(sim->spawn_cube(CubeColor::kGreen, 0.15, 0.02).ok());
  sim->set_mode(Mode::kSimulate);
  ASSERT_TRUE(sim->hold({0.05, 0.3, -0.5, 0.4}).ok());
  ASSERT_TRUE(sim->step(100).ok());
  auto copy = sim->clone();
  ASSERT_TRUE(copy.ok());
  ASSERT_TRUE(sim->step(300).ok());
  ASSERT_TRUE((*copy)->step(300).ok());
  const mjData* a = sim->data();
  const mjData* b = (*copy)->data();
  for (int i = 0; i < sim->model()->nq; ++i) EXPECT_EQ(a->qpos[i], b->qpos[i]) << i;
}

}  // namespace
}  // namespace scaratwin::sim
