// The experiments of the paper's Section 6 that scaratwin measures on its own processes (the
// emulated robot, the simulator, the hub), as `scaratwin bench paper` runs them:
//  - the mirror latency against the serial rate, beside the wire time of one state report at
//    each rate (the paper ran 115200 baud; the Uno's 16 MHz clock makes 1,000,000 exactly);
//  - Fig. 15's control half: the time to reach five target points with the paper's
//    "traditional single-class" loading (one value per line, z, y, x, then m, with the companion
//    scripts' 2 s pauses: the firmware's companion dialect) against our mixed packets (a
//    quintic loaded as TB/TP with credit flow control);
//  - Fig. 15's mapping half: the delay from the robot's state to the virtual robot over five
//    action sets, the robot reporting one value per line (setting 10 = 2) and the twin loading
//    them one by one, against our ST packets mirrored by the hub.
// Each experiment starts its own emulated robot (exact, paced 1x) and simulator; their logs go
// to `out`, the runs into `db`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/twin_db.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin::session {

struct BenchOptions {
  std::vector<int> rates{9600, 57600, 115200, 250000, 500000, 1000000};
  double seconds = 10.0;    // per rate
  int report_hz = 200;      // the robot's state reports
  int targets = 5;          // Fig. 15 control targets
  int action_sets = 5;      // Fig. 15 mapping action sets
  double mapping_s = 10.0;  // per action set and form
  // where scaratwin-sim and scaratwin-robot are (empty: beside this program's executable)
  std::filesystem::path bin_dir;
};

struct RateResult {
  int nominal = 0;
  double baud = 0.0;
  double wire_ms = 0.0;
  std::size_t frames = 0;
  std::int64_t lost = 0;
  Stats latency_ms;
  Stats hub_to_sim_ms;
};

struct ControlResult {
  ToolPose target;
  double ours_s = 0.0;  // TB/TP quintic: first packet to the robot's EV 3
  int ours_points = 0;
  double single_s = 0.0;  // z, 2 s, y, 2 s, x, 2 s, m: first line to the motors at rest there
};

struct MappingResult {
  std::string name;
  LatencyFigures mixed;
  std::int64_t mixed_lost = 0;
  double mixed_bytes = 0.0;  // bytes on the wire per line received (almost all ST)
  LatencyFigures single;
  std::int64_t single_lost = 0;
  double single_bytes = 0.0;  // bytes on the wire per sample (the six lines)
};

// One rate: a fresh emulated robot and simulator, the hub mirroring at `report_hz` while the
// robot's J2 jog buttons are pressed back and forth (the paper moved its robot by hand).
Result<RateResult> measure_rate(const RobotModel& model, const BenchOptions& options, int nominal,
                                const std::filesystem::path& out, TwinDb& db);

// Fig. 15, control: each target reached both ways from home.
Result<std::vector<ControlResult>> measure_control(const RobotModel& model,
                                                   const BenchOptions& options,
                                                   const std::filesystem::path& out, TwinDb& db);

// Fig. 15, mapping: each action set both ways.
Result<std::vector<MappingResult>> measure_mapping(const RobotModel& model,
                                                   const BenchOptions& options,
                                                   const std::filesystem::path& out, TwinDb& db);

// The latency against the rate, as an SVG line chart.
std::string rate_plot_svg(const std::vector<RateResult>& results, int report_hz);
// Fig. 15's two halves, as SVG line charts.
std::string control_plot_svg(const std::vector<ControlResult>& results);
std::string mapping_plot_svg(const std::vector<MappingResult>& results);

}  // namespace scaratwin::session
