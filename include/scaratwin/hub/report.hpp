// Self-contained HTML reports of twin runs (inline SVG plots, no scripts, no network): joint
// values virtual vs physical, mirror latency histogram, top and side views of the tool paths,
// tool deviation over time, and our figures beside the paper's.
#pragma once

#include <filesystem>

#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/twin_db.hpp"

namespace scaratwin {

// Metric names shared by the hub (which records them) and the report (which shows them).
namespace metric {
inline constexpr const char* kLatencyMeanMs = "mirror_latency_mean_ms";
inline constexpr const char* kLatencyP99Ms = "mirror_latency_p99_ms";
inline constexpr const char* kHubToSimMeanMs = "hub_to_sim_latency_mean_ms";
inline constexpr const char* kLostFrames = "mirror_lost_frames";
inline constexpr const char* kReplayLostFrames = "replay_lost_frames";
inline constexpr const char* kFrames = "mirror_frames";
inline constexpr const char* kToolErrTargetPhysMm = "tool_error_target_physical_mm";
inline constexpr const char* kToolErrTargetVirtMm = "tool_error_target_virtual_mm";
inline constexpr const char* kToolErrVirtPhysMm = "tool_error_virtual_physical_mm";
inline constexpr const char* kReplayToolMaxMm = "replay_tool_deviation_max_mm";
inline constexpr const char* kReplayToolRmsMm = "replay_tool_deviation_rms_mm";
inline constexpr const char* kReplayFinalMm = "replay_final_tool_error_mm";
inline constexpr const char* kCubesInTray = "cubes_in_tray";
inline constexpr const char* kDesyncAlarms = "desync_alarms";
inline constexpr const char* kOffPlanMaxMm = "replay_off_plan_max_mm";
inline constexpr const char* kLostSteps = "lost_steps";  // found by homing again, all axes
// against the physical truth of the emulated robot as built (the emulator's measuring
// instrument; never with a real board)
inline constexpr const char* kControlErrTrueMm = "control_error_target_true_mm";
inline constexpr const char* kVirtTrueMeanMm = "virtual_true_tool_mean_mm";
inline constexpr const char* kVirtTrueMaxMm = "virtual_true_tool_max_mm";
inline constexpr const char* kPhysicalCubesInTray = "physical_cubes_in_trays";
inline constexpr const char* kLostStepsTrue = "lost_steps_truth";  // all axes
// calibration: virtual vs true tool at test poses the fit did not use
inline constexpr const char* kCalibBeforeMeanMm = "calibration_before_mean_mm";
inline constexpr const char* kCalibBeforeMaxMm = "calibration_before_max_mm";
inline constexpr const char* kCalibAfterMeanMm = "calibration_after_mean_mm";
inline constexpr const char* kCalibAfterMaxMm = "calibration_after_max_mm";
// each identified parameter: `calibration.<key>` (the value), `calibration.<key>.se` (its
// standard error) and `calibration.<key>.true` (the truth, emulated robot only); the report
// tables them together
inline constexpr const char* kCalibParamPrefix = "calibration.";
}  // namespace metric

// Writes the report of `run` (and of the runs whose parent it is) to `html`.
Status write_report(TwinDb& db, const RobotModel& model, int64_t run,
                    const std::filesystem::path& html);

}  // namespace scaratwin
