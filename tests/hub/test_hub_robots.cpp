// The hub through its robot interface (hub/robot_interface.hpp): the fake robot of the unit
// tests (fake_robot.hpp, the firmware's protocol on a real pty), the emulated robot started
// for the hub, and the robot a command picks from a workcell (`--robot NAME`). A real
// simulator (scaratwin-sim, no camera) is the virtual side of every hub here.
//
// Expected figures are worked out by hand from config/scara.toml, not by the code under test:
// J2 has 945 steps per rad, J3 1455 and moves 0.8 of each J2 step (the belt coupling); Z has
// 205,560 steps per metre.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <Eigen/Core>

#include "fake_robot.hpp"
#include "hub_robots_support.hpp"
#include "hub_test_support.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using fake::FakeRobot;
using fake::FakeRobotOptions;
using test::Outcome;
using namespace robots_test;

// One simulator for the suite (one hub at a time controls it).
class HubRobots : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fresh_dir("sim"));
    auto sim =
        ChildProcess::start(kBin / "scaratwin-sim",
                            {"--port", "0", "--http-port", "0", "--no-camera"}, *dir_ / "sim.log");
    ASSERT_TRUE(sim) << sim.error().message;
    sim_ = sim->release();
    auto port = test::simulator_port(*sim_);
    ASSERT_TRUE(port) << port.error().message;
    port_ = *port;
  }
  static void TearDownTestSuite() {
    delete sim_;
    sim_ = nullptr;
    delete dir_;
  }

  HubOptions options() const {
    HubOptions o;
    o.sim_port = port_;
    o.hello_timeout_s = 5.0;
    return o;
  }

  std::shared_ptr<FakeRobot> fake(FakeRobotOptions fo = {}) {
    auto f = FakeRobot::start(model_, fo);
    if (!f) ADD_FAILURE() << f.error().message;
    return f ? std::shared_ptr<FakeRobot>(std::move(*f)) : nullptr;
  }

  RobotModel model_ = paper_model();
  static inline ChildProcess* sim_ = nullptr;
  static inline fs::path* dir_ = nullptr;
  static inline std::uint16_t port_ = 0;
};

// Through the interface the hub reads the fake's reports, homes it and runs a trajectory;
// the fake ends at the counts worked out by hand.
TEST_F(HubRobots, TheHubHomesAndRunsATrajectoryOnTheFakeRobot) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  EXPECT_STREQ((*hub)->robot_interface().kind(), "fake");
  EXPECT_EQ((*hub)->robot_interface().where(), robot->device_path());
  ASSERT_TRUE((*hub)->home(10.0));
  // home: d1 0.12 m is round(0.12 * 205560) = 24667 Z steps
  EXPECT_EQ(robot->state().steps[0], 24667);
  const protocol::MotorSteps home = robot->state().steps;

  JointVector q0 = (*hub)->physical().q;
  JointVector q1 = q0;
  q1[1] += 0.4;  // J2 +0.4 rad: 378 J2 steps, and J3 0.8 * 378 = 302.4 -> 302
  auto plan = plan_quintic(model_, q0, q1);
  ASSERT_TRUE(plan) << plan.error().message;
  auto points = (*hub)->run_trajectory(*plan, 20.0);
  ASSERT_TRUE(points) << points.error().message;
  EXPECT_GT(*points, 1);
  const protocol::MotorSteps end = robot->state().steps;
  EXPECT_EQ(end[0], home[0]);
  EXPECT_EQ(end[1] - home[1], 378);
  EXPECT_EQ(end[2] - home[2], 302);
  EXPECT_GT((*hub)->serial_counters().packets_in, 0u);
  EXPECT_EQ((*hub)->mirror_counters().lost, 0u);
}

// A trajectory that stands still longer than one point may last (5 s, the firmware's TP limit:
// a robot of a workcell waiting for the other arm) is sent as points at most 4 s apart, on the
// robot's own line; before, its first long point was refused (TP ER 11, detail 1) and the
// robot stopped.
TEST_F(HubRobots, ALongWaitInATrajectoryIsSentAsPointsTheRobotTakes) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  ASSERT_TRUE((*hub)->home(10.0));
  const protocol::MotorSteps home = robot->state().steps;
  const JointVector q0 = (*hub)->physical().q;
  JointVector q1 = q0;
  q1[1] += 0.4;  // 378 J2 steps, 302 J3 steps (as above)
  auto plan = plan_quintic(model_, q0, q1);
  ASSERT_TRUE(plan) << plan.error().message;
  append_dwell(*plan, 5.5);
  auto back = plan_quintic(model_, q1, q0);
  ASSERT_TRUE(back);
  append(*plan, *back);
  auto points = (*hub)->run_trajectory(*plan, 30.0);
  ASSERT_TRUE(points) << points.error().message;
  EXPECT_EQ(robot->state().steps, home) << "there and back";
}

