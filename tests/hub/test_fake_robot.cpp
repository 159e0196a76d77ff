// The fake robot (fake_robot.hpp) through the project's real transport: SerialLink on its pty
// and RobotChannel, as the hub's connect() builds them. Each test checks the exact replies the
// firmware gives (docs/protocol.md sections 8, 9, 11), so that hub tests written against the
// fake hold against the robot.
#include "fake_robot.hpp"
#include "hub_test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <numbers>
#include <string>
#include <thread>
#include <vector>

#include "scaratwin/core/error_codes.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/transport/channel.hpp"
#include "scaratwin/transport/io_thread.hpp"
#include "scaratwin/transport/serial.hpp"

#ifdef SCARATWIN_BIN_DIR
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#endif

namespace scaratwin::fake {
namespace {

namespace pr = protocol;
namespace tr = transport;
using namespace std::chrono_literals;
using Event = pr::DeviceEventCode;

constexpr tr::Duration kReplyTimeout{2000};
constexpr auto kEventTimeout = 3s;

// The paper's robot with a home pose off the joint zero, so that each axis's conversion shows.
RobotModel test_model() {
  RobotModel m = paper_robot();
  m.home = {0.10, 0.30, -0.20, 0.0};
  return m;
}

// The home pose's step counts from the model's numbers (DESIGN.md: Z steps per metre, J2 and
// J3 steps per radian, and the J3 motor's 0.8 step per J2 motor step), not from motor.hpp.
pr::MotorSteps expected_home_steps(const RobotModel& m) {
  const double z = m.home[0] * m.motors.z.steps_per_unit;
  const double j2 = m.home[1] * m.motors.j2.steps_per_unit;
  const double j3 = m.home[2] * m.motors.j3.steps_per_unit + m.motors.j3_per_j2_coupling * j2;
  return {static_cast<std::int32_t>(std::lround(z)), static_cast<std::int32_t>(std::lround(j2)),
          static_cast<std::int32_t>(std::lround(j3))};
}

double cdeg(std::int32_t v) { return v * std::numbers::pi / 18000.0; }

class FakeRobotTest : public ::testing::Test {
 protected:
  void start(FakeRobotOptions options = {}) {
    model_ = test_model();
    auto robot = FakeRobot::start(model_, std::move(options));
    ASSERT_TRUE(robot) << robot.error().message;
    robot_ = std::move(*robot);
    io_ = tr::IoThread::create("fake-robot-test");
    tr::SerialOptions so;
    so.device = robot_->device_path();
    auto link = tr::SerialLink::create(so, io_);
    ASSERT_TRUE(link) << link.error().message;
    link_ = std::move(*link);
    ASSERT_TRUE(link_->wait_connected(kReplyTimeout)) << link_->name();
    channel_ = std::make_unique<tr::RobotChannel>(*link_, tr::robot_channel_defaults());
    channel_->set_unsolicited_handler([this](pr::SerialFromDevice&& m, const tr::RxPacket&) {
      std::lock_guard lock(mu_);
      unsolicited_.push_back(std::move(m));
      cv_.notify_all();
    });
  }

  Result<tr::RobotChannel::Reply> request(const pr::SerialToDevice& m) {
    return channel_->request(m, kReplyTimeout);
  }
  // The one message of a request's reply (a failed test when it was refused).
  pr::SerialFromDevice reply(const pr::SerialToDevice& m) {
    auto r = request(m);
    EXPECT_TRUE(r) << r.error().message;
    return r ? r->last() : pr::SerialFromDevice(pr::ErrorReply{});
  }
  pr::DeviceState query() {
    const auto r = reply(pr::QueryState{});
    const auto* st = std::get_if<pr::DeviceState>(&r);
    EXPECT_NE(st, nullptr);
    return st != nullptr ? *st : pr::DeviceState{};
  }

