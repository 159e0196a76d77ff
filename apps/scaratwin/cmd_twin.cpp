// The control statements at the command line (`scaratwin move X Y Z`, `grip`, `spawn red X Y`,
// `mirror --seconds N`, ...) and `scaratwin run FILE`, against a running simulator and robot.
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "commands.hpp"
#include "hub_session.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/runner.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin::cli {
namespace {

struct StatementArgs {
  std::string name;
  std::vector<std::string> words;
  std::string file;
  double seconds = 5.0;
};

// Ctrl-C (SIGINT) and SIGTERM while a hub runs: the first stops the robot and fails the
// statement in progress (Hub::interrupt(), exit status 130); a second one, or one before the
// hub is connected, ends the process at once. The signals are blocked in every thread and
// taken by a watcher thread with sigtimedwait(), so the stop runs as ordinary code.
constexpr int kExitInterrupted = 130;

class InterruptWatcher {
 public:
  InterruptWatcher() {
    sigemptyset(&set_);
    sigaddset(&set_, SIGINT);
    sigaddset(&set_, SIGTERM);
    // before the hub's threads start, so that they inherit the mask
    pthread_sigmask(SIG_BLOCK, &set_, &old_);
    thread_ = std::thread([this] { watch(); });
  }
  ~InterruptWatcher() {
    done_ = true;
    thread_.join();
    pthread_sigmask(SIG_SETMASK, &old_, nullptr);
  }
  InterruptWatcher(const InterruptWatcher&) = delete;
  InterruptWatcher& operator=(const InterruptWatcher&) = delete;

  void attach(Hub* hub) { hub_ = hub; }
  void detach() { hub_ = nullptr; }
  bool fired() const { return fired_; }

 private:
  void watch() {
    const timespec tick{0, 100'000'000};
    while (!done_) {
      const int sig = sigtimedwait(&set_, nullptr, &tick);
      if (sig < 0) continue;
      Hub* hub = hub_;
      if (hub == nullptr || fired_) _exit(kExitInterrupted);
      fired_ = true;
      std::fprintf(stderr, "scaratwin: interrupted: stopping the robot\n");
      hub->interrupt();
    }
  }

  sigset_t set_{};
  sigset_t old_{};
  std::atomic<Hub*> hub_{nullptr};
  std::atomic<bool> done_{false};
  std::atomic<bool> fired_{false};
  std::thread thread_;
};

}  // namespace

void add_link_options(CLI::App& cmd, LinkArgs& l) {
  cmd.add_option("--serial", l.serial,
                 "serial port of the robot (a board's /dev/ttyACM0, or the pty that "
                 "`scaratwin robot` prints); default: $SCARATWIN_SERIAL");
  cmd.add_option("--sim", l.sim, "simulator address HOST:PORT")->capture_default_str();
  cmd.add_option("--sim-token", l.sim_token,
                 "the simulator's access token, when it listens beyond this machine; "
                 "default: $SCARATWIN_TOKEN");
  cmd.add_option("--db", l.db, "twin database to record into")->capture_default_str();
  cmd.add_flag("--no-db", l.no_db, "record nothing");
  cmd.add_option("--workcell", l.workcell,
                 "a workcell file: several robots around one scene (docs/workcell.md); "
                 "default: the one robot of --config");
  cmd.add_option("--robot", l.robot,
                 "which of the workcell's robots this is (its name); default: the only one");
}