// The simulated prediction follows the plan's path though the simulator stalls mid-way (a
// loaded machine descheduling it: SIGSTOP for 0.5 s): the hub, late by the stall, holds the
// rest of the plan back by as much instead of sending the targets it missed back to back,
// which the virtual robot's servos chased off the path (the cause of a 15 mm deviation between
// the prediction and its replay in a loaded CI run). The oracle is the plan's tool path: every
// recorded state of the virtual robot lies within 1 mm of it.
TEST_F(HubRobots, APredictionKeepsToThePlansPathWhenTheSimulatorStalls) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  const fs::path dir = fresh_dir("stall");
  auto db = TwinDb::open(dir / "twin.db");
  ASSERT_TRUE(db) << db.error().message;
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), db->get());
  ASSERT_TRUE(hub) << hub.error().message;
  Hub& h = **hub;
  ASSERT_TRUE(h.reset_scene());
  ASSERT_TRUE(h.sim_mode(protocol::SimMode::kSimulate));
  ASSERT_TRUE(h.place_virtual(JointVector{0.09, -0.7, 1.2, 0.9}));
  // a straight line of the tool across the table, which the joints follow on a curve
  const JointVector q0{0.09, -0.7, 1.2, 0.9};
  auto plan = plan_line(model_, q0, forward(model_, JointVector{0.09, 0.5, 1.2, 0.9}));
  ASSERT_TRUE(plan) << plan.error().message;
  const double duration_s = plan->duration_s();
  ASSERT_GT(duration_s, 0.8);
  auto run = h.begin_run("prediction", "a line, the simulator stalled");
  ASSERT_TRUE(run);
  auto sim = std::async(std::launch::async, [&] { return h.simulate_trajectory(*plan); });
  std::this_thread::sleep_for(std::chrono::milliseconds(static_cast<int>(duration_s * 350)));
  ASSERT_EQ(::kill(sim_->pid(), SIGSTOP), 0);
  std::this_thread::sleep_for(500ms);
  ASSERT_EQ(::kill(sim_->pid(), SIGCONT), 0);
  ASSERT_EQ(sim.wait_for(30s), std::future_status::ready);
  const Status done = sim.get();
  ASSERT_TRUE(done) << done.error().message;
  ASSERT_TRUE(h.end_run(true));
  auto virt = (*db)->samples(*run, SampleSource::kVirtual);
  ASSERT_TRUE(virt);
  ASSERT_GT(virt->size(), 20u);
  // the plan's tool path as a polyline (its samples are 10 ms apart)
  std::vector<Eigen::Vector3d> path;
  for (const JointSample& s : plan->samples) {
    const ToolPose p = forward(model_, s.q);
    path.emplace_back(p.x_m, p.y_m, p.z_m);
  }
  double worst_m = 0.0;
  double worst_t = 0.0;
  for (const JointRecord& r : *virt) {
    const ToolPose p = forward(model_, r.q);
    const Eigen::Vector3d x(p.x_m, p.y_m, p.z_m);
    double nearest = INFINITY;
    for (std::size_t i = 0; i + 1 < path.size(); ++i) {
      const Eigen::Vector3d d = path[i + 1] - path[i];
      const double len2 = d.squaredNorm();
      const double u = len2 > 0.0 ? std::clamp((x - path[i]).dot(d) / len2, 0.0, 1.0) : 0.0;
      nearest = std::min(nearest, (path[i] + u * d - x).norm());
    }
    if (nearest > worst_m) {
      worst_m = nearest;
      worst_t = r.t_s;
    }
  }
  fmt::print("virtual robot at most {:.3f} mm off the plan's path (at {:.3f} s of {:.3f} s)\n",
             worst_m * 1e3, worst_t, duration_s);
  EXPECT_LT(worst_m, 0.001) << "at " << worst_t << " s";
}