  // Waits for the unsolicited messages to satisfy `pred` (called with the lock held).
  bool wait_for(const std::function<bool(const std::vector<pr::SerialFromDevice>&)>& pred,
                std::chrono::milliseconds timeout = kEventTimeout) {
    std::unique_lock lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return pred(unsolicited_); });
  }
  bool wait_event(Event event, std::optional<std::int32_t> value = std::nullopt) {
    return wait_for([&](const auto& all) {
      for (const auto& m : all) {
        const auto* ev = std::get_if<pr::DeviceEvent>(&m);
        if (ev != nullptr && ev->event == event && (!value || ev->value == value)) return true;
      }
      return false;
    });
  }
  std::vector<pr::DeviceEvent> events() {
    std::lock_guard lock(mu_);
    std::vector<pr::DeviceEvent> out;
    for (const auto& m : unsolicited_) {
      if (const auto* ev = std::get_if<pr::DeviceEvent>(&m)) out.push_back(*ev);
    }
    return out;
  }
  std::vector<pr::DeviceState> reports() {
    std::lock_guard lock(mu_);
    std::vector<pr::DeviceState> out;
    for (const auto& m : unsolicited_) {
      if (const auto* st = std::get_if<pr::DeviceState>(&m)) out.push_back(*st);
    }
    return out;
  }
  void clear() {
    std::lock_guard lock(mu_);
    unsolicited_.clear();
  }
  void home() {
    EXPECT_EQ(reply(pr::Home{}), pr::SerialFromDevice(pr::Ack{"HM", std::nullopt}));
    EXPECT_TRUE(wait_event(Event::kHomed));
  }
  // ER code N of a refused request
  static int refused(const Result<tr::RobotChannel::Reply>& r) {
    return r ? 0 : r.error().code - protocol_error_code(0);
  }

  // the unsolicited messages first: destroyed after the channel whose handler fills them
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<pr::SerialFromDevice> unsolicited_;
  RobotModel model_;
  std::unique_ptr<FakeRobot> robot_;
  std::shared_ptr<tr::IoThread> io_;
  std::unique_ptr<tr::SerialLink> link_;
  std::unique_ptr<tr::RobotChannel> channel_;
};

TEST_F(FakeRobotTest, AnswersHelloWithTheDescriptionHash) {
  ASSERT_NO_FATAL_FAILURE(start());
  const std::string hash = description_hash(model_);
  EXPECT_EQ(reply(pr::Hello{1, {}, {}, hash, std::nullopt}),
            pr::SerialFromDevice(pr::PeerHello{1, "fake", "0.1.0", hash}));
  // a version-1 hello (no hash) gets a version-1 answer
  EXPECT_EQ(reply(pr::Hello{1, {}, {}, {}, std::nullopt}),
            pr::SerialFromDevice(pr::PeerHello{1, "fake", "0.1.0", ""}));
  // another protocol version: ER 13 naming the supported one
  auto r = request(pr::Hello{2, {}, {}, {}, std::nullopt});
  ASSERT_FALSE(r);
  EXPECT_EQ(refused(r), 13);
  EXPECT_NE(r.error().message.find("detail 1"), std::string::npos) << r.error().message;
  EXPECT_EQ(robot_->received_codes(), (std::vector<std::string>{"HI", "HI", "HI"}));
}

TEST_F(FakeRobotTest, AnswersWithTheHashItWasGiven) {
  FakeRobotOptions o;
  o.description_hash = "0badcafe";
  ASSERT_NO_FATAL_FAILURE(start(o));
  const auto hi = reply(pr::Hello{1, {}, {}, description_hash(model_), std::nullopt});
  ASSERT_TRUE(std::holds_alternative<pr::PeerHello>(hi));
  EXPECT_EQ(std::get<pr::PeerHello>(hi).description, "0badcafe");
}

