// The processes and instruments of a twin session: the simulator (scaratwin-sim), the physical
// robot (a real board on a serial port, or our firmware in the emulator, scaratwin-robot), and
// the emulated robot's side channel (its buttons, the operator's hands, the truth) and webcam.
// Used by `scaratwin demo` and `scaratwin calibrate`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/process.hpp"
#include "scaratwin/hub/tool_tracker.hpp"
#include "scaratwin/session/emulator_side.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

struct RigOptions {
  std::string config_path;  // robot description for the simulator and the emulator
  std::string serial;       // a real board; empty: the emulator
  int http_port = 0;        // the simulator's browser UI (0: none)
  double robot_speed = 1.0;
  std::optional<std::uint64_t> as_built_seed;  // the emulated robot's build
  std::string camera;                          // a real robot's webcam as host:port
  double truth_hz = TruthRecorder::kDemoHz;    // the emulated robot's truth recorder
  std::string mqtt;        // the broker whose fleet the simulator's fleet page shows (empty: none)
  bool companion = false;  // the simulator also serves the paper's companion TCP dialect
  // where scaratwin-sim and scaratwin-robot are (empty: beside this program's executable)
  std::filesystem::path bin_dir;
};

struct Rig {
  std::unique_ptr<ChildProcess> sim;
  std::unique_ptr<ChildProcess> robot;  // null with a real board
  std::uint16_t sim_port = 0;
  std::string device;          // the serial device (or the emulator's pty)
  std::string plant = "real";  // real, as-built or ideal
  std::string ui_url;
  std::string fleet_url;             // the fleet page (with --mqtt)
  std::uint16_t companion_port = 0;  // the companion dialect's port on 127.0.0.1 (0: off)
  std::optional<EmulatorSide> side;
  std::unique_ptr<TruthRecorder> truth;  // as-built emulated robots only
  std::unique_ptr<NetCamera> webcam;

  void stop();
};

// Starts the rig; the children's logs go to `log_dir` (sim.log, robot.log). Says what it
// started (the addresses of the 3D view, the robot's device).
Result<Rig> start_rig(const RigOptions& options, const std::filesystem::path& log_dir,
                      const Say& say);

}  // namespace scaratwin::session
