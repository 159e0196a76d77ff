// scaratwin demo: the main job. Starts the simulator and the emulated robot (our firmware in
// simavr) as separate processes, connects the hub to both over real TCP and a pty, and runs the
// paper's three twin functions: mirror, control, and the colour-sorting prediction followed by
// its physical replay. Writes the database and the report; exits 0 only if every cube ends in
// its tray. `--serial /dev/ttyACM0` drives a real Arduino instead of the emulator.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "commands.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/config/workcell_config.hpp"
#include "scaratwin/fleet/local_broker.hpp"
#include "scaratwin/fleet/topics.hpp"
#include "scaratwin/session/demo.hpp"
#include "scaratwin/session/demo_cell.hpp"

namespace scaratwin::cli {
namespace {

struct DemoArgs {
  std::string serial;
  std::string out = "scaratwin-out";
  bool keep_open = false;
  int http_port = 8080;
  double robot_speed = 1.0;
  unsigned seed = 7;
  int cubes = kNumColors;  // cubes to sort: red, green, blue, the first `cubes` of them
  double mirror_s = 6.0;
  bool calibrate = true;
  long long as_built_seed = -1;  // the emulated robot's build (-1: the description's)
  std::string mqtt;              // publish the demo's state on this broker (docs/fleet.md)
  bool mqtt_given = false;       // --mqtt without a URL: start a Mosquitto of our own
  bool calibrate_given = false;  // --calibrate or --no-calibrate said
  long long layout_seed = -1;    // cubes at random spots of the workspace (-1: --seed's layout)
  int robots = 1;                // more: the robots of a workcell share the table (demo_cell.hpp)
  std::string workcell;          // their workcell file (default config/two_arms_trays.toml)
};

std::atomic<bool> g_interrupted{false};
void on_interrupt(int) { g_interrupted = true; }

// Waits for Ctrl-C (or SIGTERM): --keep-open.
void wait_for_interrupt() {
  fmt::print("--keep-open: the simulator and its UI keep running; Ctrl-C to stop\n");
  std::fflush(stdout);
  sigset_t block, old;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  sigprocmask(SIG_BLOCK, &block, &old);
  while (!g_interrupted) sigsuspend(&old);
  sigprocmask(SIG_SETMASK, &old, nullptr);
}

const session::Say kWarn = [](const std::string& line) {
  std::fprintf(stderr, "scaratwin demo: %s\n", line.c_str());
};

// --robots N: the robots of a workcell on one table.
int run_cell(const DemoArgs& a) {
  namespace fs = std::filesystem;
  const fs::path file = a.workcell.empty()
                            ? default_robot_config_path().parent_path() / "two_arms_trays.toml"
                            : fs::path(a.workcell);
  auto cell = load_workcell_config(file);
  if (!cell) {
    kWarn(cell.error().message);
    return kExitUsage;
  }
  const int n = static_cast<int>(cell->robots.size());
  if (n != a.robots) {
    kWarn(fmt::format("--robots {}, but {} has {} robot{} ({})", a.robots, file.string(), n,
                      n == 1 ? "" : "s", robot_names(*cell)));
    return kExitUsage;
  }
  const auto out_dir = create_out_dir(a.out, "demo");
  if (!out_dir) return kExitUsage;
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  session::CellDemoOptions c;
  c.out = *out_dir;
  c.http_port = a.http_port;
  c.robot_speed = a.robot_speed;
  c.seed = a.seed;
  c.cubes = a.cubes;
  c.as_built_seed = a.as_built_seed;
  c.interrupted = &g_interrupted;
  if (a.keep_open) c.before_stop = wait_for_interrupt;
  auto r = session::run_cell_demo(*cell, file, c, session::say_on_stdout(), kWarn);
  if (!r) {
    kWarn(r.error().message);
    return kExitFailure;
  }
  return r->ok ? kExitOk : kExitFailure;
}

int run_demo(const CommonOptions& common, const DemoArgs& a) {
  if (a.robots > 1 || !a.workcell.empty()) {
    if (!a.serial.empty() || a.calibrate_given || a.mqtt_given || a.layout_seed >= 0 ||
        !common.config_path.empty()) {
      std::fprintf(stderr,
                   "scaratwin demo: --robots/--workcell runs the workcell's emulated robots; "
                   "--serial, --calibrate, --mqtt, --layout-seed and --config are for the single "
                   "robot\n");
      return kExitUsage;
    }
    return run_cell(a);
  }
  auto model = load_model(common);
  if (!model) return kExitUsage;
  namespace fs = std::filesystem;
  const auto out_dir = create_out_dir(a.out, "demo");
  if (!out_dir) return kExitUsage;
  const fs::path& out = *out_dir;
  // --mqtt with no URL: the demo starts its own broker (Mosquitto on a free loopback port)
  fleet::LocalBroker own_broker;
  std::string mqtt = a.mqtt;
  if (a.mqtt_given && mqtt.empty()) {
    auto b = fleet::start_local_broker(out / "broker");
    if (!b) {
      std::fprintf(stderr, "scaratwin demo: --mqtt: %s\n", b.error().message.c_str());
      return kExitFailure;
    }
    own_broker = std::move(*b);
    mqtt = own_broker.url;
    fmt::print("fleet broker: Mosquitto on {} (started by the demo; log in {})\n", mqtt,
               (out / "broker").string());
  }
  if (!mqtt.empty()) {
    if (auto b = fleet::parse_broker_url(mqtt); !b) {
      std::fprintf(stderr, "scaratwin demo: %s\n", b.error().message.c_str());
      return kExitUsage;
    }
  }
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  fmt::print("scaratwin demo: results in {}\n", out.string());
  std::fflush(stdout);

  session::DemoOptions o;
  o.phases.seed = a.seed;
  o.phases.cubes = a.cubes;
  o.phases.mirror_s = a.mirror_s;
  o.phases.calibrate = a.calibrate;
  o.phases.layout_seed = a.layout_seed;
  o.config_path = common.config_path;
  o.serial = a.serial;
  o.out_dir = out;
  o.http_port = a.http_port;
  o.robot_speed = a.robot_speed;
  o.as_built_seed = a.as_built_seed;
  o.mqtt = mqtt;
  o.companion = a.keep_open;  // the paper's own scripts may drive the scene left open
  if (a.keep_open) o.before_stop = wait_for_interrupt;
  auto r = session::run_demo(*model, o, session::say_on_stdout(), kWarn);
  if (!r) {
    kWarn(r.error().message);
    return kExitFailure;
  }
  return r->ok ? kExitOk : kExitFailure;
}

}  // namespace

void add_demo_command(CLI::App& app, CommonOptions& common, Runner& run) {
  auto a = std::make_shared<DemoArgs>();
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "the whole twin, no hardware needed: simulator + emulated robot + hub; mirror, "
      "control, colour-sorting prediction and its physical replay; database and report");
  cmd->add_option("--serial", a->serial,
                  "drive a real Arduino on this serial port instead of the emulator "
                  "(e.g. /dev/ttyACM0)");
  cmd->add_option("--out", a->out, "folder for the database, report, CSV and logs")
      ->capture_default_str();
  cmd->add_flag("--keep-open", a->keep_open,
                "leave the simulator and its UI running at the end; the simulator also serves the "
                "paper's companion TCP dialect on 127.0.0.1 (its port printed at the start)");
  cmd->add_option("--http-port", a->http_port, "port of the browser UI (0: none)")
      ->capture_default_str();
  cmd->add_option("--robot-speed", a->robot_speed,
                  "emulated robot: emulated seconds per wall second (1 = real time)")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "seed of the cube layout")->capture_default_str();
  cmd->add_option("--cubes", a->cubes,
                  "cubes to sort (red, then green, then blue); --cubes 1 is the short demo")
      ->check(CLI::Range(1, kNumColors))
      ->capture_default_str();
  CLI::Option* calibrate = cmd->add_flag(
      "--calibrate,!--no-calibrate", a->calibrate,
      "calibrate after homing (the default with the emulated robot as built): the twin "
      "measures the robot and runs on the calibrated description "
      "(docs/calibration.md); --no-calibrate runs on the description as it is");
  cmd->add_option(
         "--as-built-seed", a->as_built_seed,
         "emulated robot: the seed of its build (default: the description's; with --robots, "
         "robot i's build is drawn with this seed + i)")
      ->check(CLI::Range(0LL, 2147483647LL));
  cmd->add_option("--layout-seed", a->layout_seed,
                  "put the cubes at random reachable, non-overlapping spots of the workspace drawn "
                  "from this seed (default: --seed's spots on the free side of the table)")
      ->check(CLI::Range(0LL, 2147483647LL));
  cmd->add_option(
         "--robots", a->robots,
         "robots on the table: 2 runs the two emulated arms of config/two_arms_trays.toml (or "
         "--workcell), which sort the cubes together (docs/workcell.md)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  cmd->add_option("--workcell", a->workcell,
                  "the workcell file of --robots (its robots, base poses and scene)")
      ->check(CLI::ExistingFile);
  CLI::Option* mqtt =
      cmd->add_option("--mqtt", a->mqtt,
                      "publish the robot's state on this MQTT broker, "
                      "mqtt://[USER@]HOST[:PORT] or mqtts://...?ca=FILE (the password from "
                      "?password-file=FILE or $SCARATWIN_MQTT_PASSWORD), and show the fleet page "
                      "(/fleet.html); --mqtt alone starts a Mosquitto of the demo's own "
                      "(docs/fleet.md)")
          ->expected(0, 1);
  add_common_options(*cmd, common, false);
  cmd->callback([&common, &run, a, mqtt, calibrate] {
    a->mqtt_given = mqtt->count() > 0;
    a->calibrate_given = calibrate->count() > 0;
    run = [&common, a] { return run_demo(common, *a); };
  });
}

}  // namespace scaratwin::cli