TEST_F(FakeRobotTest, ReportsAtTheRequestedRate) {
  ASSERT_NO_FATAL_FAILURE(start());
  EXPECT_EQ(reply(pr::Ping{7}), pr::SerialFromDevice(pr::Ack{"PI", 7}));
  EXPECT_EQ(reply(pr::SetReportRate{100}), pr::SerialFromDevice(pr::Ack{"SR", 100}));
  ASSERT_TRUE(wait_for([](const auto& all) { return !all.empty(); }));
  clear();
  std::this_thread::sleep_for(500ms);
  const auto st = reports();
  // 50 at 100 Hz; loose bounds for a loaded machine (sanitizers, parallel tests)
  EXPECT_GE(st.size(), 25u);
  EXPECT_LE(st.size(), 75u);
  ASSERT_GE(st.size(), 2u);
  for (std::size_t i = 1; i < st.size(); ++i) {
    EXPECT_EQ(st[i].seq, static_cast<std::uint16_t>(st[i - 1].seq + 1));
    EXPECT_GT(st[i].t_us - st[i - 1].t_us, 0u);
    EXPECT_EQ(st[i].flags, 0u);  // not homed, at rest
    EXPECT_EQ(st[i].queue_free, 15);
  }
  EXPECT_EQ(channel_->lost_packets(), 0u);
  // off again
  EXPECT_EQ(reply(pr::SetReportRate{0}), pr::SerialFromDevice(pr::Ack{"SR", 0}));
  std::this_thread::sleep_for(50ms);
  clear();
  std::this_thread::sleep_for(200ms);
  EXPECT_TRUE(reports().empty());
}

TEST_F(FakeRobotTest, HomesToTheHomePoseSteps) {
  ASSERT_NO_FATAL_FAILURE(start());
  EXPECT_EQ(query().flags & pr::state_flags::kHomed, 0u);
  home();
  const pr::DeviceState st = query();
  EXPECT_EQ(st.flags, pr::state_flags::kHomed);
  EXPECT_EQ(st.steps, expected_home_steps(model_));
  EXPECT_EQ(st.steps, robot_->home_steps());
  // the first homing reports no offsets (the robot was not homed before)
  auto ev = events();
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0], (pr::DeviceEvent{Event::kHomed, std::nullopt}));
  // homing again: the three offsets (nothing lost) just before the homed event
  clear();
  home();
  ev = events();
  ASSERT_EQ(ev.size(), 4u);
  EXPECT_EQ(ev[0], (pr::DeviceEvent{Event::kHomingOffsetZ, 0}));
  EXPECT_EQ(ev[1], (pr::DeviceEvent{static_cast<Event>(11), 0}));
  EXPECT_EQ(ev[2], (pr::DeviceEvent{static_cast<Event>(12), 0}));
  EXPECT_EQ(ev[3], (pr::DeviceEvent{Event::kHomed, std::nullopt}));
  EXPECT_EQ(robot_->moves_started(), 2);
}

TEST_F(FakeRobotTest, RunsATrajectoryToItsLastPointWithTheDoneEvent) {
  ASSERT_NO_FATAL_FAILURE(start());
  home();
  EXPECT_EQ(reply(pr::SetReportRate{100}), pr::SerialFromDevice(pr::Ack{"SR", 100}));
  const pr::MotorSteps h = robot_->home_steps();
  // within the firmware's speed and acceleration checks at 50 ms a point, at rest at the end
  const int offsets[] = {5, 15, 25, 30, 30};
  EXPECT_EQ(reply(pr::TrajectoryBegin{5}), pr::SerialFromDevice(pr::Ack{"TB", 15}));
  for (int i = 0; i < 5; ++i) {
    pr::TrajectoryPoint p;
    p.seq = i;
    p.dt_s = 0.05;
    p.steps = {h[0] + offsets[i], h[1] - offsets[i], h[2] + offsets[i]};
    p.wrist_rad = cdeg(100 * (i + 1));
    if (i == 4) p.grip_rad = cdeg(7500);
    // points wait in the queue until the last one is in: the free slots count down
    EXPECT_EQ(reply(p), pr::SerialFromDevice(pr::Ack{"TP", 15 - (i + 1)}));
  }
  ASSERT_TRUE(wait_event(Event::kTrajectoryDone, 5));
  const pr::DeviceState st = query();
  EXPECT_EQ(st.steps, (pr::MotorSteps{h[0] + 30, h[1] - 30, h[2] + 30}));
  EXPECT_NEAR(st.wrist_rad, cdeg(500), 1e-9);
  EXPECT_NEAR(st.grip_rad, cdeg(7500), 1e-9);
  EXPECT_EQ(st.flags, pr::state_flags::kHomed);
  EXPECT_EQ(st.queue_free, 15);
  // the reports showed the run: the trajectory flag while points remained
  bool saw_running = false;
  for (const auto& r : reports()) {
    if ((r.flags & pr::state_flags::kTrajectory) != 0) saw_running = true;
  }
  EXPECT_TRUE(saw_running);
  EXPECT_EQ(robot_->moves_started(), 2);  // the homing and the trajectory
}