namespace {

// The robot the command drives: its instance in the workcell (--workcell, or the one robot of
// --config) and its index there, which the packets to the simulator carry (protocol v2).
struct ChosenRobot {
  RobotInstance instance;
  int index = 0;
};

Result<ChosenRobot> choose_robot(const CommonOptions& common, const LinkArgs& l) {
  Workcell cell;
  if (!l.workcell.empty()) {
    if (!common.config_path.empty()) {
      return Error{error_code(ConfigError::kInvalid),
                   "--config and --workcell: give one (the workcell file names each robot's "
                   "description)"};
    }
    auto w = load_workcell_config(l.workcell);
    if (!w) return w.error();
    cell = std::move(*w);
  } else {
    auto model = load_model(common);
    if (!model) return Error{error_code(ConfigError::kInvalid), ""};  // load_model said why
    cell = single_robot_workcell(*model);
    cell.robots[0].description_file =
        common.config_path.empty() ? default_robot_config_path().string() : common.config_path;
  }
  int index = 0;
  if (!l.robot.empty()) {
    auto k = robot_index(cell, l.robot);
    if (!k) return k.error();
    index = *k;
  } else if (cell.robots.size() > 1) {
    return Error{error_code(ConfigError::kUnknownRobot),
                 fmt::format("{} has {} robots ({}): say which one with --robot NAME", l.workcell,
                             cell.robots.size(), robot_names(cell))};
  }
  // the robot's own view: the scene in its base frame (cube positions are the robot's)
  RobotInstance chosen = cell.robots[static_cast<std::size_t>(index)];
  chosen.model = scene_in_base(cell, index);
  return ChosenRobot{std::move(chosen), index};
}

}  // namespace

int with_hub(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
             const std::string& label, const std::function<Status(Hub&)>& body) {
  auto chosen = choose_robot(common, l);
  if (!chosen) {
    if (!chosen.error().message.empty()) {
      std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), chosen.error().message.c_str());
    }
    return kExitUsage;
  }
  const RobotModel& model = chosen->instance.model;
  HubOptions o;
  o.sim_robot = chosen->index;
  o.base = chosen->instance.base;
  o.report_rate_hz = l.report_hz;
  o.serial_device = l.serial;
  if (o.serial_device.empty()) {
    if (const char* env = std::getenv("SCARATWIN_SERIAL")) o.serial_device = env;
  }
  if (o.serial_device.empty()) {
    std::fprintf(stderr,
                 "scaratwin %s: no robot: pass --serial DEVICE or set SCARATWIN_SERIAL "
                 "(start one with `scaratwin robot`)\n",
                 kind.c_str());
    return kExitUsage;
  }
  const size_t colon = l.sim.rfind(':');
  int port = 0;
  try {
    port = colon == std::string::npos ? 0 : std::stoi(l.sim.substr(colon + 1));
  } catch (...) {
  }
  if (colon == std::string::npos || port <= 0 || port > 65535) {
    std::fprintf(stderr, "scaratwin %s: --sim '%s': expected HOST:PORT\n", kind.c_str(),
                 l.sim.c_str());
    return kExitUsage;
  }
  o.sim_host = l.sim.substr(0, colon);
  o.sim_port = static_cast<std::uint16_t>(port);
  o.sim_token = l.sim_token;
  o.description_source = chosen->instance.description_file;
  // stop acts on the robot alone, so it may run while another hub controls the simulator
  if (kind == "stop") o.sim_role = "observe";
  if (o.sim_token.empty()) {
    if (const char* env = std::getenv("SCARATWIN_TOKEN"); env != nullptr) o.sim_token = env;
  }
  std::unique_ptr<TwinDb> db;
  if (!l.no_db) {
    auto d = TwinDb::open(l.db);
    if (!d) {
      std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), d.error().message.c_str());
      return kExitUsage;
    }
    db = std::move(*d);
  }
  InterruptWatcher watcher;
  auto hub = Hub::connect(model, o, db.get());
  if (!hub) {
    std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), hub.error().message.c_str());
    return kExitFailure;
  }
  watcher.attach(hub->get());
  (void)(*hub)->begin_run(kind, label);
  if (o.sim_role != "observe") (*hub)->set_mirror(true);
  Status s = body(**hub);
  (void)(*hub)->end_run(s.ok());
  watcher.detach();
  if (!s) {
    std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), s.error().message.c_str());
    return watcher.fired() ? kExitInterrupted : kExitFailure;
  }
  return kExitOk;
}

