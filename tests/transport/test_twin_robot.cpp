// The control statements against the real firmware running in the emulator
// (scaratwin-robot: the Uno build in simavr behind a pty): hello, state reading, homing,
// a trajectory loaded with credit flow control through the 64-byte window, the gripper.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

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
constexpr Duration kWait{5000};

// The emulator as a child process, killed at the end of the test.
struct Emulator {
  pid_t pid = -1;
  fs::path dir;
  fs::path tty;
  Emulator() {
    char tmpl[] = "/tmp/scaratwin-emu-XXXXXX";
    dir = ::mkdtemp(tmpl);
    tty = dir / "tty";
    std::vector<std::string> args{SCARATWIN_ROBOT_EXE,  "--pty-link", tty.string(),
                                  "--exit-with-parent", "--speed",    "0"};
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

TEST(TwinWithFirmware, StatementsAgainstTheEmulatedRobot) {
  auto model = load_robot_config(SCARATWIN_CONFIG_FILE);
  ASSERT_TRUE(model) << model.error().message;
  Emulator emu;
  ASSERT_GT(emu.pid, 0);
  SerialOptions so;
  so.device = emu.tty.string();  // appears when the emulator is up; the link retries
  auto link = SerialLink::create(so);
  ASSERT_TRUE(link);
  ASSERT_TRUE((*link)->wait_connected(Duration{10000})) << "emulator did not come up";
  RobotChannel channel(**link, robot_channel_defaults());
  std::mutex m;
  std::vector<protocol::DeviceEvent> events;
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

  auto hello = channel.request(protocol::Hello{}, kWait);
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

}  // namespace
}  // namespace scaratwin::transport
