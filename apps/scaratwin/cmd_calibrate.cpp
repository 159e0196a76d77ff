// scaratwin calibrate: measures the connected robot (the emulated one by default) and writes
// its calibrated description, an overlay next to the base description (docs/calibration.md).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "commands.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/session/calibration.hpp"
#include "terminal_operator.hpp"

namespace scaratwin::cli {
namespace {

struct CalibrateArgs {
  std::string serial;
  std::string camera;
  std::string out = "scaratwin-calibration";
  std::string output;
  double robot_speed = 1.0;
  int poses = 24;
  int touch_offs = 4;
  unsigned seed = 1;
  long long as_built_seed = -1;
};

int run_calibrate(const CommonOptions& common, const CalibrateArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
  // the emulated robot's build (the twin never reads it; the comparison at the end does)
  if (a.as_built_seed >= 0)
    model->physical.as_built.seed = static_cast<std::uint64_t>(a.as_built_seed);
  if (is_calibrated(*model)) {
    std::fprintf(stderr,
                 "scaratwin calibrate: --config names a calibrated description; calibrate with "
                 "its base description\n");
    return kExitUsage;
  }
  if (!a.serial.empty() && a.camera.empty()) {
    std::fprintf(stderr,
                 "scaratwin calibrate: a real robot needs its webcam: --camera HOST:PORT (a "
                 "camera server answering `grab W H`, docs/calibration.md)\n");
    return kExitUsage;
  }
  if (!a.camera.empty() && !parse_host_port(a.camera)) {
    std::fprintf(stderr,
                 "scaratwin calibrate: --camera '%s': expected HOST:PORT (a port of 1..65535)\n",
                 a.camera.c_str());
    return kExitUsage;
  }
  namespace fs = std::filesystem;
  const fs::path base =
      common.config_path.empty() ? default_robot_config_path() : fs::path(common.config_path);
  const fs::path overlay =
      a.output.empty() ? session::default_overlay_path(base) : fs::path(a.output);
  if (!create_out_dir(a.out, "calibrate")) return kExitUsage;
  if (!fs::exists(fs::absolute(overlay).parent_path())) {
    std::fprintf(stderr, "scaratwin calibrate: --output '%s': no such folder\n",
                 overlay.string().c_str());
    return kExitUsage;
  }
  session::CalibrateOptions o;
  o.config_path = common.config_path;
  o.serial = a.serial;
  o.camera = a.camera;
  o.out_dir = a.out;
  o.overlay = overlay;
  o.robot_speed = a.robot_speed;
  o.as_built_seed = a.as_built_seed;
  o.marker_poses = a.poses;
  o.touch_offs = a.touch_offs;
  o.seed = a.seed;
  TerminalOperator person;
  auto run = session::run_calibration(*model, o, &person, session::say_on_stdout());
  if (!run) {
    std::fprintf(stderr, "scaratwin calibrate: %s\n", run.error().message.c_str());
    return run.error().code == error_code(CalibrationError::kCalibratedBase) ? kExitUsage
                                                                             : kExitFailure;
  }
  return kExitOk;
}

}  // namespace

void add_calibrate_command(CLI::App& app, CommonOptions& common, Runner& run) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "measure the connected robot (endstops, the webcam on a printed pattern and on the tool's "
      "markers, touch-offs) and write its calibrated description (an overlay for --config)");
  cmd->add_option("--serial", a->serial,
                  "a real robot on this serial port (default: the emulated robot)");
  cmd->add_option("--camera", a->camera, "a real robot's webcam server, HOST:PORT");
  cmd->add_option("--output", a->output,
                  "the overlay to write (default: <base description>.calibrated.toml beside it)");
  cmd->add_option("--out", a->out, "folder for the logs")->capture_default_str();
  cmd->add_option("--touch-offs", a->touch_offs, "touch-offs (marks on the mat)")
      ->capture_default_str()
      ->check(CLI::Range(3, 6));
  cmd->add_option("--poses", a->poses, "marker poses")
      ->capture_default_str()
      ->check(CLI::Range(12, 500));
  cmd->add_option("--seed", a->seed, "seed of the marker poses")->capture_default_str();
  cmd->add_option("--as-built-seed", a->as_built_seed,
                  "emulated robot: the seed of its build (default: the description's)")
      ->check(CLI::Range(0LL, 2147483647LL));
  cmd->add_option("--robot-speed", a->robot_speed,
                  "emulated robot: emulated seconds per wall second")
      ->capture_default_str();
  add_common_options(*cmd, common, false);
  cmd->callback([&common, &run, a] { run = [&common, a] { return run_calibrate(common, *a); }; });
}

}  // namespace scaratwin::cli
