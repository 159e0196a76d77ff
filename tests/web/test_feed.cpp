// The browser feed's messages, the page's commands and the link figures, on a real World
// (physics only: no camera needed).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/sim/camera.hpp"
#include "scaratwin/web/feed.hpp"
#include "scaratwin/web/link_monitor.hpp"

namespace scaratwin::web {
namespace {

using nlohmann::json;

std::unique_ptr<sim::World> make_world() {
  auto robot = load_robot_config_or_default("");
  EXPECT_TRUE(robot.ok());
  sim::WorldOptions wo;
  wo.camera = false;
  auto world = sim::World::create(*robot, {}, wo);
  EXPECT_TRUE(world.ok()) << (world ? "" : world.error().message);
  return std::move(*world);
}

TEST(Feed, SceneMessageCarriesTheModelsGeometryCameraAndLimits) {
  auto world = make_world();
  const json j = json::parse(scene_message(world->robot(), world->geometry(), 30.0));
  EXPECT_EQ(j["type"], "scene");
  ASSERT_EQ(j["joints"].size(), 4U);
  EXPECT_EQ(j["joints"][0]["unit"], "mm");
  EXPECT_NEAR(j["joints"][0]["max_display"].get<double>(), 1e3 * world->robot().limits[0].max,
              1e-9);
  EXPECT_NEAR(j["joints"][1]["min_display"].get<double>(),
              world->robot().limits[1].min * 180.0 / std::numbers::pi, 1e-9);
  const sim::SceneGeometry g = world->geometry();
  EXPECT_EQ(j["bodies"].size(), g.bodies.size());
  EXPECT_EQ(j["geoms"].size(), g.geoms.size());
  // every cube body of the pool is there, so the page can show any cube the sim spawns
  int cubes = 0;
  for (const auto& b : j["bodies"]) cubes += b.get<std::string>().rfind("cube_", 0) == 0 ? 1 : 0;
  EXPECT_EQ(cubes,
            3 * world->with_simulation([](sim::Simulation& s) { return s.cubes_per_color(); }));
  // camera axes are orthonormal and the view direction (-z) looks down at the table
  const auto& cam = j["camera"];
  double dot = 0.0;
  for (int i = 0; i < 3; ++i) dot += cam["x"][i].get<double>() * cam["z"][i].get<double>();
  EXPECT_NEAR(dot, 0.0, 1e-4);
  EXPECT_GT(cam["z"][2].get<double>(), 0.5);
  EXPECT_EQ(j["trays"].size(), 3U);
}

TEST(Feed, StateMessageFollowsTheSimulation) {
  auto world = make_world();
  JointVector q{0.08, 0.5, -0.7, 0.3};
  ASSERT_TRUE(world->with_simulation([&](sim::Simulation& s) { return s.set_joints(q); }).ok());
  ASSERT_TRUE(world->with_simulation([](sim::Simulation& s) { return s.step(5); }).ok());
  LinkStatus link;
  link.connected = true;
  link.has_latency = true;
  link.latency_last_s = 0.0021;
  const json j =
      json::parse(state_message(world->robot(), world->snapshot(), link, {true, 2, 1.0, {}}));
  EXPECT_EQ(j["type"], "state");
  EXPECT_NEAR(j["display"][0].get<double>(), 80.0, 1e-3);
  EXPECT_NEAR(j["display"][1].get<double>(), 0.5 * 180.0 / std::numbers::pi, 1e-3);
  EXPECT_EQ(j["out_of_limit"], json({false, false, false, false}));
  EXPECT_EQ(j["twin_mode"], "mirror");
  EXPECT_EQ(j["clients"], 2);
  EXPECT_NEAR(j["link"]["latency_ms"].get<double>(), 2.1, 1e-9);
  EXPECT_TRUE(j.contains("path"));
  EXPECT_EQ(j["bodies"].size(), world->geometry().bodies.size());
  // the tool is where forward kinematics puts it
  const ToolPose fk = forward(world->robot(), q);
  EXPECT_NEAR(j["tool"]["x"].get<double>(), fk.x_m, 1e-4);
  EXPECT_NEAR(j["tool"]["y"].get<double>(), fk.y_m, 1e-4);
}

// A workcell of two robots: the state message has each robot's name, mode, joints and tool (in
// the world frame); a single robot's has no `robots` (the page's panels are robot 0's).
TEST(Feed, AWorkcellsStateCarriesEachRobot) {
  auto alone = make_world();
  EXPECT_FALSE(
      json::parse(state_message(alone->robot(), alone->snapshot(), {}, {})).contains("robots"));
  auto cell = load_workcell_config(std::filesystem::path(SCARATWIN_CONFIG_FILE).parent_path() /
                                   "two_arms.toml");
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  sim::WorldOptions wo;
  wo.camera = false;
  auto world = sim::World::create(*cell, {}, wo);
  ASSERT_TRUE(world.ok()) << world.error().message;
  const JointVector q{0.08, 0.5, -0.7, 0.3};
  ASSERT_TRUE(
      (*world)->with_simulation([&](sim::Simulation& s) { return s.set_joints(q, 1); }).ok());
  const json j = json::parse(state_message((*world)->robot(), (*world)->snapshot(), {}, {}));
  ASSERT_TRUE(j.contains("robots"));
  ASSERT_EQ(j["robots"].size(), 2u);
  EXPECT_EQ(j["robots"][0]["name"], "left");
  EXPECT_EQ(j["robots"][1]["name"], "right");
  EXPECT_EQ(j["robots"][1]["mode"], "mirror");
  EXPECT_NEAR(j["robots"][1]["display"][0].get<double>(), 80.0, 1e-3);
  EXPECT_NEAR(j["robots"][0]["display"][0].get<double>(), 120.0, 1e-3);  // at home
  // robot 1's tool: its forward kinematics in its base, put in the world by its base pose
  const ToolPose fk = forward((*world)->workcell().robots[1].model, q);
  const auto w = base_to_world(cell->robots[1].base, {fk.x_m, fk.y_m, fk.z_m});
  EXPECT_NEAR(j["robots"][1]["tool"]["x"].get<double>(), w[0], 1e-4);
  EXPECT_NEAR(j["robots"][1]["tool"]["y"].get<double>(), w[1], 1e-4);
  EXPECT_NEAR(j["robots"][1]["tool"]["z"].get<double>(), w[2], 1e-4);
  // the top-level fields are robot 0's
  EXPECT_NEAR(j["display"][0].get<double>(), 120.0, 1e-3);
  EXPECT_EQ(j["arm_touches"], 0);
  EXPECT_FALSE(j["robots"][0].contains("link")) << "no link figures given: none shown";

  // each robot's link, as the simulator's monitors give them, in its row
  StateExtras extras;
  extras.robot_links.resize(2);
  extras.robot_links[1].connected = true;
  extras.robot_links[1].frames = 412;
  extras.robot_links[1].lost = 3;
  extras.robot_links[1].has_latency = true;
  extras.robot_links[1].latency_mean_s = 0.00125;
  const json k = json::parse(state_message((*world)->robot(), (*world)->snapshot(), {}, extras));
  EXPECT_EQ(k["robots"][0]["link"]["connected"], false);
  EXPECT_EQ(k["robots"][0]["link"]["frames"], 0);
  EXPECT_FALSE(k["robots"][0]["link"].contains("latency_mean_ms"));
  EXPECT_EQ(k["robots"][1]["link"]["connected"], true);
  EXPECT_EQ(k["robots"][1]["link"]["frames"], 412);
  EXPECT_EQ(k["robots"][1]["link"]["lost"], 3);
  EXPECT_NEAR(k["robots"][1]["link"]["latency_mean_ms"].get<double>(), 1.25, 1e-9);
}

TEST(Feed, OutOfLimitJointIsFlagged) {
  auto world = make_world();
  JointVector q = world->robot().home;
  q[1] = world->robot().limits[1].max + 0.2;
  ASSERT_TRUE(world->with_simulation([&](sim::Simulation& s) { return s.set_joints(q); }).ok());
  const json j = json::parse(state_message(world->robot(), world->snapshot(), {}, {}));
  EXPECT_EQ(j["out_of_limit"], json({false, true, false, false}));
  EXPECT_GE(j["warnings_total"].get<int>(), 1);
  ASSERT_FALSE(j["warnings"].empty());
  EXPECT_EQ(j["warnings"].back()["joint"], 1);
}

TEST(Feed, TwinModeFromTheHubOrTheSimulator) {
  sim::Snapshot s;
  LinkStatus link;
  s.mode = sim::Mode::kMirror;
  EXPECT_EQ(twin_mode(s, link, 1.0), "mirror");
  s.mode = sim::Mode::kSimulate;
  EXPECT_EQ(twin_mode(s, link, 1.0), "control");
  EXPECT_EQ(twin_mode(s, link, 0.0), "prediction");
  link.twin_mode = "mirror";
  EXPECT_EQ(twin_mode(s, link, 0.0), "mirror");
}

TEST(Commands, ParseAcceptsTheDocumentedCommands) {
  auto c = parse_command(R"({"cmd":"spawn","color":"green","x_mm":150,"y_mm":-20.5,"id":7})");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->kind, Command::Kind::kSpawn);
  EXPECT_EQ(c->color, CubeColor::kGreen);
  EXPECT_NEAR(*c->x_m, 0.150, 1e-12);
  EXPECT_NEAR(*c->y_m, -0.0205, 1e-12);
  EXPECT_EQ(*c->id, 7);
  c = parse_command(R"({"cmd":"spawn","color":"red"})");
  ASSERT_TRUE(c.ok());
  EXPECT_FALSE(c->x_m.has_value());
  EXPECT_EQ(parse_command(R"({"cmd":"reset"})")->kind, Command::Kind::kReset);
  EXPECT_EQ(parse_command(R"({"cmd":"shoot"})")->kind, Command::Kind::kShoot);
}

TEST(Commands, ParseRejectsBadInputNamingTheProblem) {
  const struct {
    const char* text;
    const char* says;
  } cases[] = {
      {"not json", "JSON object"},
      {"[1,2]", "JSON object"},
      {R"({"color":"red"})", "missing \"cmd\""},
      {R"({"cmd":"fly"})", "unknown command \"fly\""},
      {R"({"cmd":"spawn"})", "needs \"color\""},
      {R"({"cmd":"spawn","color":"pink"})", "\"pink\""},
      {R"({"cmd":"spawn","color":"red","x_mm":10})", "both x_mm and y_mm"},
      {R"({"cmd":"spawn","color":"red","x_mm":"a","y_mm":1})", "must be numbers"},
      {R"({"cmd":"reset","id":"x"})", "\"id\""},
  };
  for (const auto& c : cases) {
    auto r = parse_command(c.text);
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_EQ(r.error().code, static_cast<int>(WebError::kBadCommand));
    EXPECT_NE(r.error().message.find(c.says), std::string::npos)
        << c.text << " -> " << r.error().message;
  }
}

TEST(Commands, SpawnAtTypedCoordinatesThenResetRemovesEverything) {
  auto world = make_world();
  std::mt19937_64 rng(1);
  auto cmd = parse_command(R"({"cmd":"spawn","color":"blue","x_mm":150,"y_mm":-70,"id":3})");
  ASSERT_TRUE(cmd.ok());
  json r = json::parse(execute_command(*world, *cmd, rng));
  ASSERT_TRUE(r["ok"].get<bool>()) << r.dump();
  EXPECT_EQ(r["id"], 3);
  EXPECT_EQ(r["cube"]["color"], "blue");
  auto cubes = world->snapshot().cubes;
  ASSERT_EQ(cubes.size(), 1U);
  EXPECT_NEAR(cubes[0].pos_m[0], 0.150, 1e-6);
  // the same spot again is occupied: refused with the simulator's message
  r = json::parse(execute_command(*world, *cmd, rng));
  EXPECT_FALSE(r["ok"].get<bool>());
  EXPECT_FALSE(r["error"].get<std::string>().empty());
  r = json::parse(execute_command(*world, *parse_command(R"({"cmd":"reset"})"), rng));
  EXPECT_TRUE(r["ok"].get<bool>());
  EXPECT_TRUE(world->snapshot().cubes.empty());
}

TEST(Commands, RandomSpotsAreFreeReachableVisibleAndOffTheTrays) {
  auto world = make_world();
  const RobotModel& robot = world->robot();
  std::mt19937_64 rng(42);
  const int pool = world->with_simulation([](sim::Simulation& s) { return s.cubes_per_color(); });
  for (int c = 0; c < kNumColors; ++c) {
    for (int i = 0; i < pool; ++i) {
      auto cube = world->with_simulation(
          [&](sim::Simulation& s) { return spawn_at_random(s, CubeColor(c), rng); });
      ASSERT_TRUE(cube.ok()) << cube.error().message;
      ToolPose pose;
      pose.x_m = cube->pos_m[0];
      pose.y_m = cube->pos_m[1];
      pose.z_m = robot.scene.grasp_z_m;
      bool reachable = false;
      for (double yaw : {0.0, 0.5 * std::numbers::pi, std::numbers::pi, -0.5 * std::numbers::pi}) {
        pose.yaw_rad = yaw;
        reachable |= inverse(robot, pose, robot.home).ok();
      }
      EXPECT_TRUE(reachable) << pose.x_m << " " << pose.y_m;
      for (const Tray& t : robot.scene.trays) {
        EXPECT_FALSE(std::abs(pose.x_m - t.x_m) < 0.5 * t.size_m &&
                     std::abs(pose.y_m - t.y_m) < 0.5 * t.size_m);
      }
      const CameraModel& cam = robot.scene.camera;
      EXPECT_TRUE(sim::project(cam, cam.width_px, cam.height_px, cube->pos_m).visible);
    }
  }
  // every pool is used up: the next one is refused, naming the colour
  auto more = world->with_simulation(
      [&](sim::Simulation& s) { return spawn_at_random(s, CubeColor::kRed, rng); });
  ASSERT_FALSE(more.ok());
  EXPECT_NE(more.error().message.find("red"), std::string::npos);
  // no two cubes overlap
  const auto cubes = world->snapshot().cubes;
  for (std::size_t a = 0; a < cubes.size(); ++a) {
    for (std::size_t b = a + 1; b < cubes.size(); ++b) {
      EXPECT_GE(
          std::hypot(cubes[a].pos_m[0] - cubes[b].pos_m[0], cubes[a].pos_m[1] - cubes[b].pos_m[1]),
          robot.scene.cube_size_m);
    }
  }
}

TEST(LinkMonitor, CountsGapsAsLostFramesAndMeasuresLatency) {
  LinkMonitor m(1.0);
  const JointVector q{0.1, 0.2, 0.3, 0.4};
  const std::int64_t t0 = 5'000'000'000;  // beyond 2^32 us: the hub's t_us wraps
  for (int i = 0; i < 10; ++i) {
    const std::int64_t sampled = t0 + i * 10'000;
    m.on_joint_frame(static_cast<std::uint16_t>(65530 + i), static_cast<std::uint32_t>(sampled), q,
                     sampled + 2'000 + i * 100);
  }
  LinkStatus s = m.status(t0 + 100'000);
  EXPECT_EQ(s.frames, 10U);
  EXPECT_EQ(s.lost, 0U);  // the seq wrapped 65535 -> 0 without a gap
  EXPECT_NEAR(s.latency_last_s, 0.0029, 1e-9);
  EXPECT_NEAR(s.latency_mean_s, 0.00245, 1e-9);
  EXPECT_NEAR(s.latency_max_s, 0.0029, 1e-9);
  EXPECT_TRUE(s.has_physical);
  EXPECT_EQ(s.physical, q);
  // a gap of 3
  m.on_joint_frame(7, static_cast<std::uint32_t>(t0 + 200'000), q, t0 + 201'000);
  EXPECT_EQ(m.status(t0 + 201'000).lost, 3U);
  // a new connection starts a new sequence: no loss counted across it
  m.set_connected(true);
  m.on_joint_frame(0, static_cast<std::uint32_t>(t0 + 300'000), q, t0 + 301'000);
  s = m.status(t0 + 301'000);
  EXPECT_EQ(s.lost, 3U);
  EXPECT_TRUE(s.connected);
  // so does a new stream on the same connection (a hub's hello, a mode switch): the reports
  // the hub did not forward meanwhile are no loss
  m.on_joint_frame(1, static_cast<std::uint32_t>(t0 + 310'000), q, t0 + 311'000);
  m.restart_sequence();
  m.on_joint_frame(400, static_cast<std::uint32_t>(t0 + 320'000), q, t0 + 321'000);
  EXPECT_EQ(m.status(t0 + 321'000).lost, 3U);
  m.on_joint_frame(402, static_cast<std::uint32_t>(t0 + 330'000), q, t0 + 331'000);
  EXPECT_EQ(m.status(t0 + 331'000).lost, 4U) << "a gap within the new stream is a loss";
  // the window forgets old frames
  s = m.status(t0 + 10'000'000);
  EXPECT_EQ(s.frame_rate_hz, 0.0);
  EXPECT_EQ(s.latency_mean_s, 0.0);
  // the mode a hub announced goes when that hub leaves
  m.set_twin_mode("control");
  EXPECT_EQ(m.status(t0).twin_mode, "control");
  m.set_connected(false);
  EXPECT_EQ(m.status(t0).twin_mode, "");
}

}  // namespace
}  // namespace scaratwin::web