// What the robot reports goes to the current run until it ends, not after: a demo's next
// stage starts a moment later, and the reports in between are no stage's (before, they went on
// into the run that had ended, past its recorded duration).
TEST_F(HubRobots, AnEndedRunTakesNoMoreOfTheRobotsReports) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  const fs::path dir = fresh_dir("ended-run");
  auto db = TwinDb::open(dir / "twin.db");
  ASSERT_TRUE(db) << db.error().message;
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), db->get());
  ASSERT_TRUE(hub) << hub.error().message;
  auto run = (*hub)->begin_run("mirror", "reports, then none");
  ASSERT_TRUE(run);
  std::this_thread::sleep_for(300ms);
  ASSERT_TRUE((*hub)->end_run(true));
  auto during = (*db)->samples(*run, SampleSource::kPhysical);
  ASSERT_TRUE(during) << during.error().message;
  ASSERT_GT(during->size(), 10u) << "the fake reports at 100 Hz";
  std::this_thread::sleep_for(300ms);
  auto after = (*db)->samples(*run, SampleSource::kPhysical);
  ASSERT_TRUE(after);
  EXPECT_EQ(after->size(), during->size());
  auto info = (*db)->run(*run);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->status, "ok");
  EXPECT_LE(after->back().t_s, info->duration_s);
  EXPECT_EQ((*hub)->current_run(), 0);
}

// A robot built for another description is refused at its hello, naming both hashes; the
// hub sends it nothing after the hello.
TEST_F(HubRobots, ARobotBuiltForAnotherDescriptionIsRefusedAtItsHello) {
  FakeRobotOptions fo;
  fo.description_hash = "0badf00d";
  auto robot = fake(fo);
  ASSERT_TRUE(robot);
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), nullptr);
  ASSERT_FALSE(hub);
  EXPECT_EQ(hub.error().message,
            fmt::format("the physical robot's firmware on {} was built for robot description "
                        "0badf00d, this hub for f062700f: build and flash the firmware for this "
                        "description (cmake -DSCARATWIN_ROBOT_DESCRIPTION=FILE), or start the hub "
                        "with the firmware's --config",
                        robot->device_path()));
  EXPECT_EQ(robot->received_codes(), std::vector<std::string>{"HI"});
  EXPECT_EQ(robot->moves_started(), 0);
}

// A simulator that does not host the robot's index is refused before the robot hears anything:
// the hub greets the simulator first (a board's bootloader must not make it wait there).
TEST_F(HubRobots, ASimulatorWithoutTheRobotIsRefusedBeforeTheRobotIsTold) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  HubOptions o = options();
  o.sim_robot = 1;
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), o, nullptr);
  ASSERT_FALSE(hub);
  EXPECT_EQ(hub.error().message,
            fmt::format("the simulator at 127.0.0.1:{} has no robot 1 (it counts from 0): start "
                        "it with the workcell this robot belongs to",
                        port_));
  EXPECT_EQ(robot->received_codes(), std::vector<std::string>{});
}

// A simulator that comes back refusing the hub (restarted with an access token here; another
// controller is refused the same way): the hub says why at once, instead of reconnecting in
// silence. A hub refused while it connects says only the refusal, not a lost link.
TEST_F(HubRobots, ASimulatorThatComesBackRefusingTheHubIsSaidWhy) {
  const fs::path dir = fresh_dir("sim-back");
  auto sim = ChildProcess::start(kBin / "scaratwin-sim",
                                 {"--port", "0", "--http-port", "0", "--no-camera"}, dir / "a.log");
  ASSERT_TRUE(sim) << sim.error().message;
  auto port = test::simulator_port(**sim);
  ASSERT_TRUE(port) << port.error().message;
  auto robot = fake();
  ASSERT_TRUE(robot);
  HubOptions o = options();
  o.sim_port = *port;
  o.log_name = "left";  // one of several hubs in a process: its messages name its robot
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), o, nullptr);
  ASSERT_TRUE(hub) << hub.error().message;

  testing::internal::CaptureStderr();
  sim->reset();  // ends it
  auto back = ChildProcess::start(
      kBin / "scaratwin-sim",
      {"--port", std::to_string(*port), "--http-port", "0", "--no-camera", "--token", "sesame"},
      dir / "b.log");
  ASSERT_TRUE(back) << back.error().message;
  ASSERT_TRUE(test::simulator_port(**back));
  const std::string refused =
      "scaratwin: robot 'left': the simulator refused the hub: it needs its access token "
      "(--sim-token or SCARATWIN_TOKEN)";
  std::string err;
  for (int i = 0; i < 100 && err.find(refused) == std::string::npos; ++i) {
    std::this_thread::sleep_for(100ms);
    // CaptureStderr ends with GetCapturedStderr: take it and capture on
    err += testing::internal::GetCapturedStderr();
    testing::internal::CaptureStderr();
  }
  err += testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("scaratwin: robot 'left': the simulator link was lost; reconnecting"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find(refused), std::string::npos) << err;
  EXPECT_FALSE((*hub)->sim_connected());

  // a second hub refused at its connection: the refusal, and no word of a lost link
  auto other = fake();
  ASSERT_TRUE(other);
  testing::internal::CaptureStderr();
  auto second = Hub::connect(model_, std::make_unique<FakeInterface>(other), o, nullptr);
  err = testing::internal::GetCapturedStderr();
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().message,
            fmt::format("simulator at 127.0.0.1:{} refused the hub: it needs its access token "
                        "(--sim-token or SCARATWIN_TOKEN)",
                        *port));
  EXPECT_EQ(err.find("link was lost"), std::string::npos) << err;
}

