// scaratwin calibrate: measures the connected robot (the emulated one by default) and writes
// its calibrated description, an overlay next to the base description (docs/calibration.md).
#include <cstdio>
#include <filesystem>
#include <memory>

#include <fmt/format.h>

#include "calibrate_step.hpp"
#include "commands.hpp"
#include "rig.hpp"
#include "scaratwin/config/robot_config.hpp"
#include "scaratwin/hub/hub.hpp"

namespace scaratwin::cli {
namespace {

struct CalibrateArgs {
  std::string serial;
  std::string camera;
  std::string out = "scaratwin-calibration";
  std::string output;
  double robot_speed = 1.0;
  int poses = 36;
  unsigned seed = 1;
  long long as_built_seed = -1;
};

int run_calibrate(const CommonOptions& common, const CalibrateArgs& a) {
  auto model = load_model(common);
  if (!model) return kExitUsage;
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
  namespace fs = std::filesystem;
  const fs::path base =
      common.config_path.empty() ? default_robot_config_path() : fs::path(common.config_path);
  const fs::path overlay = a.output.empty() ? default_overlay_path(base) : fs::path(a.output);
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec) {
    std::fprintf(stderr, "scaratwin calibrate: cannot create --out '%s': %s\n", a.out.c_str(),
                 ec.message().c_str());
    return kExitUsage;
  }
  if (!fs::exists(fs::absolute(overlay).parent_path())) {
    std::fprintf(stderr, "scaratwin calibrate: --output '%s': no such folder\n",
                 overlay.string().c_str());
    return kExitUsage;
  }
  RigOptions ro;
  ro.config_path = common.config_path;
  ro.serial = a.serial;
  ro.camera = a.camera;
  ro.robot_speed = a.robot_speed;
  if (a.as_built_seed >= 0) ro.as_built_seed = static_cast<std::uint64_t>(a.as_built_seed);
  auto rig = start_rig(ro, fs::absolute(a.out));
  if (!rig) {
    std::fprintf(stderr, "scaratwin calibrate: %s\n", rig.error().message.c_str());
    return kExitFailure;
  }
  if (!rig->webcam) {
    std::fprintf(stderr,
                 "scaratwin calibrate: the robot has no webcam (an emulated robot "
                 "needs --plant as-built)\n");
    rig->stop();
    return kExitFailure;
  }
  HubOptions ho;
  ho.serial_device = rig->device;
  ho.sim_port = rig->sim_port;
  auto hub = Hub::connect(*model, ho, nullptr);
  if (!hub) {
    std::fprintf(stderr, "scaratwin calibrate: %s\n", hub.error().message.c_str());
    rig->stop();
    return kExitFailure;
  }
  std::unique_ptr<CalibrationOperator> op;
  if (rig->side) {
    op = std::make_unique<EmulatedOperator>(*rig->side);
  } else {
    op = std::make_unique<TerminalOperator>();
  }
  CalibrationOptions co;
  co.marker_poses = a.poses;
  co.seed = a.seed;
  co.progress = [](const std::string& line) {
    fmt::print("==> {}\n", line);
    std::fflush(stdout);
  };
  // with the emulated robot: each measurement beside the truth (a measuring instrument for
  // the record, never given to the fit)
  std::FILE* log = nullptr;
  if (rig->side) {
    log = std::fopen((fs::path(a.out) / "calibration-truth.csv").c_str(), "w");
    if (log)
      std::fputs(
          "kind,q_fw0,q_fw1,q_fw2,q_fw3,dir1,dir2,true0,true1,true2,true3,axis_col,axis_row,flag_"
          "col,flag_row,tool_x,tool_y,tool_z\n",
          log);
    co.on_measurement = [&](const calib::MarkerView* v, const calib::TouchOff* t) {
      auto tr = rig->side->query();
      if (!log || !tr) return;
      const JointVector& q = v ? v->q_fw : t->q_fw;
      const calib::Directions& d = v ? v->dir : t->dir;
      std::fprintf(
          log,
          "%s,%.9g,%.9g,%.9g,%.9g,%d,%d,%.9g,%.9g,%.9g,%.9g,%.4f,%.4f,%.4f,%.4f,%.9g,%.9g,%.9g\n",
          v ? "marker" : "touch", q[0], q[1], q[2], q[3], d[1], d[2], tr->q[0], tr->q[1], tr->q[2],
          tr->q[3], v && v->axis_px ? (*v->axis_px)[0] : -1.0,
          v && v->axis_px ? (*v->axis_px)[1] : -1.0, v && v->flag_px ? (*v->flag_px)[0] : -1.0,
          v && v->flag_px ? (*v->flag_px)[1] : -1.0, tr->tool[0], tr->tool[1], tr->tool[2]);
      std::fflush(log);
    };
  }
  auto run = calibrate_and_write(**hub, *rig->webcam, *op, base, overlay, co);
  if (log) std::fclose(log);
  hub->reset();
  rig->stop();
  if (!run) {
    std::fprintf(stderr, "scaratwin calibrate: %s\n", run.error().message.c_str());
    return run.error().code == 2 ? kExitUsage : kExitFailure;
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
