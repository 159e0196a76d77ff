// bench_scale: how many emulated robots this machine holds at real time. For each N of a list,
// N scaratwin-robot emulators (our firmware in simavr, paced 1x, ideal plant, no camera) are
// started through the hub's robot interface on one shared io thread, as a hub with N robots
// would hold them; each reports at 100 Hz, is homed, then jogs J2 back and forth for the whole
// measurement window (the "moving" case of docs/benchmarks.md). Per robot it measures the
// reports received against the 100 Hz grid, the reports lost (gaps in the ST sequence), the
// real-time factor (the robot's clock advance over the wall time between the window's first
// and last report) and the emulator's CPU (utime + stime from /proc); the bench's own CPU is
// the hub side. One table row per N on stdout, progress on stderr.
//
// Usage: bench_scale [--robots 1,2,3,4,5,6] [--seconds 20] [--exe PATH] [--config FILE]
// Measure on a Release build (cmake --preset release) on a quiet machine.
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/robot_interface.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/protocol/messages.hpp"
#include "scaratwin/transport/channel.hpp"
#include "scaratwin/transport/io_thread.hpp"

namespace fs = std::filesystem;
namespace pr = scaratwin::protocol;
namespace tr = scaratwin::transport;
using scaratwin::RobotInterface;
using std::chrono::milliseconds;

namespace {

constexpr int kReportRateHz = 100;
// J2 jogs of 800 steps (about 48 deg at 945 steps/rad, inside the joint's -105..115 deg from
// home at 0): about 1.5 s each at the firmware's default jog speed and acceleration (1,000
// steps/s, 1,500 steps/s^2), so the motors run nearly all the time and a jog's few
// milliseconds at rest between two moves do not change what the emulator costs.
constexpr double kJogSteps = 800.0;
// A jog acknowledged but not seen moving within this long is sent again.
constexpr std::int64_t kJogStartTimeoutUs = 500'000;
// A refused jog (busy: the last one still decelerating) is retried after this long.
constexpr std::int64_t kJogRetryUs = 50'000;
// Jogging runs this long before the window opens, so that every robot is moving in it.
constexpr milliseconds kWarmUp{1000};

std::int64_t now_us() { return tr::steady_now_us(); }

// What the io thread records of one robot (its unsolicited handler and its jogs' replies),
// read by the main thread under `mu`.
struct RobotStats {
  enum class Jog { kIdle, kAwaitAck, kAwaitMoving, kMoving };

