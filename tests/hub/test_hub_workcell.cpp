// Several hubs in one process, one per robot of a workcell (issue 13), each through its robot
// interface (a fake robot here) and one real simulator of the workcell (config/two_arms.toml).
#include <chrono>
#include <cmath>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "hub_robots_support.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {
namespace {

using namespace std::chrono_literals;
using namespace robots_test;

// issue 13: one process holds a hub per robot of a workcell, each with its robot's interface
// (a fake here) and its own simulator link naming its robot; both drive their arms of one
// simulator at once, and each arm of the simulator ends where its own robot's counts put it
// (J2: 945 steps per rad, as above). A third hub for a robot that is driven is refused.
TEST(HubWorkcell, TwoHubsDriveTheTwoArmsOfOneSimulatorAtOnce) {
  const fs::path dir = fresh_dir("cell");
  auto sim = ChildProcess::start(
      kBin / "scaratwin-sim",
      {"--workcell", kWorkcell.string(), "--port", "0", "--http-port", "0", "--no-camera"},
      dir / "sim.log");
  ASSERT_TRUE(sim) << sim.error().message;
  auto port = test::simulator_port(**sim);
  ASSERT_TRUE(port) << port.error().message;
  auto cell = load_workcell_config(kWorkcell);
  ASSERT_TRUE(cell.ok()) << cell.error().message;

  std::vector<std::shared_ptr<FakeRobot>> fakes;
  std::vector<std::unique_ptr<Hub>> hubs;
  for (int i = 0; i < 2; ++i) {
    auto f = FakeRobot::start(paper_model(), {});
    ASSERT_TRUE(f) << f.error().message;
    fakes.emplace_back(std::move(*f));
    HubOptions o;
    o.sim_port = *port;
    o.sim_robot = i;
    o.base = cell->robots[static_cast<std::size_t>(i)].base;
    auto hub = Hub::connect(scene_in_base(*cell, i), std::make_unique<FakeInterface>(fakes.back()),
                            o, nullptr);
    ASSERT_TRUE(hub) << "robot " << i << ": " << hub.error().message;
    hubs.push_back(std::move(*hub));
  }
  // a third hub for the right arm: refused before its robot is told anything but hello
  auto third_robot = FakeRobot::start(paper_model(), {});
  ASSERT_TRUE(third_robot);
  std::shared_ptr<FakeRobot> third_fake = std::move(*third_robot);
  HubOptions o3;
  o3.sim_port = *port;
  o3.sim_robot = 1;
  auto third = Hub::connect(scene_in_base(*cell, 1), std::make_unique<FakeInterface>(third_fake),
                            o3, nullptr);
  ASSERT_FALSE(third.ok());
  EXPECT_NE(third.error().message.find("another client controls it"), std::string::npos)
      << third.error().message;
  EXPECT_EQ(third_fake->moves_started(), 0);

  // both home and turn their shoulders at once: left +0.4 rad, right -0.3 rad
  const double turn[2] = {0.4, -0.3};
  std::vector<std::future<Status>> runs;
  for (int i = 0; i < 2; ++i) {
    runs.push_back(std::async(std::launch::async, [&hubs, &turn, i]() -> Status {
      Hub& hub = *hubs[static_cast<std::size_t>(i)];
      hub.set_mirror(true);
      if (Status s = hub.home(10.0); !s) return s;
      const JointVector q0 = hub.physical().q;
      JointVector q1 = q0;
      q1[1] += turn[i];
      auto plan = plan_quintic(hub.model(), q0, q1);
      if (!plan) return plan.error();
      auto r = hub.run_trajectory(*plan, 20.0);
      if (!r) return r.error();
      return Ok{};
    }));
  }
  for (int i = 0; i < 2; ++i) {
    const Status s = runs[static_cast<std::size_t>(i)].get();
    ASSERT_TRUE(s) << "robot " << i << ": " << s.error().message;
  }
  // J2 counts: round(0.4 * 945) = 378 and round(-0.3 * 945) = -284 steps from home
  const double want[2] = {378.0 / 945.0, -284.0 / 945.0};
  for (int i = 0; i < 2; ++i) {
    Hub& hub = *hubs[static_cast<std::size_t>(i)];
    ASSERT_TRUE(hub.fresh_physical(2.0));
    std::this_thread::sleep_for(200ms);  // the last report mirrored
    auto st = hub.sim_state();
    ASSERT_TRUE(st) << st.error().message;
    EXPECT_EQ(st->robot, i);
    EXPECT_NEAR(st->q[1], want[i], 2e-3) << "robot " << i << "'s arm in the simulator";
    EXPECT_NEAR(st->q[0], 0.12, 1e-4) << "robot " << i << " at d1 120 mm";
    EXPECT_EQ(hub.mirror_counters().lost, 0u) << "robot " << i;
  }

  // Objects in each robot's own base frame: the right robot (config/two_arms.toml: base at
  // (400, 200) mm, turned 180 deg) puts a cube 150 mm ahead of it and 100 mm to its right,
  // (150, -100) mm in its frame, which is (400 - 150, 200 + 100) = (250, 300) mm in the world,
  // robot 0's frame; each hub reads it back in its own frame, the cube's yaw turned with it.
  ASSERT_TRUE(hubs[1]->sim_mode(protocol::SimMode::kSimulate));
  auto id = hubs[1]->spawn_cube(CubeColor::kBlue, 0.150, -0.100);
  ASSERT_TRUE(id) << id.error().message;
  const auto cube_of = [&](Hub& hub) -> protocol::ObjectPose {
    auto objs = hub.objects();
    EXPECT_TRUE(objs) << objs.error().message;
    for (const protocol::ObjectPose& o : objs ? *objs : std::vector<protocol::ObjectPose>{}) {
      if (o.id == *id) return o;
    }
    ADD_FAILURE() << "cube " << *id << " not in the scene";
    return {};
  };
  // The two hubs' reads are two requests, a moment apart: compare them only once the cube
  // rests, read from the left hub before and after the right hub's read with the same pose
  // (the wire carries micrometres), so that both describe one state of the table.
  protocol::ObjectPose in_world;
  protocol::ObjectPose in_right;
  const auto settled = [](const protocol::ObjectPose& a, const protocol::ObjectPose& b) {
    return a.x_m == b.x_m && a.y_m == b.y_m && a.z_m == b.z_m && a.yaw_rad == b.yaw_rad;
  };
  bool at_rest = false;
  for (const auto until = std::chrono::steady_clock::now() + 10s;
       !at_rest && std::chrono::steady_clock::now() < until;) {
    std::this_thread::sleep_for(100ms);
    in_world = cube_of(*hubs[0]);
    in_right = cube_of(*hubs[1]);
    at_rest = settled(in_world, cube_of(*hubs[0]));
  }
  ASSERT_TRUE(at_rest) << "the cube did not come to rest within 10 s";
  EXPECT_NEAR(in_world.x_m, 0.250, 1e-3);
  EXPECT_NEAR(in_world.y_m, 0.300, 1e-3);
  EXPECT_NEAR(in_right.x_m, 0.150, 1e-3);
  EXPECT_NEAR(in_right.y_m, -0.100, 1e-3);
  EXPECT_NEAR(in_right.z_m, in_world.z_m, 1e-9) << "both bases stand on the floor";
  EXPECT_NEAR(std::abs(wrap_angle(in_right.yaw_rad - in_world.yaw_rad)), M_PI, 1e-6);
  // a second cube on the first one's spot is refused naming the spot in both frames, and the
  // shared scene is not the right robot's to reset: nothing changes
  auto again = hubs[1]->spawn_cube(CubeColor::kRed, 0.150, -0.100);
  ASSERT_FALSE(again);
  EXPECT_NE(again.error().message.find(
                "the simulator refused a cube at (0.1500, -0.1000) m in robot 1's base frame, "
                "(0.2500, 0.3000) m in the world: off its table, or closer than a cube's "
                "diagonal to another cube"),
            std::string::npos)
      << again.error().message;
  const Status reset = hubs[1]->reset_scene();
  ASSERT_FALSE(reset);
  EXPECT_NE(reset.error().message.find("only the hub of its first robot (0) resets it; this hub "
                                       "drives robot 1"),
            std::string::npos)
      << reset.error().message;
  auto left = hubs[0]->objects();
  ASSERT_TRUE(left);
  EXPECT_EQ(left->size(), 1u);
}

}  // namespace
}  // namespace scaratwin