namespace {

void print_result(const Statement& st, const std::string& result) {
  if (st.line > 0) {
    fmt::print("{:>4}  {:<36} {}\n", st.line, st.source, result);
  } else {
    fmt::print("{}\n", result);
  }
  std::fflush(stdout);
}

int run_statement(const CommonOptions& common, const LinkArgs& l, const StatementArgs& a) {
  std::string text = a.name;
  for (const std::string& w : a.words) text += " " + w;
  if (a.name == "mirror") text = fmt::format("mirror {}", a.seconds);
  auto st = parse_statement(text, 0);
  if (!st) {
    std::fprintf(stderr, "scaratwin %s: %s\n", a.name.c_str(), st.error().message.c_str());
    return kExitUsage;
  }
  return with_hub(common, l, a.name, text,
                  [&](Hub& hub) { return execute(hub, *st, print_result); });
}

int run_file(const CommonOptions& common, const LinkArgs& l, const StatementArgs& a) {
  std::ifstream in(a.file);
  if (!in) {
    std::fprintf(stderr, "scaratwin run: cannot read '%s'\n", a.file.c_str());
    return kExitUsage;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  // parse everything first: a script with a syntax error moves nothing.
  auto script = parse_script(ss.str(), a.file);
  if (!script) {
    std::fprintf(stderr, "scaratwin run: %s\n", script.error().message.c_str());
    return kExitUsage;
  }
  return with_hub(common, l, "script", a.file,
                  [&](Hub& hub) { return run_script(hub, *script, a.file, print_result); });
}

}  // namespace

void add_statement_commands(CLI::App& app, CommonOptions& common, Runner& run) {
  auto links = std::make_shared<LinkArgs>();
  struct Spec {
    const char* name;
    const char* help;
    const char* args;
  };
  static constexpr Spec kSpecs[] = {
      {"home", "home the physical robot against its endstops", nullptr},
      {"stop", "stop the physical robot at once (halted until the next home or motion)", nullptr},
      {"move", "move the tool to X Y Z (m) [YAW (deg)]; the virtual robot follows", "X Y Z [YAW]"},
      {"line", "move the tool in a straight line to X Y Z (m) [YAW (deg)]", "X Y Z [YAW]"},
      {"movej", "move the joints to D1 (m) Q2 Q3 Q4 (deg)", "D1 Q2 Q3 Q4"},
      {"grip", "close the gripper", nullptr},
      {"release", "open the gripper", nullptr},
      {"shoot", "take a camera picture [FILE.png]", "[FILE]"},
      {"spawn", "spawn a cube in the virtual scene: red|green|blue X Y (m)", "COLOR X Y"},
      {"reset", "remove every cube from the virtual scene", nullptr},
      {"pick", "pick cube ID and place it in the tray of its colour", "ID"},
      {"sort", "camera shot, colour recognition, sort every cube into its tray", nullptr},
  };
  for (const Spec& s : kSpecs) {
    auto a = std::make_shared<StatementArgs>();
    a->name = s.name;
    CLI::App* cmd = app.add_subcommand(s.name, s.help);
    cmd->group("Statements");
    if (s.args != nullptr) {
      cmd->add_option("args", a->words, s.args)->allow_extra_args();
    }
    add_link_options(*cmd, *links);
    add_common_options(*cmd, common, false);
    cmd->callback([&common, &run, links, a] {
      run = [&common, links, a] { return run_statement(common, *links, *a); };
    });
  }
  auto m = std::make_shared<StatementArgs>();
  m->name = "mirror";
  CLI::App* mirror = app.add_subcommand(
      "mirror",
      "mirror the physical robot in the virtual one for a while; prints latency and loss");
  mirror->group("Statements");
  mirror->add_option("--seconds", m->seconds, "how long")->capture_default_str();
  add_link_options(*mirror, *links);
  // at 115200 baud the serial line carries up to 300 reports a second without loss
  // (docs/benchmarks.md, "Physical link"); the firmware takes 0..1000
  mirror
      ->add_option("--report-hz", links->report_hz,
                   "the robot's state reports per second, each one a mirrored frame")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  add_common_options(*mirror, common, false);
  mirror->callback([&common, &run, links, m] {
    run = [&common, links, m] { return run_statement(common, *links, *m); };
  });

  auto f = std::make_shared<StatementArgs>();
  CLI::App* file = app.add_subcommand(
      "run", "run a script of statements (one per line; see docs); stops at the first error");
  file->add_option("file", f->file, "script file")->required();
  add_link_options(*file, *links);
  add_common_options(*file, common, false);
  file->callback([&common, &run, links, f] {
    run = [&common, links, f] { return run_file(common, *links, *f); };
  });
}

}  // namespace scaratwin::cli
