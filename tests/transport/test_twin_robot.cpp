// The control statements against the real firmware running in the emulator
// (scaratwin-robot: the Uno build in simavr behind a pty): hello, state reading, homing,
// a trajectory loaded with credit flow control through the 64-byte window, the gripper.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <thread>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/transport/serial.hpp"
#include "scaratwin/transport/statements.hpp"

extern char** environ;

namespace scaratwin::transport {
namespace {

namespace fs = std::filesystem;
// How long a reply may take in wall-clock time: a guard against a hang, not a judgement (a
// loaded machine slows the paced emulator; 5 s ran out at a load average of 16)
constexpr Duration kWait{30000};

// The emulator as a child process, killed at the end of the test.
struct Emulator {
  pid_t pid = -1;
  fs::path dir;
  fs::path tty;
  // speed: emulated seconds per wall second, 0 = as fast as it goes
  explicit Emulator(const char* speed = "0") {
    char tmpl[] = "/tmp/scaratwin-emu-XXXXXX";
    dir = ::mkdtemp(tmpl);
    tty = dir / "tty";
    std::vector<std::string> args{SCARATWIN_ROBOT_EXE,  "--pty-link", tty.string(),
                                  "--exit-with-parent", "--speed",    speed};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) pid = -1;
  }
  ~Emulator() {
    if (pid > 0) {
      ::kill(pid, SIGTERM);
      int status = 0;
      ::waitpid(pid, &status, 0);
    }
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

// The firmware's hello, asked for as a host asks a board that may still be booting: its
// receiver is off until the firmware has set it up, and what comes before is lost (on a
// real board as in simavr), so one request sent too early is never answered. The hub asks
// every 500 ms (src/hub/hub.cpp); so does this, for up to kWait.
Result<RobotChannel::Reply> greet(RobotChannel& channel) {
  const auto end = std::chrono::steady_clock::now() + kWait;
  for (;;) {
    auto hello = channel.request(protocol::Hello{}, Duration{500});
    if (hello || std::chrono::steady_clock::now() >= end) return hello;
    // the board's bootloader took that hello (the port's open reset it): never answered
    channel.forget_abandoned();
  }
}

TEST(TwinWithFirmware, StatementsAgainstTheEmulatedRobot) {
  auto model = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model) << model.error().message;
  // declared before the link and the channel, whose io thread runs the handler until they
  // are destroyed (see EveryStateReportReachesTheMirrorWhileATrajectoryStreams)
  std::mutex m;
  std::vector<protocol::DeviceEvent> events;
  Emulator emu;
  ASSERT_GT(emu.pid, 0);
  SerialOptions so;
  so.device = emu.tty.string();  // appears when the emulator is up; the link retries
  auto link = SerialLink::create(so);
  ASSERT_TRUE(link);
  ASSERT_TRUE((*link)->wait_connected(Duration{10000})) << "emulator did not come up";
  RobotChannel channel(**link, robot_channel_defaults());
  channel.set_unsolicited_handler([&](protocol::SerialFromDevice&& msg, const RxPacket&) {
    if (auto* ev = std::get_if<protocol::DeviceEvent>(&msg)) {
      std::lock_guard lock(m);
      events.push_back(*ev);
    }
  });
  auto wait_event = [&](protocol::DeviceEventCode code, Duration timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard lock(m);
        for (const auto& e : events) {
          if (e.event == code) return true;
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  };
  TwinOptions to;
  to.reply_timeout = kWait;
  Twin twin(*model, &channel, nullptr, to);

  auto hello = greet(channel);
  ASSERT_TRUE(hello) << hello.error().message;
  ASSERT_TRUE(std::holds_alternative<protocol::PeerHello>(hello->last()));
  // the emulated board was already reporting when the port opened, so the first line may be
  // a cut one (reported and skipped); from here on every line must decode
  const std::uint64_t errors_at_open = channel.decode_errors();
  EXPECT_LE(errors_at_open, 1u);

  auto before = twin.read_physical_joints();
  ASSERT_TRUE(before) << before.error().message;

  auto home = channel.request(protocol::Home{}, kWait);
  ASSERT_TRUE(home) << home.error().message;
  ASSERT_TRUE(wait_event(protocol::DeviceEventCode::kHomed, Duration{30000}));
  auto homed = twin.read_physical_joints();
  ASSERT_TRUE(homed) << homed.error().message;
  EXPECT_TRUE(homed->flags & protocol::state_flags::kHomed);

  const JointVector goal{0.09, deg_to_rad(20), deg_to_rad(-30), deg_to_rad(45)};
  auto plan = plan_quintic(*model, homed->q, goal, QuinticOptions{30, 0.0});
  ASSERT_TRUE(plan) << plan.error().message;
  auto load = twin.load_trajectory(*plan);
  ASSERT_TRUE(load) << load.error().message;
  EXPECT_EQ(load->points, 30);
  EXPECT_GT(load->device_slots, 0);
  ASSERT_TRUE(wait_event(protocol::DeviceEventCode::kTrajectoryDone, Duration{30000}));
  auto after = twin.read_physical_joints();
  ASSERT_TRUE(after) << after.error().message;
  EXPECT_NEAR(after->q[0], goal[0], 2.0 / model->motors.z.steps_per_unit);
  EXPECT_NEAR(after->q[1], goal[1], 2.0 / model->motors.j2.steps_per_unit);
  EXPECT_NEAR(after->q[2], goal[2], 3.0 / model->motors.j3.steps_per_unit);
  EXPECT_NEAR(after->q[3], goal[3], deg_to_rad(0.5));

  auto grip = twin.grip(Robots::kPhysical);
  ASSERT_TRUE(grip) << grip.error().message;
  EXPECT_EQ(channel.decode_errors(), errors_at_open) << channel.last_decode_error();
  EXPECT_EQ(twin.stored_joints().size(), 3u);
}

// The replay case of the demo: a trajectory far longer than the Uno's queue streams through
// credit flow control (QS polls when the credit is used up) at real time, while the mirror
// listens to the periodic reports. Every report the firmware numbers must reach the listener:
// the ones that answer a QS too, and none may be crowded out of the transmit buffer.
TEST(TwinWithFirmware, EveryStateReportReachesTheMirrorWhileATrajectoryStreams) {
  auto model = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model) << model.error().message;
  // what the channel's handler writes into, declared before the link and the channel: their
  // io thread runs the handler until they are destroyed, and they are destroyed first (the
  // other order let a report arrive into freed vectors as the test ended: ASan, CI)
  std::mutex m;
  std::vector<std::uint16_t> seqs;
  std::vector<std::uint32_t> times;
  bool homed = false, done = false;
  Emulator emu("1");
  ASSERT_GT(emu.pid, 0);
  SerialOptions so;
  so.device = emu.tty.string();
  auto link = SerialLink::create(so);
  ASSERT_TRUE(link);
  ASSERT_TRUE((*link)->wait_connected(Duration{10000})) << "emulator did not come up";
  RobotChannel channel(**link, robot_channel_defaults());
  channel.set_unsolicited_handler([&](protocol::SerialFromDevice&& msg, const RxPacket&) {
    std::lock_guard lock(m);
    if (const auto* st = std::get_if<protocol::DeviceState>(&msg)) {
      seqs.push_back(st->seq);
      times.push_back(st->t_us);
    }
    if (const auto* ev = std::get_if<protocol::DeviceEvent>(&msg)) {
      homed = homed || ev->event == protocol::DeviceEventCode::kHomed;
      done = done || ev->event == protocol::DeviceEventCode::kTrajectoryDone;
    }
  });
  auto wait_for = [&](const bool& flag, Duration timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard lock(m);
        if (flag) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  };
  TwinOptions to;
  to.reply_timeout = kWait;
  to.credit_poll = Duration{100};  // as the hub polls
  Twin twin(*model, &channel, nullptr, to);
  ASSERT_TRUE(greet(channel));
  ASSERT_TRUE(channel.request(protocol::Home{}, kWait));
  ASSERT_TRUE(wait_for(homed, Duration{30000})) << "not homed";
  auto start = twin.read_physical_joints();
  ASSERT_TRUE(start) << start.error().message;

  // points of 20 ms over the fastest quintic the motors allow out to a far pose: many times
  // the Uno's queue of 15
  const JointVector goal{0.05, deg_to_rad(60), deg_to_rad(-60), deg_to_rad(90)};
  const double duration_s = std::ceil(quintic_min_duration(*model, start->q, goal) / 0.02) * 0.02;
  const int n = static_cast<int>(std::lround(duration_s / 0.02));
  auto plan = plan_quintic(*model, start->q, goal, QuinticOptions{n, duration_s});
  ASSERT_TRUE(plan) << plan.error().message;
  std::size_t first = 0;
  {
    std::lock_guard lock(m);
    first = seqs.size();
  }
  const std::uint64_t lost_before = channel.lost_packets();
  auto load = twin.load_trajectory(*plan);
  ASSERT_TRUE(load) << load.error().message;
  EXPECT_EQ(load->points, n);
  EXPECT_GT(load->credit_polls, 0) << "the queue never filled: the test does not test the polls";
  ASSERT_TRUE(wait_for(done, Duration{30000})) << "trajectory not done";

  std::lock_guard lock(m);
  ASSERT_GT(seqs.size() - first, static_cast<std::size_t>(duration_s * 80))
      << "100 Hz reports while the trajectory ran";
  int gaps = 0;
  for (std::size_t k = first + 1; k < seqs.size(); ++k) {
    const int step = (seqs[k] - seqs[k - 1] + 65536) % 65536;
    if (step != 1) {
      ++gaps;
      ADD_FAILURE() << "report " << seqs[k - 1] << " followed by " << seqs[k] << ", "
                    << times[k] - times[k - 1] << " us later by the device clock";
    }
  }
  EXPECT_EQ(gaps, 0);
  EXPECT_EQ(channel.lost_packets(), lost_before);
}

}  // namespace
}  // namespace scaratwin::transport
