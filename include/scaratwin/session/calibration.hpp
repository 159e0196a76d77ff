// Calibration as a session runs it (`scaratwin calibrate`, the demo's calibration step, Python's
// scaratwin.calibrate): the emulated robot's operator (its hands place the pattern and its
// eyes, the truth, guide the touch-offs; a person at a real robot is a front end's
// CalibrationOperator), the overlay file, the table of what was identified, and the test poses
// that measure the gap before and after.
#pragma once

#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "scaratwin/hub/analysis.hpp"
#include "scaratwin/hub/calibrate.hpp"
#include "scaratwin/session/emulator_side.hpp"
#include "scaratwin/session/figures.hpp"
#include "scaratwin/session/say.hpp"

namespace scaratwin::session {

// The operator of the emulated robot. Its eyes (the truth) see where the tool is, as a person
// at the robot sees it; the twin only learns that the tool is on the mark.
class EmulatedOperator : public CalibrationOperator {
 public:
  explicit EmulatedOperator(EmulatorSide& side) : side_(side) {}
  Status pattern(bool on) override;
  Status touch_off(Hub& hub, const std::string& name, const std::array<double, 3>& mark_B) override;

 private:
  EmulatorSide& side_;
};

// Runs the routine, says the identified parameters and writes the overlay to `overlay`
// (its `base` relative to the overlay's folder). Nothing is written when the fit is refused.
Result<CalibrationRun> calibrate_and_write(Hub& hub, NetCamera& camera, CalibrationOperator& op,
                                           const std::filesystem::path& base_config,
                                           const std::filesystem::path& overlay,
                                           const CalibrationOptions& options, const Say& say);

// Where the overlay goes by default: next to the base description, <stem>.calibrated.toml.
std::filesystem::path default_overlay_path(const std::filesystem::path& base_config);

// Test poses (not used by the fit): seeded tool poses over the workspace.
std::vector<ToolPose> test_poses(const RobotModel& model, int count, std::uint64_t seed);

// The virtual -> true tool distances (m) at the test poses, as two descriptions see the same
// physical poses.
struct TestPoseErrors {
  std::vector<double> before;  // `before`'s tool at the reported step counts
  std::vector<double> after;   // the hub's (its model, dead bands included) at the same report
};

// Moves the robot to each test pose as `hub.model()` computes it and measures, with the
// truth, how far the virtual tool is from the true tool: as the hub's model puts it (after)
// and as `before` (the description as it was) puts it from the same reported counts, which
// is the joints an uncalibrated twin shows there. One pass measures both.
Result<TestPoseErrors> measure_test_poses(Hub& hub, EmulatorSide& side,
                                          const std::vector<ToolPose>& poses,
                                          const RobotModel& before);

// One measurement of the routine beside the emulator's truth: the firmware's joints, the
// side each joint came from, and the true joints there.
struct MeasuredJoints {
  JointVector q_fw{};
  calib::Directions dir{};
  JointVector q_true{};
};

// Logs each measurement of the routine beside the truth (CSV, one line per measurement, for
// the record) and keeps the samples. A measuring instrument: never given to the fit.
class TruthLog {
 public:
  TruthLog(EmulatorSide& side, const std::filesystem::path& csv);
  ~TruthLog();
  TruthLog(const TruthLog&) = delete;
  TruthLog& operator=(const TruthLog&) = delete;
  void attach(CalibrationOptions& options);  // sets its on_measurement
  const std::vector<MeasuredJoints>& samples() const { return samples_; }

 private:
  EmulatorSide& side_;
  std::FILE* csv_ = nullptr;
  std::vector<MeasuredJoints> samples_;
};

// The true values of the fit's parameters for the emulated robot built from `description`
// (report and tests only, never given to the twin), in the fit's units:
// - the joint map as the truth measured it at the routine's poses: where each joint rests
//   against the firmware's counts, from each side of its dead band (so it includes what the
//   build's parameters alone do not say: a switch closing between two steps, a joint coasting
//   into its dead band); NaN without samples;
// - the links and the jaw as the build drew them;
// - the webcam as built, as the change from the description's (adjustment()).
std::array<double, calib::kParamCount> true_parameters(const RobotModel& description,
                                                       const std::vector<MeasuredJoints>& samples);
// The build's drawn parameters themselves, in the fit's units (the camera as above).
std::array<double, calib::kParamCount> drawn_parameters(const RobotModel& description);
// The fit's values in the units of true_parameters (the camera as the change from the
// description's camera rather than from the pattern's).
std::array<double, calib::kParamCount> identified_parameters(const RobotModel& description,
                                                             const calib::Fit& fit);

// Each parameter identified beside the truth and the draw (key units), and the table said.
std::vector<CalibrationParameter> compare_parameters(const RobotModel& description,
                                                     const calib::Fit& fit,
                                                     const std::vector<MeasuredJoints>& samples);
void say_comparison(const std::vector<CalibrationParameter>& params, const Say& say);

// The demo's calibration step with the emulated robot: the test poses as the description is,
// the routine and its overlay (written to `overlay`), the hub switched to the calibrated
// description, the same test poses again; the figures and their metrics in the current run.
Result<CalibrationFigures> calibration_phase(Hub& hub, EmulatorSide& side, NetCamera& camera,
                                             const std::filesystem::path& base_config,
                                             const std::filesystem::path& overlay,
                                             std::uint64_t test_seed, const Say& say);

// A whole calibration session (`scaratwin calibrate`, Python's scaratwin.calibrate): the
// processes (the emulated robot, or a real board and its webcam), a hub without a database,
// the routine with its operator, the overlay written.
struct CalibrateOptions {
  std::string config_path;        // the base description (empty: the default one)
  std::string serial;             // a real robot on this port; empty: the emulated robot
  std::string camera;             // a real robot's webcam, HOST:PORT (needed with `serial`)
  std::filesystem::path out_dir;  // exists; the logs and the truth log go here
  std::filesystem::path overlay;  // the overlay to write (empty: default_overlay_path)
  double robot_speed = 1.0;       // the emulated robot's seconds per wall second
  long long as_built_seed = -1;   // the emulated robot's build (-1: the description's)
  int marker_poses = 24;
  int touch_offs = 4;
  unsigned seed = 1;  // of the marker poses
  // Set (from any thread) to stop: the robot stops at once and the routine fails as
  // interrupted; no overlay is written.
  const std::atomic<bool>* stop = nullptr;
  std::filesystem::path bin_dir;  // scaratwin-sim and -robot (empty: beside this program)
};

struct CalibrateResult {
  CalibrationRun run;
  std::filesystem::path overlay;
  // each parameter beside the truth (the emulated robot only; empty with a real one)
  std::vector<CalibrationParameter> compared;
};

// Runs a calibration session. `person`: the operator at a real robot (the emulated robot has
// its own); a real robot without one is refused. `model` is the base description as loaded
// (its as-built seed set to the emulated robot's, for the comparison only).
Result<CalibrateResult> run_calibration(const RobotModel& model, const CalibrateOptions& options,
                                        CalibrationOperator* person, const Say& say);

}  // namespace scaratwin::session