// The stop statement: the fake confirms it, and the next trajectory runs (recover()).
TEST_F(HubRobots, AStopIsConfirmedAndTheNextTrajectoryRuns) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  ASSERT_TRUE((*hub)->home(10.0));
  ASSERT_TRUE((*hub)->stop());
  EXPECT_NE(robot->state().flags & protocol::state_flags::kHalted, 0u);
  JointVector q0 = (*hub)->physical().q;
  JointVector q1 = q0;
  q1[2] -= 0.2;  // J3 -0.2 rad: 1455 * 0.2 = 291 J3 steps
  const protocol::MotorSteps before = robot->state().steps;
  auto plan = plan_quintic(model_, q0, q1);
  ASSERT_TRUE(plan) << plan.error().message;
  auto points = (*hub)->run_trajectory(*plan, 20.0);
  ASSERT_TRUE(points) << points.error().message;
  EXPECT_EQ(robot->state().steps[2] - before[2], -291);
  EXPECT_EQ(robot->state().steps[1], before[1]);
  EXPECT_EQ(robot->state().flags & protocol::state_flags::kHalted, 0u);
}

// A robot that goes silent mid-trajectory: the trajectory ends with the hub's stop sent into
// the silence, and once the link is back the robot homes again.
TEST_F(HubRobots, ARobotSilentMidTrajectoryEndsItAndHomesWhenItIsBack) {
  auto robot = fake();
  ASSERT_TRUE(robot);
  auto hub = Hub::connect(model_, std::make_unique<FakeInterface>(robot), options(), nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  ASSERT_TRUE((*hub)->home(10.0));
  JointVector q0 = (*hub)->physical().q;
  JointVector q1 = q0;
  q1[1] += 1.0;
  auto plan = plan_quintic(model_, q0, q1, QuinticOptions{60, 4.0});
  ASSERT_TRUE(plan) << plan.error().message;
  auto run = std::async(std::launch::async, [&] { return (*hub)->run_trajectory(*plan, 30.0); });
  std::this_thread::sleep_for(700ms);
  robot->set_silent(true);
  ASSERT_EQ(run.wait_for(15s), std::future_status::ready);
  auto r = run.get();
  ASSERT_FALSE(r);
  const auto codes = robot->received_codes();
  EXPECT_NE(std::find(codes.begin(), codes.end(), "!"), codes.end())
      << "the hub sent no stop into the silence";
  robot->set_silent(false);
  const Status homed = (*hub)->home(10.0);
  ASSERT_TRUE(homed) << "homing after the silence: " << homed.error().message;
  EXPECT_EQ(robot->state().steps[0], 24667);
}

// The emulated robot: the interface starts the emulator, the hub reads its reports over the
// pty it printed, and the emulator stops with the hub (its pty goes away).
TEST_F(HubRobots, TheEmulatedRobotIsStartedForTheHubAndStoppedWithIt) {
  const fs::path dir = fresh_dir("emulated");
  EmulatedRobotOptions eo;
  eo.executable = kBin / "scaratwin-robot";
  eo.args = {"--plant", "ideal", "--camera-port", "-1"};
  eo.log = dir / "robot.log";
  HubOptions o = options();
  auto hub = Hub::connect(model_, emulated_robot(eo), o, nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  EXPECT_STREQ((*hub)->robot_interface().kind(), "emulated");
  const std::string pty = (*hub)->robot_interface().where();
  EXPECT_EQ(pty.rfind("/dev/pts/", 0), 0u) << pty;
  auto st = (*hub)->fresh_physical(5.0);
  ASSERT_TRUE(st) << st.error().message;
  EXPECT_TRUE(st->valid);
  hub->reset();
  EXPECT_FALSE(fs::exists(pty)) << "the emulator's pty is still there: the emulator runs on";
}

Outcome run_cli(const std::vector<std::string>& args) {
  return test::run_program(kBin / "scaratwin", args);
}

// `--robot NAME` picks one robot of a workcell: a workcell of two needs it, an unknown name
// is refused (exit 2) before anything is opened, and the robot's index reaches the
// simulator, which refuses a robot it does not host before the robot hears anything.
TEST_F(HubRobots, TheCommandLinePicksTheRobotByName) {
  const std::string sim = fmt::format("127.0.0.1:{}", port_);
  Outcome o = run_cli(
      {"home", "--workcell", kWorkcell.string(), "--serial", "/dev/null", "--sim", sim, "--no-db"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find(fmt::format("scaratwin home: {} has 2 robots ('left', 'right'): say "
                                      "which one with --robot NAME",
                                      kWorkcell.string())),
            std::string::npos)
      << o.output;

  o = run_cli({"home", "--config", kConfig.string(), "--robot", "arm7", "--serial", "/dev/null",
               "--sim", sim, "--no-db"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("scaratwin home: no robot named 'arm7' in the workcell (robots: "
                          "'robot')"),
            std::string::npos)
      << o.output;

  auto right = fake();
  ASSERT_TRUE(right);
  o = run_cli({"home", "--workcell", kWorkcell.string(), "--robot", "right", "--serial",
               right->device_path(), "--sim", sim, "--no-db"});
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find(fmt::format("scaratwin home: the simulator at {} has no robot 1", sim)),
            std::string::npos)
      << o.output;
  EXPECT_EQ(right->received_codes(), std::vector<std::string>{});
  EXPECT_EQ(right->moves_started(), 0);

  // the first robot of the workcell is the simulator's robot 0: it homes
  auto left = fake();
  ASSERT_TRUE(left);
  o = run_cli({"home", "--workcell", kWorkcell.string(), "--robot", "left", "--serial",
               left->device_path(), "--sim", sim, "--no-db"});
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(left->state().flags & protocol::state_flags::kHomed, 0u);
  EXPECT_EQ(left->state().steps[0], 24667);
}

// `scaratwin hub --workcell` without --robot drives every robot: each one's port is
// NAME=DEVICE, and every mistake in them is refused (exit 2) before any port is opened, so the
// robot on the port that was right hears nothing.
TEST_F(HubRobots, AHubOfEveryRobotRefusesPortsItCannotMatch) {
  auto left = fake();
  ASSERT_TRUE(left);
  const std::string cell = kWorkcell.string();
  const std::string at_left = "left=" + left->device_path();
  const std::string sim = fmt::format("127.0.0.1:{}", port_);
  const struct {
    std::vector<std::string> args;
    std::string error;
  } cases[] = {
      {{"--serial", at_left},
       "scaratwin hub: no serial port for robot 'right': pass --serial right=DEVICE (one for each "
       "of 'left', 'right')"},
      {{"--serial", left->device_path()},
       fmt::format("scaratwin hub: --serial '{}': this hub drives 2 robots ('left', 'right'); "
                   "give each one's port as --serial NAME=DEVICE",
                   left->device_path())},
      {{"--serial", at_left, "--serial", "arm7=/dev/null"},
       "scaratwin hub: --serial 'arm7=/dev/null': no robot named 'arm7' in the workcell (robots: "
       "'left', 'right')"},
      {{"--serial", at_left, "--serial", "left=/dev/null"},
       "scaratwin hub: --serial names robot 'left' twice"},
      {{"--serial", at_left, "--serial", "right=" + left->device_path()},
       fmt::format("scaratwin hub: --serial: robots 'left' and 'right' are both on {}; each "
                   "robot has a port of its own",
                   left->device_path())},
      {{"--serial", at_left, "--serial", "right=/dev/null", "--name", "r1"},
       fmt::format("scaratwin hub: --name: this hub drives the 2 robots of {} under their own "
                   "names ('left', 'right'); --robot NAME drives one of them alone",
                   cell)},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args{"hub", "--workcell", cell, "--sim", sim, "--no-db"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const Outcome o = run_cli(args);
    EXPECT_EQ(o.status, 2) << o.output;
    EXPECT_NE(o.output.find(c.error), std::string::npos) << o.output;
  }
  // a command of one robot given two ports
  const Outcome o = run_cli(
      {"home", "--serial", left->device_path(), "--serial", "/dev/null", "--sim", sim, "--no-db"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("scaratwin home: --serial given 2 times: this command drives one robot "
                          "('robot')"),
            std::string::npos)
      << o.output;
  EXPECT_TRUE(left->received_codes().empty());
}

}  // namespace
}  // namespace scaratwin
