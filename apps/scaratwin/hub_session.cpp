// The links of the commands that hold a hub, and the hub sessions themselves: which robots of
// the workcell a command drives, each one's link options and database, connect, record, Ctrl-C.
#include "hub_session.hpp"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/session/links.hpp"

namespace scaratwin::cli {
namespace {

namespace fs = std::filesystem;

// Ctrl-C (SIGINT) and SIGTERM while hubs run: the first stops every robot and fails the
// statements in progress (Hub::interrupt(), exit status 130); a second one, or one before the
// hubs are connected, ends the process at once. The signals are blocked in every thread and
// taken by a watcher thread with sigtimedwait(), so the stop runs as ordinary code.

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

int run_hubs(const CommonOptions& common, const LinkArgs& l, const std::string& kind,
             const std::string& label, bool every,
             const std::function<Status(const std::vector<NamedHub>&)>& body) {
  auto cell = load_cell(common, l);
  if (!cell) {
    if (!cell.error().message.empty()) {
      std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), cell.error().message.c_str());
    }
    return kExitUsage;
  }
  auto links = session::robot_links(*cell, l, kind, every);
  if (!links) {
    if (!links.error().message.empty()) {
      std::fprintf(stderr, "scaratwin %s: %s\n", kind.c_str(), links.error().message.c_str());
    }
    return kExitUsage;
  }
  std::vector<std::unique_ptr<TwinDb>> dbs;
  for (const session::RobotLink& link : *links) {
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
    const session::RobotLink& link = (*links)[i];
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
