// Lost steps from physics, seen while they happen: the emulated robot as built with a driver
// whose current is set too low (0.35 A instead of 1.2 A, a Vref turned down). A J2 move of
// 60 deg at the description's acceleration loses nothing; the operator then hangs 1 kg on the
// tool and the same move at three times the acceleration loses steps on J2 (the pull-out
// torque of the weak driver falls short of what the load's acceleration asks for). The twin's
// camera tracker, which follows the tool's marker through the robot's webcam, raises the
// desync alarm within 200 ms of the tool leaving the virtual robot by more than 2 mm; homing
// again counts the steps the truth says were lost, to within one step. The truth (the
// emulator's side channel) only measures. Figures: docs/physical.md, "Lost steps seen while
// they happen".
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/core/units.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/tool_tracker.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/sim/mjcf.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
const fs::path kBin = SCARATWIN_BIN_DIR;
const char* kCurrentA =
    std::getenv("LOST_STEPS_CURRENT") ? std::getenv("LOST_STEPS_CURRENT") : "0.35";

std::uint64_t mono_us() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec) / 1000ULL;
}

double field(const std::string& line, const char* key) {
  const std::string k = std::string(" ") + key + "=";
  const auto at = line.find(k);
  if (at == std::string::npos) return NAN;
  return std::stod(line.substr(at + k.size()));
}

// The truth at 200 Hz: when (mono; board: the firmware's clock, which starts over at the reset
// the hub's open of the port made), the true tool, J2's lost steps.
struct Truth {
  std::uint64_t mono_us, board_us;
  double x, y;
  long long lost_j2;
};

class TruthProbe {
 public:
  explicit TruthProbe(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    const std::string rate = "rate 200\n";
    ok_ = ok_ && ::send(fd_, rate.data(), rate.size(), 0) == static_cast<ssize_t>(rate.size());
    thread_ = std::thread([this] {
      std::string buf;
      char chunk[8192];
      while (!stop_) {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, 100) != 1) continue;
        const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
        if (n <= 0) break;
        buf.append(chunk, static_cast<std::size_t>(n));
        std::size_t nl;
        while ((nl = buf.find('\n')) != std::string::npos) {
          const std::string line = buf.substr(0, nl);
          buf.erase(0, nl + 1);
          if (line.rfind("TR ", 0) != 0 || line.find("plant=as-built") == std::string::npos) {
            continue;
          }
          std::lock_guard lock(mu_);
          all_.push_back({static_cast<std::uint64_t>(field(line, "mono_us")),
                          static_cast<std::uint64_t>(field(line, "board_us")),
                          field(line, "tool_x_m"), field(line, "tool_y_m"),
                          static_cast<long long>(field(line, "lost_j2"))});
        }
      }
    });
  }
  ~TruthProbe() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  bool ok() const { return ok_; }
  std::vector<Truth> since(std::uint64_t from) const {
    std::lock_guard lock(mu_);
    std::vector<Truth> out;
    for (const Truth& t : all_)
      if (t.mono_us >= from) out.push_back(t);
    return out;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
  std::atomic<bool> stop_{false};
  mutable std::mutex mu_;
  std::vector<Truth> all_;
  std::thread thread_;
};

// One command on the emulator's side channel (the operator), its reply.
std::string side_command(int port, const std::string& line) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string reply;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) {
    const std::string out = "rate 0\n" + line + "\n";
    (void)::send(fd, out.data(), out.size(), 0);
    char c = 0;
    std::string cur;
    while (reply.empty()) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 2000) != 1 || ::recv(fd, &c, 1, 0) != 1) break;
      if (c != '\n') {
        cur.push_back(c);
      } else if (cur.rfind("OK " + line, 0) == 0 || cur.rfind("ERR", 0) == 0) {
        reply = cur;
      } else {
        cur.clear();
      }
    }
  }
  ::close(fd);
  return reply;
}

// Every report of the hub, by the robot's clock, for the virtual tool at a truth instant.
class ReportLog {
 public:
  explicit ReportLog(Hub& hub) : hub_(hub) {
    thread_ = std::thread([this] {
      std::uint32_t last = 0;
      while (!stop_) {
        const PhysicalState ps = hub_.physical();
        if (ps.valid && ps.raw.t_us != last) {
          last = ps.raw.t_us;
          std::lock_guard lock(mu_);
          log_.emplace_back(ps.raw.t_us, ps.q);
        }
        std::this_thread::sleep_for(1ms);
      }
    });
  }
  ~ReportLog() {
    stop_ = true;
    thread_.join();
  }
  // the virtual robot's tool at robot time t (interpolated), if reports bracket it
  std::optional<std::array<double, 2>> tool_at(const RobotModel& m, std::uint64_t board_us) const {
    std::lock_guard lock(mu_);
    const auto t = static_cast<std::uint32_t>(board_us);
    for (std::size_t i = 1; i < log_.size(); ++i) {
      const auto span = static_cast<std::int32_t>(log_[i].first - log_[i - 1].first);
      const auto off = static_cast<std::int32_t>(t - log_[i - 1].first);
      if (span <= 0 || off < 0 || off > span || span > 50000) continue;
      const double w = static_cast<double>(off) / span;
      JointVector q{};
      for (int j = 0; j < kNumJoints; ++j) {
        q[j] = log_[i - 1].second[j] + w * (log_[i].second[j] - log_[i - 1].second[j]);
      }
      const ToolPose p = forward(m, q);
      return std::array<double, 2>{p.x_m, p.y_m};
    }
    return std::nullopt;
  }

