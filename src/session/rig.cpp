#include "scaratwin/session/rig.hpp"

#include <chrono>
#include <cstdio>
#include <vector>

#include <fmt/format.h>

#include "scaratwin/session/address.hpp"

namespace scaratwin::session {

using namespace std::chrono_literals;

void Rig::stop() {
  truth.reset();
  webcam.reset();
  side.reset();
  if (robot) robot->stop();
  if (sim) sim->stop();
}

Result<Rig> start_rig(const RigOptions& o, const std::filesystem::path& log_dir, const Say& say) {
  auto program = [&o](const std::string& name) { return program_path(o.bin_dir, name); };
  Rig rig;
  // the virtual robot.
  std::vector<std::string> sim_args{"--port", "0", "--http-port", std::to_string(o.http_port)};
  if (!o.config_path.empty()) sim_args.insert(sim_args.end(), {"--config", o.config_path});
  if (!o.mqtt.empty() && o.http_port != 0) sim_args.insert(sim_args.end(), {"--mqtt", o.mqtt});
  if (o.companion) sim_args.insert(sim_args.end(), {"--companion-port", "0"});
  auto sim = start_simulator(program("scaratwin-sim"), sim_args, log_dir / "sim.log", 30s);
  if (!sim) return Error{AppError::kRigStart, "simulator: " + sim.error().message};
  rig.sim = std::move(sim->process);
  rig.sim_port = sim->ready.port;
  if (o.companion) {
    // the paper's MATLAB/Octave scripts (docs/protocol.md section 13.1); loopback only
    rig.companion_port = sim->ready.companion_port;
    say(fmt::format("companion dialect (the paper's scripts): 127.0.0.1:{}", rig.companion_port));
  }
  rig.ui_url = sim->ready.ui_url;
  if (!rig.ui_url.empty()) say(fmt::format("3D view: {}", rig.ui_url));
  rig.fleet_url = sim->ready.fleet_url;
  if (!rig.fleet_url.empty()) say(fmt::format("fleet page: {}", rig.fleet_url));

  // the physical robot: a real board or our firmware in the emulator.
  std::uint16_t side_port = 0;
  std::uint16_t cam_port = 0;
  rig.device = o.serial;
  if (rig.device.empty()) {
    std::vector<std::string> robot_args{"--speed", fmt::format("{}", o.robot_speed)};
    if (!o.config_path.empty()) robot_args.insert(robot_args.end(), {"--config", o.config_path});
    if (o.as_built_seed) {
      robot_args.insert(robot_args.end(), {"--as-built-seed", std::to_string(*o.as_built_seed)});
    }
    auto r = start_emulator(program("scaratwin-robot"), robot_args, log_dir / "robot.log", 30s);
    if (!r) return Error{AppError::kRigStart, "emulator: " + r.error().message};
    rig.robot = std::move(r->process);
    rig.device = r->ready.pty;
    rig.plant = r->ready.plant;
    side_port = r->ready.side_port;
    if (rig.plant == "as-built") cam_port = r->ready.camera_port;
    say(fmt::format("physical robot: firmware in the AVR emulator on {}", rig.device));
  } else {
    say(fmt::format("physical robot: {}", rig.device));
  }

  if (side_port != 0) {
    auto b = EmulatorSide::connect(side_port);
    if (!b) return b.error();
    rig.side.emplace(std::move(*b));
    if (rig.plant == "as-built") {
      // the measuring instrument: the truth, read only for the figures
      auto t = TruthRecorder::start(side_port, o.truth_hz);
      if (!t) return t.error();
      rig.truth = std::move(*t);
    }
  }
  say(fmt::format("physical robot: {}",
                  rig.plant == "real" ? "a real board" : "emulated, plant " + rig.plant));
  // the robot's webcam: the emulated robot's, or a real one given as host:port
  std::string host = "127.0.0.1";
  if (!(rig.robot && rig.plant == "as-built") && !o.camera.empty()) {
    const auto camera = parse_host_port(o.camera);
    if (!camera) {
      return Error{AppError::kBadOption,
                   "--camera '" + o.camera + "': expected HOST:PORT (a port of 1..65535)"};
    }
    host = camera->host;
    cam_port = camera->port;
  }
  if (cam_port != 0) {
    auto c = NetCamera::connect(host, cam_port);
    if (!c) return c.error();
    rig.webcam = std::move(*c);
  }
  return rig;
}

}  // namespace scaratwin::session
