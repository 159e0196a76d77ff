#include "rig.hpp"

#include <chrono>
#include <cstdio>
#include <vector>

#include <fmt/format.h>

#include "commands.hpp"

namespace scaratwin::cli {

using namespace std::chrono_literals;

void Rig::stop() {
  truth.reset();
  webcam.reset();
  side.reset();
  if (robot) robot->stop();
  if (sim) sim->stop();
}

Result<Rig> start_rig(const RigOptions& o, const std::filesystem::path& log_dir) {
  Rig rig;
  // the virtual robot.
  std::vector<std::string> sim_args{"--port", "0", "--http-port", std::to_string(o.http_port)};
  if (!o.config_path.empty()) sim_args.insert(sim_args.end(), {"--config", o.config_path});
  if (!o.mqtt.empty() && o.http_port != 0) sim_args.insert(sim_args.end(), {"--mqtt", o.mqtt});
  if (o.companion) sim_args.insert(sim_args.end(), {"--companion-port", "0"});
  auto sim =
      ChildProcess::start(sibling_executable("scaratwin-sim"), sim_args, log_dir / "sim.log");
  if (!sim) return sim.error();
  rig.sim = std::move(*sim);
  auto listening = rig.sim->wait_for_line("listening on", 30s);
  if (!listening) return Error{AppError::kRigStart, "simulator: " + listening.error().message};
  const size_t colon = listening->rfind(':', listening->find(" (speed"));
  rig.sim_port = static_cast<std::uint16_t>(std::stoi(listening->substr(colon + 1)));
  if (o.companion) {
    // the paper's MATLAB/Octave scripts (docs/protocol.md section 13.1); loopback only
    auto c = rig.sim->wait_for_line("companion dialect on ", 5s);
    if (!c) return Error{AppError::kRigStart, "simulator: " + c.error().message};
    rig.companion_port = static_cast<std::uint16_t>(std::stoi(c->substr(c->rfind(':') + 1)));
    fmt::print("companion dialect (the paper's scripts): 127.0.0.1:{}\n", rig.companion_port);
    std::fflush(stdout);
  }
  if (o.http_port != 0) {
    if (auto ui = rig.sim->wait_for_line("http://", 5s); ui) {
      rig.ui_url = ui->substr(ui->find("http://"));
      fmt::print("3D view: {}\n", rig.ui_url);
    }
    if (!o.mqtt.empty()) {
      if (auto fl = rig.sim->wait_for_line("fleet page on ", 5s); fl) {
        rig.fleet_url = fl->substr(fl->find("http://"));
        rig.fleet_url = rig.fleet_url.substr(0, rig.fleet_url.find(' '));
        fmt::print("fleet page: {}\n", rig.fleet_url);
      }
    }
  }

  // the physical robot: a real board or our firmware in the emulator.
  std::uint16_t side_port = 0;
  rig.device = o.serial;
  if (rig.device.empty()) {
    std::vector<std::string> robot_args{"--speed", fmt::format("{}", o.robot_speed)};
    if (!o.config_path.empty()) robot_args.insert(robot_args.end(), {"--config", o.config_path});
    if (o.as_built_seed) {
      robot_args.insert(robot_args.end(), {"--as-built-seed", std::to_string(*o.as_built_seed)});
    }
    auto r = ChildProcess::start(sibling_executable("scaratwin-robot"), robot_args,
                                 log_dir / "robot.log");
    if (!r) return r.error();
    rig.robot = std::move(*r);
    auto pty = rig.robot->wait_for_line("pty: ", 30s);
    if (!pty) return Error{AppError::kRigStart, "emulator: " + pty.error().message};
    rig.device = pty->substr(pty->find("pty: ") + 5);
    if (auto pl = rig.robot->wait_for_line("plant: ", 1s); pl) {
      rig.plant = pl->substr(pl->find("plant: ") + 7);
      rig.plant = rig.plant.substr(0, rig.plant.find(' '));
    }
    fmt::print("physical robot: firmware in the AVR emulator on {}\n", rig.device);
    auto side = rig.robot->wait_for_line("side channel: ", 5s);
    if (!side) return Error{AppError::kRigStart, "emulator: " + side.error().message};
    side_port = static_cast<std::uint16_t>(std::stoi(side->substr(side->rfind(':') + 1)));
  } else {
    fmt::print("physical robot: {}\n", rig.device);
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
  fmt::print("physical robot: {}\n",
             rig.plant == "real" ? "a real board" : "emulated, plant " + rig.plant);
  // the robot's webcam: the emulated robot's, or a real one given as host:port
  std::string host = "127.0.0.1";
  std::uint16_t cam_port = 0;
  if (rig.robot && rig.plant == "as-built") {
    if (auto cam_line = rig.robot->wait_for_line("camera: ", 2s); cam_line) {
      cam_port = static_cast<std::uint16_t>(std::stoi(cam_line->substr(cam_line->rfind(':') + 1)));
    }
  } else if (!o.camera.empty()) {
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

}  // namespace scaratwin::cli