  std::mutex mu;
  // the latest report
  bool have_report = false;
  std::uint32_t flags = 0;
  std::int64_t last_rx_us = 0;
  // homing's outcome (EV 1 or EV 9 with its axis)
  bool homed_event = false;
  int homing_failed_axis = -1;
  // the window [window_begin_us, window_end_us] of the steady clock, and the reports in it
  std::int64_t window_begin_us = std::numeric_limits<std::int64_t>::max();
  std::int64_t window_end_us = std::numeric_limits<std::int64_t>::max();
  std::uint64_t reports = 0;
  std::uint64_t lost = 0;
  std::uint16_t first_seq = 0, last_seq = 0;
  std::uint32_t first_t_us = 0, last_t_us = 0;
  std::int64_t first_rx_us = 0, window_last_rx_us = 0;
  std::int32_t j2_min = 0, j2_max = 0;  // J2 motor steps seen in the window
  // the jog driver: the main thread sends, the io thread follows the reply and the reports
  Jog jog = Jog::kIdle;
  std::int64_t jog_since_us = 0;
  int jog_dir = 1;
  std::uint64_t jogs_done = 0;
  std::uint64_t jog_errors = 0;
  std::string last_jog_error;
};

void on_packet(RobotStats& s, pr::SerialFromDevice&& m, const tr::RxPacket& rx) {
  std::lock_guard<std::mutex> lock(s.mu);
  if (const auto* st = std::get_if<pr::DeviceState>(&m)) {
    s.have_report = true;
    s.flags = st->flags;
    s.last_rx_us = rx.steady_us;
    const bool moving = (st->flags & pr::state_flags::kMoving) != 0;
    if (s.jog == RobotStats::Jog::kAwaitMoving && moving) {
      s.jog = RobotStats::Jog::kMoving;
    } else if (s.jog == RobotStats::Jog::kMoving && !moving) {
      s.jog = RobotStats::Jog::kIdle;
      s.jog_since_us = rx.steady_us;
      s.jog_dir = -s.jog_dir;
      ++s.jogs_done;
    }
    if (rx.steady_us < s.window_begin_us || rx.steady_us > s.window_end_us) return;
    const std::int32_t j2 = st->steps[1];
    if (s.reports == 0) {
      s.first_seq = st->seq;
      s.first_t_us = st->t_us;
      s.first_rx_us = rx.steady_us;
      s.j2_min = s.j2_max = j2;
    } else {
      // docs/protocol.md section 4: a gap is (seq - last - 1) mod 65536
      s.lost += static_cast<std::uint16_t>(st->seq - s.last_seq - 1);
    }
    ++s.reports;
    s.last_seq = st->seq;
    s.last_t_us = st->t_us;
    s.window_last_rx_us = rx.steady_us;
    s.j2_min = std::min(s.j2_min, j2);
    s.j2_max = std::max(s.j2_max, j2);
  } else if (const auto* ev = std::get_if<pr::DeviceEvent>(&m)) {
    if (ev->event == pr::DeviceEventCode::kHomed) s.homed_event = true;
    if (ev->event == pr::DeviceEventCode::kHomingFailed) {
      s.homing_failed_axis = ev->value.value_or(-1);
    }
  }
}

// utime + stime of a process, in seconds, and its parent and name (/proc/<pid>/stat).
struct ProcStat {
  bool ok = false;
  pid_t ppid = 0;
  std::string comm;
  double cpu_s = 0.0;
};

ProcStat read_proc_stat(const std::string& pid) {
  ProcStat p;
  std::ifstream in("/proc/" + pid + "/stat");
  std::string line;
  if (!std::getline(in, line)) return p;
  // the name may hold spaces and parentheses: it ends at the last ')'
  const auto lparen = line.find('('), rparen = line.rfind(')');
  if (lparen == std::string::npos || rparen == std::string::npos || rparen < lparen) return p;
  p.comm = line.substr(lparen + 1, rparen - lparen - 1);
  std::istringstream rest(line.substr(rparen + 1));
  std::vector<std::string> f;
  for (std::string tok; rest >> tok;) f.push_back(tok);
  // fields 3 (state), 4 (ppid), ..., 14 (utime), 15 (stime), counted from 1
  if (f.size() < 13) return p;
  static const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  p.ppid = static_cast<pid_t>(std::stol(f[1]));
  p.cpu_s = static_cast<double>(std::stoull(f[11]) + std::stoull(f[12])) / tick;
  p.ok = true;
  return p;
}

double cpu_s(pid_t pid) { return read_proc_stat(std::to_string(pid)).cpu_s; }

// The child of this process named `comm` (the kernel keeps 15 characters of it) that is not in
// `known`: the robot interface keeps its emulator's pid to itself.
pid_t find_new_child(const std::string& comm, const std::set<pid_t>& known) {
  const pid_t self = getpid();
  const std::string name = comm.substr(0, 15);
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string pid = entry.path().filename().string();
    if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) continue;
    const ProcStat p = read_proc_stat(pid);
    const auto id = static_cast<pid_t>(std::stol(pid));
    if (p.ok && p.ppid == self && p.comm == name && known.count(id) == 0) return id;
  }
  return -1;
}

std::string log_tail(const fs::path& log, std::size_t lines) {
  std::ifstream in(log);
  std::vector<std::string> all;
  for (std::string l; std::getline(in, l);) all.push_back(l);
  std::string out;
  for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) {
    out += "  " + all[i] + "\n";
  }
  return out.empty() ? "  (no output)\n" : out;
}

struct Robot {
  int index = 0;
  std::unique_ptr<RobotInterface> iface;
  bool started = false;  // configure() succeeded: where() is its pty
  pid_t pid = -1;
  fs::path log;
  std::shared_ptr<RobotStats> stats = std::make_shared<RobotStats>();
};

