// The links of the commands that hold a hub, and the hub sessions themselves: which robots of
// the workcell a command drives, each one's link options and database, connect, record, Ctrl-C.
#include "hub_session.hpp"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin::cli {
namespace {

namespace fs = std::filesystem;

// Ctrl-C (SIGINT) and SIGTERM while hubs run: the first stops every robot and fails the
// statements in progress (Hub::interrupt(), exit status 130); a second one, or one before the
// hubs are connected, ends the process at once. The signals are blocked in every thread and
// taken by a watcher thread with sigtimedwait(), so the stop runs as ordinary code.
constexpr int kExitInterrupted = 130;

class InterruptWatcher {
 public:
  InterruptWatcher() {
    sigemptyset(&set_);
    sigaddset(&set_, SIGINT);
    sigaddset(&set_, SIGTERM);
    // before the hubs' threads start, so that they inherit the mask
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

  void attach(std::vector<Hub*> hubs) {
    std::lock_guard<std::mutex> lock(mu_);
    hubs_ = std::move(hubs);
  }
  void detach() {
    std::lock_guard<std::mutex> lock(mu_);
    hubs_.clear();
  }
  bool fired() const { return fired_; }

 private:
  void watch() {
    const timespec tick{0, 100'000'000};
    while (!done_) {
      const int sig = sigtimedwait(&set_, nullptr, &tick);
      if (sig < 0) continue;
      std::lock_guard<std::mutex> lock(mu_);
      if (hubs_.empty() || fired_) _exit(kExitInterrupted);
      fired_ = true;
      std::fprintf(stderr, "scaratwin: interrupted: stopping the robot%s\n",
                   hubs_.size() > 1 ? "s" : "");
      for (Hub* hub : hubs_) hub->interrupt();
    }
  }

  sigset_t set_{};
  sigset_t old_{};
  std::mutex mu_;
  std::vector<Hub*> hubs_;
  std::atomic<bool> done_{false};
  std::atomic<bool> fired_{false};
  std::thread thread_;
};

// The workcell the command works in: --workcell, or the one robot of --config.
Result<Workcell> load_cell(const CommonOptions& common, const LinkArgs& l) {
  if (!l.workcell.empty()) {
    if (!common.config_path.empty()) {
      return Error{error_code(ConfigError::kInvalid),
                   "--config and --workcell: give one (the workcell file names each robot's "
                   "description)"};
    }
    return load_workcell_config(l.workcell);
  }
  auto model = load_model(common);
  if (!model) return Error{error_code(ConfigError::kInvalid), ""};  // load_model said why
  Workcell cell = single_robot_workcell(*model);
  cell.robots[0].description_file =
      common.config_path.empty() ? default_robot_config_path().string() : common.config_path;
  return cell;
}

// The robots the command drives (indices into the cell): the one of --robot, the only one, or
// with `every` all of them.
Result<std::vector<int>> chosen_robots(const Workcell& cell, const LinkArgs& l, bool every) {
  if (!l.robot.empty()) {
    auto k = robot_index(cell, l.robot);
    if (!k) return k.error();
    return std::vector<int>{*k};
  }
  if (cell.robots.size() > 1 && !every) {
    return Error{error_code(ConfigError::kUnknownRobot),
                 fmt::format("{} has {} robots ({}): say which one with --robot NAME", l.workcell,
                             cell.robots.size(), robot_names(cell))};
  }
  std::vector<int> all;
  for (std::size_t i = 0; i < cell.robots.size(); ++i) all.push_back(static_cast<int>(i));
  return all;
}

// Each chosen robot's serial port: with one robot, --serial DEVICE (or $SCARATWIN_SERIAL);
// with several, --serial NAME=DEVICE once for each.
Result<std::vector<std::string>> serial_ports(const Workcell& cell, const std::vector<int>& chosen,
                                              const LinkArgs& l, const std::string& kind) {
  const int invalid = error_code(ConfigError::kInvalid);
  if (chosen.size() == 1) {
    const std::string& name = cell.robots[static_cast<std::size_t>(chosen[0])].name;
    if (l.serial.size() > 1) {
      return Error{invalid, fmt::format("--serial given {} times: this command drives one "
                                        "robot ('{}')",
                                        l.serial.size(), name)};
    }
    std::string device = l.serial.empty() ? std::string() : l.serial[0];
    // NAME=DEVICE naming this very robot is accepted too
    if (device.rfind(name + "=", 0) == 0) device = device.substr(name.size() + 1);
    if (device.empty()) {
      if (const char* env = std::getenv("SCARATWIN_SERIAL")) device = env;
    }
    if (device.empty()) {
      return Error{invalid,
                   "no robot: pass --serial DEVICE or set SCARATWIN_SERIAL (start one with "
                   "`scaratwin robot`)"};
    }
    return std::vector<std::string>{device};
  }
  std::map<int, std::string> by_robot;
  std::map<std::string, int> by_device;
  for (const std::string& given : l.serial) {
    const size_t eq = given.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == given.size()) {
      return Error{invalid,
                   fmt::format("--serial '{}': this {} drives {} robots ({}); give each one's "
                               "port as --serial NAME=DEVICE",
                               given, kind, chosen.size(), robot_names(cell))};
    }
    auto k = robot_index(cell, given.substr(0, eq));
    if (!k) return Error{invalid, "--serial '" + given + "': " + k.error().message};
    const std::string device = given.substr(eq + 1);
    const std::string& name = cell.robots[static_cast<std::size_t>(*k)].name;
    if (by_robot.count(*k) != 0) {
      return Error{invalid, fmt::format("--serial names robot '{}' twice", name)};
    }
    if (auto other = by_device.find(device); other != by_device.end()) {
      return Error{
          invalid,
          fmt::format("--serial: robots '{}' and '{}' are both on {}; each robot has a "
                      "port of its own",
                      cell.robots[static_cast<std::size_t>(other->second)].name, name, device)};
    }
    by_robot[*k] = device;
    by_device[device] = *k;
  }
  std::vector<std::string> ports;
  for (const int k : chosen) {
    auto it = by_robot.find(k);
    if (it == by_robot.end()) {
      const std::string& name = cell.robots[static_cast<std::size_t>(k)].name;
      return Error{invalid, fmt::format("no serial port for robot '{}': pass --serial "
                                        "{}=DEVICE (one for each of {})",
                                        name, name, robot_names(cell))};
    }
    ports.push_back(it->second);
  }
  return ports;
}

// One robot's session as the command opens it.
struct RobotLink {
  std::string name;
  RobotModel model;  // its description, the scene in its base frame
  HubOptions options;
  std::string db;  // empty: record nothing
};

Result<std::vector<RobotLink>> robot_links(const CommonOptions& common, const LinkArgs& l,
                                           const std::string& kind, bool every) {
  auto cell = load_cell(common, l);
  if (!cell) return cell.error();
  auto chosen = chosen_robots(*cell, l, every);
  if (!chosen) return chosen.error();
  auto ports = serial_ports(*cell, *chosen, l, kind);
  if (!ports) return ports.error();
  const auto sim = parse_host_port(l.sim);
  if (!sim) {
    return Error{error_code(ConfigError::kInvalid),
                 fmt::format("--sim '{}': expected HOST:PORT (a port of 1..65535)", l.sim)};
  }
  std::string token = l.sim_token;
  if (token.empty()) {
    if (const char* env = std::getenv("SCARATWIN_TOKEN"); env != nullptr) token = env;
  }
  std::vector<RobotLink> links;
  for (std::size_t n = 0; n < chosen->size(); ++n) {
    const int index = (*chosen)[n];
    const RobotInstance& instance = cell->robots[static_cast<std::size_t>(index)];
    RobotLink link;
    link.name = instance.name;
    // the robot's own view: the scene in its base frame (cube positions are the robot's)
    link.model = scene_in_base(*cell, index);
    HubOptions& o = link.options;
    o.sim_robot = index;
    o.base = instance.base;
    o.report_rate_hz = l.report_hz;
    o.serial_device = (*ports)[n];
    o.sim_host = sim->host;
    o.sim_port = sim->port;
    o.sim_token = token;
    o.description_source = instance.description_file;
    if (chosen->size() > 1) o.log_name = instance.name;  // says which robot a message is of
    // stop acts on the robot alone, so it may run while another hub controls the simulator
    if (kind == "stop") o.sim_role = "observe";
    if (!l.no_db) {
      // several robots: one database each, twin-left.db beside --db's twin.db
      fs::path db = l.db;
      if (chosen->size() > 1) {
        db = db.parent_path() /
             fmt::format("{}-{}{}", db.stem().string(), instance.name, db.extension().string());
      }
      link.db = db.string();
    }
    links.push_back(std::move(link));
  }
  return links;
}

int run_hubs(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
             const std::string& label, bool every,
             const std::function<Status(const std::vector<NamedHub>&)>& body) {
  auto links = robot_links(common, l, kind, every);
  if (!links) {
    if (!links.error().message.empty()) {
      std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), links.error().message.c_str());
    }
    return kExitUsage;
  }
  std::vector<std::unique_ptr<TwinDb>> dbs;
  for (const RobotLink& link : *links) {
    if (link.db.empty()) {
      dbs.push_back(nullptr);
      continue;
    }
    auto d = TwinDb::open(link.db);
    if (!d) {
      std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), d.error().message.c_str());
      return kExitUsage;
    }
    dbs.push_back(std::move(*d));
  }
  InterruptWatcher watcher;
  std::vector<std::unique_ptr<Hub>> hubs;
  std::vector<NamedHub> named;
  for (std::size_t i = 0; i < links->size(); ++i) {
    const RobotLink& link = (*links)[i];
    auto hub = Hub::connect(link.model, link.options, dbs[i].get());
    if (!hub) {
      std::fprintf(stderr, "scaratwin %s: %s%s\n", kind.c_str(),
                   links->size() > 1 ? fmt::format("robot '{}': ", link.name).c_str() : "",
                   hub.error().message.c_str());
      return kExitFailure;
    }
    hubs.push_back(std::move(*hub));
    named.push_back(NamedHub{link.name, hubs.back().get()});
  }
  std::vector<Hub*> raw;
  for (const auto& h : hubs) raw.push_back(h.get());
  watcher.attach(raw);
  const bool mirror = links->front().options.sim_role != "observe";
  for (Hub* hub : raw) {
    (void)hub->begin_run(kind, label);
    if (mirror) hub->set_mirror(true);
  }
  Status s = body(named);
  for (Hub* hub : raw) (void)hub->end_run(s.ok());
  watcher.detach();
  if (!s) {
    std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), s.error().message.c_str());
    return watcher.fired() ? kExitInterrupted : kExitFailure;
  }
  return kExitOk;
}

}  // namespace

