// The paper's procedure on a running twin (`scaratwin demo`, Python's scaratwin.demo): home,
// calibrate (with the emulated robot as built), mirror, control, prediction and its physical
// replay, homing again; then results.json, the report and the CSV tables. The measuring
// instruments of the emulated robot (its side channel and truth) only measure; the twin's own
// logic never reads them.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/tool_tracker.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/session/emulator_side.hpp"
#include "scaratwin/session/figures.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

// What the phases need besides the hub.
struct DemoPhaseOptions {
  unsigned seed = 7;           // the cube layout's (and the calibration's test poses', + 1000)
  int cubes = kNumColors;      // red, green, blue: the first `cubes` of them
  double mirror_s = 6.0;       // the mirror phase's length
  bool calibrate = true;       // calibrate after homing when the robot has the instruments for it
  long long layout_seed = -1;  // cubes at random spots of the workspace (-1: `seed`'s)
  std::string base_config;     // the description file the calibration overlay is based on
  std::filesystem::path out_dir;  // where the calibrated overlay and the truth log go
};

// Measuring instruments of the emulated robot (none with a real board).
struct Instruments {
  EmulatorSide* side = nullptr;
  TruthRecorder* truth = nullptr;
  NetCamera* camera = nullptr;  // the robot's webcam (the twin's own sensor, not a truth)
};

// Runs the phases on a connected hub, each in a run of `db` under the run `demo`.
Result<DemoOutcome> run_demo_phases(Hub& hub, TwinDb& db, const DemoPhaseOptions& options,
                                    std::int64_t demo, const Instruments& inst, const Say& say);

// A whole demo session: its processes, database, hub and phases.
struct DemoOptions {
  DemoPhaseOptions phases;
  std::string config_path;        // the robot description (empty: the default one)
  std::string serial;             // a real board on this port; empty: the emulated robot
  std::filesystem::path out_dir;  // exists; the database, report, CSV and logs go here
  int http_port = 8080;           // the simulator's browser view (0: none)
  double robot_speed = 1.0;       // the emulated robot's seconds per wall second
  long long as_built_seed = -1;   // the emulated robot's build (-1: the description's)
  std::string mqtt;               // publish the robot's state on this broker (empty: none)
  bool companion = false;         // the simulator also serves the paper's companion dialect
  std::filesystem::path bin_dir;  // scaratwin-sim and -robot (empty: beside this program)
  // Runs after the report is written, while every process still runs (the command line's
  // --keep-open waits there for Ctrl-C).
  std::function<void()> before_stop;
  // Set (from any thread) to stop the demo: the robot stops at once, the phase in progress
  // fails as interrupted, and the report of what was recorded is written all the same.
  const std::atomic<bool>* stop = nullptr;
};

struct DemoResult {
  bool ok = false;                     // every cube in its tray, nothing lost
  std::optional<DemoOutcome> outcome;  // every figure (none when a phase failed)
  std::optional<Error> failure;        // the phase that failed, and why
  std::string plant;                   // real, as-built or ideal
  std::int64_t demo_run = 0;           // the session's run in the database
  double duration_s = 0.0;
  std::filesystem::path database, results, report, csv_dir;
  int cubes_in_trays = 0;  // physical when the truth sees them, else virtual
};

// Runs a whole demo. Errors before the first phase (a process that did not start, a database
// that cannot be opened, a hub refused) are returned; a failing phase is in the result, with
// the report and the tables of what was recorded written all the same. `warn` receives the
// problems that do not stop the session (a file that could not be written).
Result<DemoResult> run_demo(const RobotModel& model, const DemoOptions& options, const Say& say,
                            const Say& warn);

// The robot's state on the fleet's topics (docs/fleet.md), published until the returned
// handle goes; commands are answered "takes no commands". `name` empty: the description's
// robot name.
Result<std::shared_ptr<void>> publish_on_fleet(const std::string& url, const std::string& name,
                                               const Hub& hub, const Say& say);

}  // namespace scaratwin::session
