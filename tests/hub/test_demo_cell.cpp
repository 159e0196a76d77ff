// End to end, as a user runs it: `scaratwin demo --robots 2`, two robots of a workcell on one
// table (issue 13), each our firmware in its own AVR emulator with a hub of its own, mirrored
// into one simulator; and the refusals of a robot count the workcell does not have.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "hub_test_support.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const fs::path kBin = SCARATWIN_BIN_DIR;

using test::fresh_dir;
using test::slurp;

// Two emulated robots on one table (config/two_arms_trays.toml) sort the cubes together, each
// with its own hub, mirrored into one simulator. Both arms get work (the tasks are split
// by reach), every cube ends in its tray, no frame is lost, and the simulator saw no touch.
// The independent oracle for "the arms stayed apart": each robot's recorded physical joints
// (its own database, from its own firmware's reports), put on one clock by the runs' start
// times, never bring the arms' centre lines closer than 50 mm seen from above (the paper's
// link lengths and the bases of the workcell file, kinematics/workcell.hpp).
TEST(DemoCell, TwoArmsSortTheCubesTogether) {
  const fs::path out = fresh_dir("demo-cell");
  auto demo = ChildProcess::start(
      kBin / "scaratwin",
      {"demo", "--robots", "2", "--out", out.string(), "--http-port", "0", "--robot-speed", "1"},
      out / "demo.log");
  ASSERT_TRUE(demo) << demo.error().message;
  auto done = (*demo)->wait_for_line("demo passed", 900s);  // about 85 s
  const int status = (*demo)->wait_exit(120s);
  ASSERT_TRUE(done) << done.error().message << "\n" << (*demo)->output_tail(40);
  EXPECT_EQ(status, 0) << (*demo)->output_tail(40);

  const nlohmann::json r = nlohmann::json::parse(slurp(out / "results.json"));
  EXPECT_EQ(r["cubes"], 3);
  EXPECT_EQ(r["in_trays"], 3);
  EXPECT_EQ(r["arm_touches"], 0);
  EXPECT_GE(r["planned_least_distance_mm"].get<double>(), 20.0);
  ASSERT_EQ(r["robots"].size(), 2u);
  int tasks = 0;
  std::uint64_t seed = 0;
  for (const auto& robot : r["robots"]) {
    EXPECT_GE(robot["tasks"].get<int>(), 1) << robot.dump() << ": both arms work";
    // each arm a robot as built, two prints of one description (config/scara.toml's draw,
    // seed 1 by default, then seed 2), measured against its truth: the twin runs on the
    // nominal description here, so the gap is the build's own (mean 1.16 mm, max 3.49 mm for
    // the first build in the single demo uncalibrated, docs/results.md)
    EXPECT_EQ(robot["plant"], "as-built") << robot.dump();
    EXPECT_EQ(robot["as_built_seed"].get<std::uint64_t>(), 1u + seed++) << robot.dump();
    EXPECT_GT(robot["virtual_true_samples"].get<int>(), 1000) << robot.dump();
    EXPECT_LT(robot["virtual_true_tool_mean_mm"].get<double>(), 5.0) << robot.dump();
    EXPECT_LT(robot["virtual_true_tool_max_mm"].get<double>(), 10.0) << robot.dump();
    EXPECT_EQ(robot["lost"], 0) << robot.dump();
    EXPECT_GT(robot["frames"].get<int>(), 100) << robot.dump();
    EXPECT_EQ(robot["stopped"], "") << robot.dump();
    tasks += robot["tasks"].get<int>();
  }
  EXPECT_EQ(tasks, 3);
  EXPECT_TRUE(fs::exists(out / "report-left.html"));
  EXPECT_TRUE(fs::exists(out / "report-right.html"));

  auto cell =
      load_workcell_config(fs::path(SCARATWIN_CONFIG_FILE).parent_path() / "two_arms_trays.toml");
  ASSERT_TRUE(cell.ok()) << cell.error().message;
  std::vector<std::vector<JointRecord>> traces;
  std::vector<double> starts;
  for (const char* name : {"left", "right"}) {
    auto db = TwinDb::open(out / fmt::format("twin-{}.db", name));
    ASSERT_TRUE(db) << name;
    auto runs = (*db)->runs();
    ASSERT_TRUE(runs && runs->size() == 1u) << name;
    EXPECT_EQ(runs->front().kind, "cell-sort");
    EXPECT_EQ(runs->front().status, "ok") << name;
    auto phys = (*db)->samples(runs->front().id, SampleSource::kPhysical);
    ASSERT_TRUE(phys && phys->size() > 100) << name;
    traces.push_back(*phys);
    starts.push_back(runs->front().started_unix_s);
  }
  // each sample of the left arm against the right arm's latest sample at that instant
  double least = INFINITY;
  std::size_t k = 0;
  int compared = 0;
  for (const JointRecord& a : traces[0]) {
    const double t = starts[0] + a.t_s;
    while (k + 1 < traces[1].size() && starts[1] + traces[1][k + 1].t_s <= t) ++k;
    if (starts[1] + traces[1][k].t_s > t) continue;
    least = std::min(least, arm_distance(*cell, 0, a.q, 1, traces[1][k].q));
    ++compared;
  }
  EXPECT_GT(compared, 100);
  // planned 70 mm apart; the two robots start their timelines a few tens of milliseconds
  // apart and report every 10 ms (64 mm recorded on this machine); their links are 36 mm wide.
  // At real time: two emulators of the sanitizer build at twice real time fell behind in CI
  // (reports lost, TP replies late) on this 2-core machine
  EXPECT_GE(least, 0.050) << "the arms came within " << least * 1e3 << " mm of each other";
  std::printf("least distance of the recorded arms: %.1f mm over %d samples\n", least * 1e3,
              compared);
}

// `--robots` must match the workcell, and the single robot's options are refused with it.
TEST(DemoCell, RefusesARobotCountTheWorkcellDoesNotHave) {
  const fs::path out = fresh_dir("demo-cell-bad");
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--robots", "3"}, "has 2 robots ('left', 'right')"},
      {{"--robots", "2", "--serial", "/dev/null"}, "are for the single robot"}};
  for (const auto& [extra, message] : cases) {
    std::vector<std::string> args{"demo", "--out", out.string(), "--http-port", "0"};
    args.insert(args.end(), extra.begin(), extra.end());
    auto demo = ChildProcess::start(kBin / "scaratwin", args, out / "demo.log");
    ASSERT_TRUE(demo);
    EXPECT_EQ((*demo)->wait_exit(60s), 2) << (*demo)->output_tail(10);
    const std::string said = (*demo)->output_tail(10);
    EXPECT_NE(said.find(message), std::string::npos) << said;
  }
  EXPECT_FALSE(fs::exists(out / "sim.log")) << "nothing was started";
}

}  // namespace
}  // namespace scaratwin