TEST_F(FakeRobotTest, StreamsMoreThanItsQueueWithCredits) {
  ASSERT_NO_FATAL_FAILURE(start());
  home();
  const pr::MotorSteps h = robot_->home_steps();
  constexpr int kPoints = 40;  // 2 steps of Z per 10 ms point: 200 steps/s
  EXPECT_EQ(reply(pr::TrajectoryBegin{kPoints}), pr::SerialFromDevice(pr::Ack{"TB", 15}));
  int credit = 15;
  for (int i = 0; i < kPoints;) {
    if (credit == 0) {
      std::this_thread::sleep_for(5ms);
      credit = query().queue_free;
      continue;
    }
    pr::TrajectoryPoint p;
    p.seq = i;
    p.dt_s = 0.01;
    p.steps = {h[0] + 2 * (i + 1), h[1], h[2]};
    const auto r = reply(p);
    const auto* ak = std::get_if<pr::Ack>(&r);
    ASSERT_NE(ak, nullptr) << "point " << i;
    credit = ak->value.value_or(0);
    ++i;
  }
  ASSERT_TRUE(wait_event(Event::kTrajectoryDone, kPoints));
  EXPECT_EQ(query().steps, (pr::MotorSteps{h[0] + 2 * kPoints, h[1], h[2]}));
}

TEST_F(FakeRobotTest, StopConfirmsAndHaltsUntilResumeOrHoming) {
  ASSERT_NO_FATAL_FAILURE(start());
  home();
  const pr::MotorSteps h = robot_->home_steps();
  // three slow points (1 s each): the stop comes in the first
  const int z[] = {1000, 2500, 3500};
  EXPECT_EQ(reply(pr::TrajectoryBegin{3}), pr::SerialFromDevice(pr::Ack{"TB", 15}));
  for (int i = 0; i < 3; ++i) {
    pr::TrajectoryPoint p;
    p.seq = i;
    p.dt_s = 1.0;
    p.steps = {h[0] + z[i], h[1], h[2]};
    ASSERT_TRUE(request(p));
  }
  std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(channel_->send_realtime(pr::Realtime::kStop));
  ASSERT_TRUE(wait_event(Event::kStopped));
  pr::DeviceState st = query();
  EXPECT_EQ(st.flags, pr::state_flags::kHomed | pr::state_flags::kHalted);
  EXPECT_EQ(st.queue_free, 15);
  EXPECT_GT(st.steps[0], h[0]);  // it had started: the counts stay where it stopped
  EXPECT_LT(st.steps[0], h[0] + 1000);
  const pr::MotorSteps stopped_at = st.steps;
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(query().steps, stopped_at);

  // halted: motion is refused (14) until '~'
  EXPECT_EQ(refused(request(pr::TrajectoryBegin{1})), 14);
  EXPECT_EQ(refused(request(pr::Jog{pr::Axis::kZ, 10})), 14);
  ASSERT_TRUE(channel_->send_realtime(pr::Realtime::kResume));
  ASSERT_TRUE(wait_event(Event::kResumed));
  EXPECT_EQ(reply(pr::TrajectoryBegin{1}), pr::SerialFromDevice(pr::Ack{"TB", 15}));

  // SP: the reply, then the same confirmation; HM also clears the halt
  clear();
  EXPECT_EQ(reply(pr::Stop{}), pr::SerialFromDevice(pr::Ack{"SP", std::nullopt}));
  ASSERT_TRUE(wait_event(Event::kStopped));
  EXPECT_EQ(refused(request(pr::TrajectoryBegin{1})), 14);
  home();
  EXPECT_EQ(query().flags, pr::state_flags::kHomed);
  EXPECT_EQ(reply(pr::TrajectoryBegin{1}), pr::SerialFromDevice(pr::Ack{"TB", 15}));
  EXPECT_EQ(robot_->received_codes(),
            (std::vector<std::string>{"HM", "TB", "TP", "TP", "TP", "!", "QS", "QS", "TB", "JG",
                                      "~", "TB", "SP", "TB", "HM", "QS", "TB"}));
}