struct Bench {
  fs::path exe;
  fs::path config;
  std::string description;  // the description's hash, checked against each firmware's
  double seconds = 20.0;
  fs::path log_dir;
  std::shared_ptr<tr::IoThread> io;
};

// A robot that cannot be measured ends the run: thrown to main, so that the robots' destructors
// stop every emulator on the way.
struct BenchError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail_robot(const Robot& r, const std::string& what) {
  std::string text =
      fmt::format("robot {}{}: {}", r.index, r.started ? " on " + r.iface->where() : "", what);
  // the interface's start-up errors quote the emulator's last output already
  if (what.find("last output") == std::string::npos) {
    text += fmt::format("\nits log {} ends:\n{}", r.log.string(), log_tail(r.log, 15));
  }
  throw BenchError(text);
}

// Starts robot `index` and brings it to reporting at 100 Hz (the hub's connect(): hello with
// the description's hash, a state query, the report rate).
Robot start_robot(const Bench& b, int index, std::set<pid_t>& known) {
  Robot r;
  r.index = index;
  r.log = b.log_dir / fmt::format("robot-{}.log", index);
  std::error_code ec;
  fs::remove(r.log, ec);
  scaratwin::EmulatedRobotOptions o;
  o.executable = b.exe;
  // no side-channel client reads the true positions here: any free port keeps emulators from
  // colliding on one; no camera, the ideal plant (its figures are in docs/benchmarks.md)
  o.args = {"--speed",     "1", "--plant",  "ideal",           "--camera-port",     "-1",
            "--side-port", "0", "--config", b.config.string(), "--exit-with-parent"};
  o.log = r.log;
  r.iface = scaratwin::emulated_robot(std::move(o));
  if (scaratwin::Status s = r.iface->configure(b.io, milliseconds(10000)); !s) {
    fail_robot(r, "the emulator did not start: " + s.error().message);
  }
  r.started = true;
  r.pid = find_new_child(b.exe.filename().string(), known);
  if (r.pid < 0) fail_robot(r, "its emulator process is not among this process's children");
  known.insert(r.pid);
  auto stats = r.stats;
  r.iface->channel().set_unsolicited_handler(
      [stats](pr::SerialFromDevice&& m, const tr::RxPacket& rx) {
        on_packet(*stats, std::move(m), rx);
      });
  auto& ch = r.iface->channel();
  // the firmware's own hello after reset carries no hash: ask until one answers with it
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (;;) {
    auto hi = ch.request(pr::Hello{pr::kProtocolVersion, {}, {}, b.description, std::nullopt}, milliseconds(500));
    const auto* peer = hi ? std::get_if<pr::PeerHello>(&hi->last()) : nullptr;
    if (peer != nullptr && !peer->description.empty()) {
      if (peer->description != b.description) {
        fail_robot(r, fmt::format("its firmware was built for description {}, {} is {}: build the "
                                  "firmware for it or pass its --config",
                                  peer->description, b.config.string(), b.description));
      }
      break;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      fail_robot(r, "no hello with a description hash within 10 s" +
                        (hi ? std::string{} : ": " + hi.error().message));
    }
  }
  if (auto qs = ch.request(pr::QueryState{}, milliseconds(1000)); !qs) {
    fail_robot(r, "state query: " + qs.error().message);
  }
  auto sr = ch.request(pr::SetReportRate{kReportRateHz}, milliseconds(1000));
  if (!sr) fail_robot(r, "set report rate: " + sr.error().message);
  return r;
}