 private:
  Hub& hub_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mu_;
  std::vector<std::pair<std::uint32_t, JointVector>> log_;
  std::thread thread_;
};

TEST(LostSteps, SeenByTheCameraWithinTwoHundredMillisecondsAndCountedByHoming) {
  const fs::path dir = fs::temp_directory_path() / ("scaratwin-lost-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  // the description with the driver's current turned down
  {
    std::ifstream in(SCARATWIN_CONFIG_FILE);
    std::stringstream ss;
    ss << in.rdbuf() << "\n[drive]\ncurrent_a = " << kCurrentA << "\n";
    std::ofstream(dir / "weak.toml") << ss.str();
  }
  auto model = load_robot_config(dir / "weak.toml");
  ASSERT_TRUE(model.ok()) << model.error().message;
  const fs::path pty = dir / "robot.pty";
  auto robot = ChildProcess::start(
      kBin / "scaratwin-robot",
      {"--pty-link", pty.string(), "--config", (dir / "weak.toml").string()}, dir / "robot.log");
  ASSERT_TRUE(robot);
  auto sim = ChildProcess::start(
      kBin / "scaratwin-sim", {"--port", "0", "--http-port", "0", "--no-camera"}, dir / "sim.log");
  ASSERT_TRUE(sim);
  auto side = (*robot)->wait_for_line("side channel: ", 60s);
  ASSERT_TRUE(side) << side.error().message;
  auto camera = (*robot)->wait_for_line("camera: ", 10s);
  ASSERT_TRUE(camera) << camera.error().message;
  auto listening = (*sim)->wait_for_line("listening on", 60s);
  ASSERT_TRUE(listening);
  const size_t paren = listening->find(" (");
  const size_t colon = listening->rfind(':', paren);
  HubOptions ho;
  ho.serial_device = pty.string();
  // points 50 ms apart: the Uno's 15-point queue then runs 750 ms ahead of the host. At the
  // hub's default 20 ms (300 ms ahead) a busy machine starved the robot (EV 5, queue underrun,
  // in 3 of 5 runs at a load average of 7-10 on 2 cores): the motors then stop dead from
  // speed and start again, and such a stop loses steps of its own.
  ho.min_point_dt_s = 0.05;
  ho.sim_port =
      static_cast<std::uint16_t>(std::stoi(listening->substr(colon + 1, paren - colon - 1)));
  // the hub may plan up to three times the description's acceleration (it checks what it
  // sends against its model's limits)
  RobotModel fast = *model;
  fast.motors.z.max_accel_steps_s2 *= 3;
  fast.motors.j2.max_accel_steps_s2 *= 3;
  fast.motors.j3.max_accel_steps_s2 *= 3;
  auto hub = Hub::connect(fast, ho, nullptr);
  ASSERT_TRUE(hub) << hub.error().message;
  const int side_port = std::stoi(side->substr(side->rfind(':') + 1));
  TruthProbe truth(side_port);
  ASSERT_TRUE(truth.ok());
  ASSERT_TRUE((*hub)->home());
  // its thread reads the hub: it ends before the hub does (below)
  std::optional<ReportLog> reports;
  reports.emplace(**hub);
  auto lost_now = [&] {
    std::this_thread::sleep_for(100ms);
    auto t = truth.since(0);
    return t.empty() ? 0LL : t.back().lost_j2;
  };
  std::printf("after homing: J2 lost %lld\n", lost_now());

  TrackerOptions to;
  to.port = static_cast<std::uint16_t>(std::stoi(camera->substr(camera->rfind(':') + 1)));
  auto tracker = ToolTracker::start(**hub, to);
  ASSERT_TRUE(tracker) << tracker.error().message;

  const JointVector home = (*hub)->physical().q;
  JointVector out = home;
  out[1] = deg_to_rad(60.0);
  auto move = [&](const RobotModel& m, const JointVector& a, const JointVector& b) {
    auto t = plan_trapezoid(m, a, b);
    EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
    auto n = (*hub)->run_trajectory(*t);
    EXPECT_TRUE(n.ok()) << (n.ok() ? "" : n.error().message);
  };
  // learn the camera while the robot is trusted (the description's limits), then judge
  (*tracker)->set_learning(true);
  move(*model, home, out);
  move(*model, out, home);
  (*tracker)->set_learning(false);
  ASSERT_TRUE((*tracker)->fit());
  std::printf("after learning: J2 lost %lld\n", lost_now());

  // the same move at the description's acceleration: nothing lost, no alarm
  const std::uint64_t calm_from = mono_us();
  move(*model, home, out);
  move(*model, out, home);
  std::this_thread::sleep_for(300ms);
  {
    double worst = 0.0, sum = 0.0;
    int n = 0;
    for (const auto& smp : (*tracker)->samples()) {
      if (smp.mono_us < calm_from || !smp.seen) continue;
      worst = std::max(worst, smp.offset_m);
      sum += smp.offset_m;
      ++n;
    }
    std::printf("calm: %d frames judged, camera vs virtual mean %.2f mm, worst %.2f mm\n", n,
                n ? 1000 * sum / n : 0.0, 1000 * worst);
  }
  EXPECT_EQ((*tracker)->alarms(), 0);
  auto calm = truth.since(calm_from);
  ASSERT_FALSE(calm.empty());
  EXPECT_EQ(calm.back().lost_j2, 0);
  // the twin's uncalibrated error along the calm move: what "off" is measured from
  double calm_worst = 0.0;
  for (const Truth& t : calm) {
    if (auto v = reports->tool_at(*model, t.board_us)) {
      calm_worst = std::max(calm_worst, std::hypot(t.x - (*v)[0], t.y - (*v)[1]));
    }
  }

  // now the operator hangs 1 kg on the tool (the issue's "the same move with the payload and
  // 3x the acceleration"; the calm move and the learning run without it: with 1 kg the weak
  // driver's load angle and the arm's wobble alone take the tool 2-4 mm off the virtual robot
  // at the description's acceleration, and homing with it would slip at the switches, the
  // weak driver cannot stop the heavy arm at once)
  ASSERT_EQ(side_command(side_port, "payload 1.0").rfind("OK", 0), 0u);
  std::this_thread::sleep_for(300ms);
  // three times the acceleration (the firmware's limit raised with CF 2)
  ASSERT_TRUE((*hub)->set_setting(2, static_cast<int>(fast.motors.j2.max_accel_steps_s2)));
  const std::uint64_t fast_from = mono_us();
  move(fast, home, out);
  std::this_thread::sleep_for(500ms);
  auto wild = truth.since(fast_from);
  ASSERT_FALSE(wild.empty());
  const long long lost = wild.back().lost_j2;
  EXPECT_NE(lost, 0) << "the weak driver should have lost steps at 3x the acceleration";
  // when the true tool first left the virtual one by 2 mm more than the calm run's worst
  std::optional<std::uint64_t> off_at;
  for (const Truth& t : wild) {
    auto v = reports->tool_at(*model, t.board_us);
    if (v && std::hypot(t.x - (*v)[0], t.y - (*v)[1]) > calm_worst + 0.002) {
      off_at = t.mono_us;
      break;
    }
  }
  ASSERT_TRUE(off_at.has_value());
  ASSERT_GE((*tracker)->alarms(), 1);
  const auto alarm = (*tracker)->first_alarm_mono_us();
  ASSERT_TRUE(alarm.has_value());
  const double delay_ms = (static_cast<double>(*alarm) - static_cast<double>(*off_at)) / 1000.0;
  EXPECT_LE(delay_ms, 200.0) << "the camera saw the tool off " << delay_ms << " ms late";
  std::printf(
      "lost %lld J2 steps; the tool left the virtual robot at +%.0f ms, the camera's "
      "alarm came %.0f ms later (%llu frames)\n",
      lost, (static_cast<double>(*off_at) - static_cast<double>(fast_from)) / 1000.0, delay_ms,
      static_cast<unsigned long long>((*tracker)->frames()));

  // homing again counts what the truth says was lost, to within one step; the operator takes
  // the mass off first
  ASSERT_TRUE((*hub)->set_setting(2, static_cast<int>(model->motors.j2.max_accel_steps_s2)));
  ASSERT_EQ(side_command(side_port, "payload 0").rfind("OK", 0), 0u);
  ASSERT_TRUE((*hub)->home());
  const HomingCheck hc = (*hub)->last_homing();
  ASSERT_TRUE(hc.measured);
  EXPECT_NEAR(std::abs(hc.offset_steps[1]), static_cast<double>(std::llabs(lost)), 1.0)
      << "homing found " << hc.offset_steps[1] << " J2 steps, the truth " << lost;
  reports.reset();
  tracker->reset();
  hub->reset();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace scaratwin