TEST_F(FakeRobotTest, RefusesAsTheFirmwareDoes) {
  ASSERT_NO_FATAL_FAILURE(start());
  // before homing: no trajectory (7), but a jog (to bring the robot to its switches by hand)
  EXPECT_EQ(refused(request(pr::TrajectoryBegin{2})), 7);
  auto tp = request(pr::TrajectoryPoint{0, 0.02, {0, 0, 0}, 0.0, std::nullopt});
  ASSERT_FALSE(tp);
  EXPECT_EQ(refused(tp), 10);
  EXPECT_NE(tp.error().message.find("detail 0"), std::string::npos) << tp.error().message;
  EXPECT_EQ(robot_->moves_started(), 0);
  EXPECT_EQ(reply(pr::Jog{pr::Axis::kJ2, -120}), pr::SerialFromDevice(pr::Ack{"JG", std::nullopt}));
  EXPECT_EQ(robot_->state().steps, (pr::MotorSteps{0, -120, 0}));
  EXPECT_EQ(refused(request(pr::Jog{pr::Axis::kWrist, cdeg(-100)})), 8);  // below 0 cdeg
  EXPECT_EQ(reply(pr::SetGripper{cdeg(6000)}), pr::SerialFromDevice(pr::Ack{"GR", 6000}));
  EXPECT_EQ(reply(pr::Config{1, std::nullopt}), pr::SerialFromDevice(pr::Ack{"CF", 5000}));
  EXPECT_EQ(reply(pr::Config{3, 50}), pr::SerialFromDevice(pr::Ack{"CF", 50}));
  EXPECT_EQ(refused(request(pr::Config{3, 5000})), 11);

  // a point out of order, and one too fast for the motors (the firmware's planner checks)
  home();
  const pr::MotorSteps h = robot_->home_steps();
  EXPECT_EQ(reply(pr::TrajectoryBegin{2}), pr::SerialFromDevice(pr::Ack{"TB", 15}));
  auto late = request(pr::TrajectoryPoint{1, 0.02, h, 0.0, std::nullopt});
  ASSERT_FALSE(late);
  EXPECT_EQ(refused(late), 10);
  EXPECT_NE(late.error().message.find("detail 0"), std::string::npos);
  auto fast = request(pr::TrajectoryPoint{0, 0.02, {h[0], h[1] + 500, h[2]}, 0.0, std::nullopt});
  ASSERT_FALSE(fast);
  EXPECT_EQ(refused(fast), 11);
  EXPECT_NE(fast.error().message.find("detail 3"), std::string::npos) << fast.error().message;
  // a refused point is not queued: the next one is still seq 0
  EXPECT_EQ(reply(pr::TrajectoryPoint{0, 0.02, h, 0.0, std::nullopt}),
            pr::SerialFromDevice(pr::Ack{"TP", 14}));

  // a line the robot cannot read: ER 3 (no detail) for an unknown code, in the place of a reply
  clear();
  ASSERT_TRUE(link_->send("ZZ=\n"));
  ASSERT_TRUE(wait_for([](const auto& all) { return !all.empty(); }));
  {
    std::lock_guard lock(mu_);
    EXPECT_EQ(unsolicited_.front(), pr::SerialFromDevice(pr::ErrorReply{3, std::nullopt}));
  }
  const auto codes = robot_->received_codes();
  ASSERT_FALSE(codes.empty());
  EXPECT_EQ(codes.back(), "?");
}

