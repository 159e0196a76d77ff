// The demo's figures against the physical truth: what a session measured (DemoOutcome), the
// virtual -> true tool comparison along a run (the robot's reports against the emulator's
// truth, aligned on the robot's own clock) and results.json (keys: docs/results.md). The
// truth is a measuring instrument of the emulated robot; the twin never reads it.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/session/emulator_side.hpp"

namespace scaratwin::session {

// Calibration, measured: the virtual -> true tool at test poses the fit did not use, before
// and after, and each identified parameter beside the true build.
struct CalibrationParameter {
  std::string key;  // with its unit (calibration::param_info)
  // in the key's unit: the fit's value, its standard error, the truth (NaN: not measured) and
  // the build's drawn parameter (calibrate_step.hpp: true_parameters, drawn_parameters)
  double identified = 0.0, std_error = 0.0, truth = 0.0, drawn = 0.0;
};
struct CalibrationFigures {
  ToolErrorStats before, after;
  int test_poses = 0;
  int fit_poses = 0;  // marker views and touch-offs
  double robot_s = 0.0, fit_s = 0.0, pixel_rms = 0.0;
  std::vector<CalibrationParameter> parameters;
  std::string overlay;
};

struct DemoOutcome {
  int in_trays_prediction = 0;
  int in_trays_replay = 0;  // virtual: the simulator mirroring the robot
  std::uint64_t lost_frames = 0;
  double virt_phys_mm = 0.0;
  // against the physical truth (emulated robot only)
  std::vector<double> control_error_mm;  // target -> true tool, per control target
  int physical_in_trays = -1;            // where the physical cubes ended up
  ToolErrorStats virt_phys_along;        // virtual -> true tool along every motion
  // the physical replay against the simulator's prediction, tool deviation at equal progress
  // along the path (RMS and max, mm; NaN when either run recorded nothing)
  double replay_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double replay_max_mm = std::numeric_limits<double>::quiet_NaN();
  std::optional<std::array<long long, 3>> steps_lost_truth;
  std::optional<std::array<int, 3>> steps_lost_homing;
  LatencyFigures latency;
  std::optional<CalibrationFigures> calibration;
};

// The sorting succeeded: on the physical table when it can be seen (the emulated robot's
// truth), else in the virtual scene mirroring the robot.
bool physical_ok(const DemoOutcome& o, std::size_t cubes);

// Virtual -> physical tool along the motions of `run` between two monotonic times; each
// compared sample's distance is appended to `distances` when given.
ToolErrorStats virtual_vs_truth(TwinDb& db, const RobotModel& model, std::int64_t run,
                                const TruthRecorder& truth, std::uint64_t from_us,
                                std::uint64_t to_us, std::vector<double>* distances);

// Writes every figure of the session to results.json (keys: docs/results.md).
Status write_results(const std::filesystem::path& path, const std::string& plant,
                     const DemoOutcome& o);

}  // namespace scaratwin::session