// Homes every robot at once: HM, then the homed flag in a report after EV 1.
void home_all(std::vector<Robot>& robots) {
  for (Robot& r : robots) {
    if (auto hm = r.iface->channel().request(pr::Home{}, milliseconds(1000)); !hm) {
      fail_robot(r, "home: " + hm.error().message);
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  const std::int64_t asked_us = now_us();
  for (Robot& r : robots) {
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(r.stats->mu);
        const RobotStats& s = *r.stats;
        if (s.homing_failed_axis >= 0) {
          static constexpr const char* kAxis[] = {"Z", "J2", "J3"};
          fail_robot(r, fmt::format("homing failed: no {} endstop",
                                    s.homing_failed_axis < 3 ? kAxis[s.homing_failed_axis] : "?"));
        }
        if (s.homed_event && s.last_rx_us > asked_us && (s.flags & pr::state_flags::kHomed) != 0 &&
            (s.flags & pr::state_flags::kMoving) == 0) {
          break;
        }
      }
      if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(90)) {
        fail_robot(r, "not homed within 90 s");
      }
      std::this_thread::sleep_for(milliseconds(20));
    }
  }
  std::fprintf(stderr, "bench_scale:   homed in %.1f s\n",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

// One pass of the jog driver: a robot at rest after its last jog gets the next one (J2, the
// other way), so that every robot keeps stepping.
void drive_jogs(std::vector<Robot>& robots) {
  const std::int64_t now = now_us();
  for (Robot& r : robots) {
    RobotStats& s = *r.stats;
    double delta = 0.0;
    {
      std::lock_guard<std::mutex> lock(s.mu);
      if (s.jog == RobotStats::Jog::kAwaitMoving && now - s.jog_since_us > kJogStartTimeoutUs) {
        s.jog = RobotStats::Jog::kIdle;  // never seen moving: send it again
        ++s.jog_errors;
        s.last_jog_error = "acknowledged but not seen moving";
      }
      if (s.jog != RobotStats::Jog::kIdle || now - s.jog_since_us < 0) continue;
      s.jog = RobotStats::Jog::kAwaitAck;
      s.jog_since_us = now;
      delta = s.jog_dir * kJogSteps;
    }
    auto stats = r.stats;
    auto on_reply = [stats](scaratwin::Result<tr::RobotChannel::Reply>&& reply) {
      std::lock_guard<std::mutex> lock(stats->mu);
      stats->jog_since_us = now_us();
      if (reply) {
        stats->jog = RobotStats::Jog::kAwaitMoving;
        return;
      }
      stats->jog = RobotStats::Jog::kIdle;
      stats->jog_since_us += kJogRetryUs;  // (a time to come: drive_jogs waits for it)
      ++stats->jog_errors;
      stats->last_jog_error = reply.error().message;
    };
    if (auto posted = r.iface->channel().post(pr::Jog{pr::Axis::kJ2, delta}, on_reply); !posted) {
      fail_robot(r, "jog: " + posted.error().message);
    }
  }
}

struct Row {
  int robots = 0;
  double factor_min = 0.0;
  std::uint64_t received = 0, expected = 0, lost = 0;
  double emulator_cpu_mean = 0.0, bench_cpu = 0.0, total_cpu = 0.0;
  std::uint64_t jogs_min = 0;
  bool all_stepped = true;
};

Row measure(const Bench& b, int n) {
  std::fprintf(stderr, "bench_scale: %d robot%s: starting\n", n, n == 1 ? "" : "s");
  std::set<pid_t> known;
  std::vector<Robot> robots;
  for (int i = 0; i < n; ++i) {
    robots.push_back(start_robot(b, i, known));
    std::fprintf(stderr, "bench_scale:   robot %d on %s (pid %d)\n", i,
                 robots.back().iface->where().c_str(), static_cast<int>(robots.back().pid));
  }
  home_all(robots);

  const auto jog_for = [&](std::chrono::steady_clock::time_point until) {
    while (std::chrono::steady_clock::now() < until) {
      drive_jogs(robots);
      std::this_thread::sleep_for(milliseconds(10));
    }
  };
  jog_for(std::chrono::steady_clock::now() + kWarmUp);

  // the window: reports, jogs and CPU from here to its end
  const auto window = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(b.seconds));
  const auto t0 = std::chrono::steady_clock::now();
  const std::int64_t t0_us = now_us();
  const std::int64_t t1_us = t0_us + static_cast<std::int64_t>(b.seconds * 1e6);
  std::vector<std::uint64_t> jogs_before(robots.size());
  std::vector<double> cpu_before(robots.size());
  for (std::size_t i = 0; i < robots.size(); ++i) {
    std::lock_guard<std::mutex> lock(robots[i].stats->mu);
    robots[i].stats->window_begin_us = t0_us;
    robots[i].stats->window_end_us = t1_us;
    jogs_before[i] = robots[i].stats->jogs_done;
  }
  for (std::size_t i = 0; i < robots.size(); ++i) cpu_before[i] = cpu_s(robots[i].pid);
  const double self_before = cpu_s(getpid());
  std::fprintf(stderr, "bench_scale:   measuring for %.0f s\n", b.seconds);
  for (double next_s = 5.0; next_s < b.seconds; next_s += 5.0) {
    jog_for(t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(next_s)));
    std::string line;
    for (std::size_t i = 0; i < robots.size(); ++i) {
      const RobotStats& s = *robots[i].stats;
      std::lock_guard<std::mutex> lock(robots[i].stats->mu);
      line += fmt::format(" r{}: {} reports, {} lost, {} jogs;", i, s.reports, s.lost,
                          s.jogs_done - jogs_before[i]);
    }
    std::fprintf(stderr, "bench_scale:   %.0f s:%s\n", next_s, line.c_str());
  }
  jog_for(t0 + window);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::vector<double> cpu_after(robots.size());
  for (std::size_t i = 0; i < robots.size(); ++i) cpu_after[i] = cpu_s(robots[i].pid);
  const double self_after = cpu_s(getpid());
  // the last report of the window may still be on its way
  std::this_thread::sleep_for(milliseconds(50));

  Row row;
  row.robots = n;
  row.factor_min = std::numeric_limits<double>::infinity();
  row.jogs_min = std::numeric_limits<std::uint64_t>::max();
  double emulators_cpu_s = 0.0;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    const Robot& r = robots[i];
    std::lock_guard<std::mutex> lock(r.stats->mu);
    const RobotStats& s = *r.stats;
    // the robot's clock is micros() modulo 2^32: the difference modulo 2^32 is its advance
    const double robot_s =
        static_cast<double>(static_cast<std::uint32_t>(s.last_t_us - s.first_t_us)) / 1e6;
    const double rx_s = static_cast<double>(s.window_last_rx_us - s.first_rx_us) / 1e6;
    const double factor = s.reports >= 2 && rx_s > 0.0 ? robot_s / rx_s : 0.0;
    const double cpu = cpu_after[i] - cpu_before[i];
    const std::uint64_t jogs = s.jogs_done - jogs_before[i];
    const bool stepped = s.j2_max - s.j2_min >= static_cast<std::int32_t>(kJogSteps / 2);
    row.factor_min = std::min(row.factor_min, factor);
    row.received += s.reports;
    row.lost += s.lost;
    row.jogs_min = std::min(row.jogs_min, jogs);
    row.all_stepped = row.all_stepped && stepped;
    emulators_cpu_s += cpu;
    std::fprintf(stderr,
                 "bench_scale:   robot %d: %llu reports, %llu lost, factor %.4f, CPU %.1f %%, %llu "
                 "jogs (J2 %d..%d steps), %llu jog retries\n",
                 r.index, static_cast<unsigned long long>(s.reports),
                 static_cast<unsigned long long>(s.lost), factor, 100.0 * cpu / wall_s,
                 static_cast<unsigned long long>(jogs), s.j2_min, s.j2_max,
                 static_cast<unsigned long long>(s.jog_errors));
    if (!s.last_jog_error.empty()) {
      std::fprintf(stderr, "bench_scale:     last jog error: %s\n", s.last_jog_error.c_str());
    }
    if (!stepped) {
      std::fprintf(stderr, "bench_scale:   robot %d did not step in the window (J2 %d..%d)\n",
                   r.index, s.j2_min, s.j2_max);
    }
  }
  row.expected = static_cast<std::uint64_t>(n * kReportRateHz * b.seconds + 0.5);
  row.emulator_cpu_mean = 100.0 * emulators_cpu_s / n / wall_s;
  row.bench_cpu = 100.0 * (self_after - self_before) / wall_s;
  row.total_cpu = 100.0 * (emulators_cpu_s + self_after - self_before) / wall_s;

  for (Robot& r : robots) r.iface->shutdown();
  return row;
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> counts{1, 2, 3, 4, 5, 6};
  double seconds = 20.0;
  std::string exe, config;
  CLI::App app{"bench_scale: how many emulated robots this machine holds at real time"};
  app.add_option("--robots", counts, "numbers of robots to run at once, one table row each")
      ->delimiter(',')
      ->check(CLI::Range(1, 64));
  app.add_option("--seconds", seconds, "measurement window per row (s)")
      ->check(CLI::Range(1.0, 3600.0));
  app.add_option("--exe", exe, "the emulator (default: scaratwin-robot beside this program)");
  app.add_option("--config", config, "robot description (default config/scara.toml)");
  CLI11_PARSE(app, argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);

  Bench b;
  b.seconds = seconds;
  b.exe = exe.empty() ? scaratwin::sibling_executable("scaratwin-robot") : fs::path(exe);
  if (access(b.exe.c_str(), X_OK) != 0) {
    std::fprintf(stderr,
                 "bench_scale: cannot run the emulator '%s' (build scaratwin-robot, or "
                 "pass --exe PATH)\n",
                 b.exe.c_str());
    return 1;
  }
  b.config = config.empty() ? scaratwin::default_robot_config_path() : fs::path(config);
  auto model = scaratwin::load_robot_config(b.config);
  if (!model) {
    std::fprintf(stderr, "bench_scale: %s\n", model.error().message.c_str());
    return 1;
  }
  b.description = scaratwin::description_hash(*model);
  b.log_dir = fs::temp_directory_path() / fmt::format("bench_scale.{}", getpid());
  std::error_code ec;
  fs::create_directories(b.log_dir, ec);
  if (ec) {
    std::fprintf(stderr, "bench_scale: cannot create %s: %s\n", b.log_dir.c_str(),
                 ec.message().c_str());
    return 1;
  }
  b.io = tr::IoThread::create("bench-scale-io");

  std::printf(
      "## emulated robots at real time (%s, paced 1x, ideal plant, reports at %d Hz, "
      "J2 jogging; %.0f s per row; %u cores, load average %s)\n\n",
      b.exe.filename().c_str(), kReportRateHz, seconds, std::thread::hardware_concurrency(),
      load_average().c_str());
  std::printf(
      "| robots | real-time factor (min) | reports received / expected | lost | CPU per emulator "
      "(mean, %% of a core) | bench (hub side) CPU (%%) | total CPU (%% of a core) | added by the "
      "last robot (%%) | jogs per robot (min) | real time |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  bool all_stepped = true;
  double previous_total = 0.0;
  int previous_n = 0;
  for (int n : counts) {
    Row row;
    try {
      row = measure(b, n);
    } catch (const BenchError& e) {
      std::fprintf(stderr,
                   "bench_scale: with %d robot%s: %s\nbench_scale: the emulators' logs are in %s\n",
                   n, n == 1 ? "" : "s", e.what(), b.log_dir.c_str());
      return 1;
    }
    // per robot added when the list skips counts (1,2,4: the last two rows add two)
    const double added = (row.total_cpu - previous_total) / std::max(1, n - previous_n);
    const bool real_time = row.factor_min >= 0.99 && row.lost == 0;
    std::printf("| %d | %.3f | %llu / %llu | %llu | %.0f | %.1f | %.0f | %.0f | %llu | %s |\n", n,
                row.factor_min, static_cast<unsigned long long>(row.received),
                static_cast<unsigned long long>(row.expected),
                static_cast<unsigned long long>(row.lost), row.emulator_cpu_mean, row.bench_cpu,
                row.total_cpu, added, static_cast<unsigned long long>(row.jogs_min),
                !row.all_stepped ? "no (a robot did not step)"
                : real_time      ? "yes"
                                 : "no");
    all_stepped = all_stepped && row.all_stepped;
    previous_total = row.total_cpu;
    previous_n = n;
    std::this_thread::sleep_for(milliseconds(500));  // the last row's emulators are gone
  }
  if (!all_stepped) {
    std::fprintf(stderr, "bench_scale: a robot did not step; its logs are in %s\n",
                 b.log_dir.c_str());
    return 1;
  }
  fs::remove_all(b.log_dir, ec);
  return 0;
}