TEST_F(FakeRobotTest, SilenceStopsTheReports) {
  ASSERT_NO_FATAL_FAILURE(start());
  EXPECT_EQ(reply(pr::SetReportRate{100}), pr::SerialFromDevice(pr::Ack{"SR", 100}));
  ASSERT_TRUE(wait_for([](const auto& all) { return all.size() >= 3; }));
  robot_->set_silent(true);
  std::this_thread::sleep_for(50ms);  // what was already on its way
  clear();
  std::this_thread::sleep_for(300ms);
  EXPECT_TRUE(reports().empty());
  // back: the reports resume, and their numbers show the gap
  robot_->set_silent(false);
  ASSERT_TRUE(wait_for([](const auto& all) { return all.size() >= 2; }));
  EXPECT_GT(channel_->lost_packets(), 10u);
}

#ifdef SCARATWIN_BIN_DIR
// The real hub against the fake: connect (hellos with the description hash, the report rate),
// homing, and a trajectory streamed with credits, with the simulator as a child process (no
// camera). The robot ends at the last point's counts, as the hub converts its joints.
TEST(FakeRobotHub, TheHubConnectsHomesAndRunsATrajectory) {
  auto model = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model) << model.error().message;
  auto robot = FakeRobot::start(*model);
  ASSERT_TRUE(robot) << robot.error().message;
  auto sim = ChildProcess::start(
      std::filesystem::path(SCARATWIN_BIN_DIR) / "scaratwin-sim",
      {"--port", "0", "--http-port", "0", "--no-camera", "--config", SCARATWIN_CONFIG_FILE});
  ASSERT_TRUE(sim) << sim.error().message;
  auto port = test::simulator_port(**sim);
  ASSERT_TRUE(port) << port.error().message;
  HubOptions opt;
  opt.serial_device = (*robot)->device_path();
  opt.sim_port = *port;
  opt.description_source = SCARATWIN_CONFIG_FILE;
  auto hub = Hub::connect(*model, opt, nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  Hub& h = **hub;

  ASSERT_TRUE(h.home(10.0));
  auto at_home = h.fresh_physical(2.0);
  ASSERT_TRUE(at_home) << at_home.error().message;
  // (a home pose on a soft limit may be settled one step inside it: Hub::settle_at_home)
  const pr::MotorSteps home = joints_to_steps(*model, model->home);
  for (std::size_t i = 0; i < home.size(); ++i) EXPECT_NEAR(at_home->raw.steps[i], home[i], 2) << i;
  EXPECT_NE(at_home->raw.flags & pr::state_flags::kHomed, 0u);

  // more points than the robot's queue holds: the credits must be followed; a short move
  // (Z is the slow axis: 3 mm are 617 steps) keeps the test at about 2 s
  const JointVector target{0.117, 0.3, 0.2, 0.5};
  const double duration_s = std::max(0.5, 1.2 * quintic_min_duration(*model, at_home->q, target));
  const JointTrajectory move = quintic(at_home->q, target, duration_s, 60);
  auto run = h.run_trajectory(move);
  ASSERT_TRUE(run) << run.error().message;
  EXPECT_GT(*run, 15);
  auto after = h.fresh_physical(2.0);
  ASSERT_TRUE(after) << after.error().message;
  const pr::MotorSteps want = joints_to_steps(*model, target);
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(after->raw.steps[i], want[i], 1) << i;
  EXPECT_EQ((*robot)->state().steps, after->raw.steps);

  const auto codes = (*robot)->received_codes();
  const auto has = [&](const char* code) {
    return std::find(codes.begin(), codes.end(), code) != codes.end();
  };
  EXPECT_EQ(codes.front(), "HI");
  for (const char* code : {"SR", "HM", "TB", "TP"}) EXPECT_TRUE(has(code)) << code;
  EXPECT_FALSE(has("?"));
  EXPECT_GE((*robot)->moves_started(), 2);
}
#endif

}  // namespace
}  // namespace scaratwin::fake
