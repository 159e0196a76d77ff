// The calibration statement: measures the robot the hub is connected to and fits its model
// (calibration/calibration.hpp). The measurements a desktop robot's owner has:
//  1. homing against the endstops (the joint zeros are measured from the switches);
//  2. the overhead webcam sees the printed pattern on the table (the camera's pose and lens);
//  3. the webcam sees the tool's markers at poses spread over the workspace, in both elbow
//     configurations, at several heights and wrist angles, each joint reaching them from both
//     sides;
//  4. touch-offs: the operator jogs the tool onto known marks (the trays' corners) at two or
//     more wrist angles (the operator, a person at a real robot, is scripted in emulation).
// Then the fit; a refused fit writes nothing. The robot moves only through the hub.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "scaratwin/calibration/calibration.hpp"
#include "scaratwin/core/result.hpp"
#include "scaratwin/hub/hub.hpp"
#include "scaratwin/hub/tool_tracker.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin {

// The person at the robot.
class CalibrationOperator {
 public:
  virtual ~CalibrationOperator() = default;
  // Lays the printed pattern on the table (on) or takes it away (off).
  virtual Status pattern(bool on) = 0;
  // The tool is above `mark` (at most a few millimetres off): jog it onto the mark, the tool
  // point at the mark's height, and return when it is there.
  virtual Status touch_off(Hub& hub, const std::string& name,
                           const std::array<double, 3>& mark_B) = 0;
};

struct CalibrationOptions {
  int marker_poses = 24;
  int touch_offs = 4;   // of the marks of touch_marks(), in their order (at most 6)
  int width_px = 1280;  // the webcam's pictures for calibration
  int height_px = 960;
  double settle_s = 0.25;  // rest before a picture
  std::uint64_t seed = 1;  // of the poses
  calib::FitOptions fit;
  std::function<void(const std::string&)> progress;  // one line per stage
  // Called after each marker view and touch-off is taken (e.g. to log it beside a measuring
  // instrument); the routine never waits on it.
  std::function<void(const calib::MarkerView*, const calib::TouchOff*)> on_measurement;
};

struct CalibrationRun {
  calib::Measurements measurements;
  calib::Fit fit;
  RobotModel calibrated;
  WebcamFit camera;      // the webcam on the printed pattern (before the joint fit)
  double robot_s = 0.0;  // the routine's duration on the robot's clock
  int pictures = 0;
};

bool is_calibrated(const RobotModel& model);

// A uniform draw in [lo, hi) from a splitmix64 state: the same poses on every machine.
double seeded_uniform(std::uint64_t& state, double lo, double hi);

// Unidirectional positioning: a quick move to `target` less `dir` x 1.5 deg on J2 and J3 (and
// 0.25 mm on Z), then a slow last 1.5 deg towards it (Z and J2, then J3 alone). A belt drive comes
// to rest on one flank of its dead band only when the last motion was slow: after a fast move the
// arm's own momentum and the other link's reaction can leave it on either. `dir` (+1 / -1 per
// stepper joint) is then the side each joint rests on.
Status approach(Hub& hub, const JointVector& target, const MotionDirections& dir);

// The marks of the touch-offs: crosses on the mat clear of the trays, in the order that
// spreads the first few over the workspace, at the height of the tool point on its gauge.
std::vector<std::pair<std::string, std::array<double, 3>>> touch_marks(const RobotModel& model);

// The marker poses (firmware joints): seeded, inside the joint limits with a margin, both
// markers well inside the picture of `camera` (the webcam as the pattern calibrated it),
// both elbows, spread in height and wrist angle; in visiting_order().
// Poses in the order that keeps the robot's moves short: one elbow configuration, then the
// other, each visited nearest first (by the time a quintic move to it takes), from home.
std::vector<JointVector> visiting_order(const RobotModel& model, std::vector<JointVector> poses);

std::vector<JointVector> marker_poses(const RobotModel& model, const WebcamModel& camera, int count,
                                      std::uint64_t seed);

// Runs the routine on the connected robot (homes it first). The hub's description must be a
// base description, not a calibrated overlay.
Result<CalibrationRun> calibrate(Hub& hub, NetCamera& camera, CalibrationOperator& op,
                                 const CalibrationOptions& options = {});

}  // namespace scaratwin