void add_link_options(CLI::App& cmd, LinkArgs& l) {
  cmd.add_option("--serial", l.serial,
                 "serial port of the robot (a board's /dev/ttyACM0, or the pty that "
                 "`scaratwin robot` prints); default: $SCARATWIN_SERIAL. A hub driving several "
                 "robots of a workcell takes NAME=DEVICE once for each")
      ->allow_extra_args(false);  // one value each time: a statement's numbers may follow
  cmd.add_option("--sim", l.sim, "simulator address HOST:PORT")->capture_default_str();
  cmd.add_option("--sim-token", l.sim_token,
                 "the simulator's access token, when it listens beyond this machine; "
                 "default: $SCARATWIN_TOKEN");
  cmd.add_option("--db", l.db,
                 "twin database to record into (several robots: one each, twin-NAME.db "
                 "beside it)")
      ->capture_default_str();
  cmd.add_flag("--no-db", l.no_db, "record nothing");
  cmd.add_option("--workcell", l.workcell,
                 "a workcell file: several robots around one scene (docs/workcell.md); "
                 "default: the one robot of --config");
  cmd.add_option("--robot", l.robot,
                 "which of the workcell's robots this is (its name); default: the only one");
}

int with_hub(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
             const std::string& label, const std::function<Status(Hub&)>& body) {
  return run_hubs(common, l, kind, label, false,
                  [&](const std::vector<NamedHub>& hubs) { return body(*hubs.front().hub); });
}

int with_hubs(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
              const std::string& label,
              const std::function<Status(const std::vector<NamedHub>&)>& body) {
  return run_hubs(common, l, kind, label, true, body);
}

}  // namespace scaratwin::cli
