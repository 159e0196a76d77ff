// Calibration: the twin learns the robot it is connected to. Measurements a desktop robot's
// owner really has (the overhead webcam seeing the printed pattern and the markers on the
// tool at many poses; touch-off points where the operator jogged the tool onto known marks)
// go into one nonlinear least-squares fit (Eigen's Levenberg-Marquardt) of the link lengths,
// the joint zeros, the Z lead, the wrist servo, the jaw offset, the belts' backlash and the
// camera's pose. Pure: measurements in, a fit out (no I/O, no clock). The routine that takes
// the measurements on a robot is in hub/calibrate.hpp; the overlay file in config.
//
// The model of one measurement (RobotModel::calibration documents the joint map):
//   true joints  q = map(q_fw, dir; theta)
//   marker       pixel = project(camera(theta), marker(model(theta), q))
//   touch-off    tool(model(theta), q) = the mark's position
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/vision/vision.hpp"
#include "scaratwin/vision/webcam.hpp"

namespace scaratwin::calib {

// The identified parameters, in fit order. Robot parameters are deviations from the base
// description (SI); the camera's are the webcam model's adjustments (vision: adjusted()).
enum class Param : int {
  kA2 = 0,
  kA3,
  kZOffset,
  kZScale,
  kJ2Zero,
  kJ3Zero,
  kWristOffset,
  kWristGain,
  kJawOffset,
  kJ2Backlash,
  kJ3Backlash,
  kCamX,
  kCamY,
  kCamZ,
  kCamRx,
  kCamRy,
  kCamRz,
  kCamFocal,
  kCamK1,
  kCount
};
inline constexpr int kParamCount = static_cast<int>(Param::kCount);
inline constexpr int kRobotParams = static_cast<int>(Param::kCamX);

struct ParamInfo {
  std::string_view key;   // overlay and results.json key (its unit in the name)
  double to_si;           // key unit -> SI
  double scale_si;        // the fit's unit (about the size of the build tolerance)
  std::string_view needs; // the measurement that makes it observable
};
const ParamInfo& param_info(Param p);
inline const ParamInfo& param_info(int i) { return param_info(static_cast<Param>(i)); }

using Directions = std::array<int, kNumJoints>;  // last motion of each joint: +1, -1 (0 unknown)

// The webcam as the printed pattern measured it (vision: calibrate_webcam): its pose and lens
// and their standard errors. The fit starts from it and keeps it as prior knowledge (a
// parameter with no standard error, held by the pattern's fit, keeps a loose prior of one
// build tolerance: the markers at several heights may still determine it).
struct CameraPrior {
  WebcamModel camera;
  std::array<double, kWebcamParams> std_error{};
  int corners = 0;  // pattern corners behind it
};

// The robot at rest at one pose, seen by the webcam: the firmware's joint values (its counts
// through the base description), how each joint got there, and the markers' centroids.
struct MarkerView {
  JointVector q_fw{};
  Directions dir{};
  int width_px = 0, height_px = 0;
  std::optional<std::array<double, 2>> axis_px;  // the magenta marker on the wrist axis
  std::optional<std::array<double, 2>> flag_px;  // the cyan flag off the axis
};

// The operator brought the tool point onto a known mark.
struct TouchOff {
  std::string mark;
  std::array<double, 3> mark_B{};  // where the tool point then is (the mark, in B)
  JointVector q_fw{};
  Directions dir{};
};

struct Measurements {
  std::vector<MarkerView> markers;
  std::vector<TouchOff> touches;
};

struct FitOptions {
  double pixel_sigma = 0.25;       // expected centroid / corner noise, px
  double touch_sigma_m = 1.0e-4;   // how well the operator puts the tool on a mark
  double max_pixel_rms = 1.5;      // above this the fit is refused (px)
  double max_touch_rms_m = 0.5e-3; // above this too (m)
  double max_normalised_error = 8; // a parameter's std error above this x its scale: refused
  double outlier_px = 2.0;         // a marker point further off than this is set aside ...
  double max_outlier_fraction = 0.1;  // ... unless more than this share of them are: refused
  int max_iterations = 200;
};

struct Fit {
  std::array<double, kParamCount> value{};      // SI (camera: vision's adjusted() units)
  std::array<double, kParamCount> std_error{};  // SI
  WebcamModel camera;                           // the pattern's camera, adjusted
  double pixel_rms = 0.0;                       // px over the markers
  double marker_rms_px = 0.0;
  double touch_rms_m = 0.0;
  double worst_marker_px = 0.0;
  int pattern_points = 0, marker_views = 0, marker_points = 0, touch_offs = 0;
  int outliers = 0;  // marker points set aside (not counted in marker_points)
  int iterations = 0;
  double fit_seconds = 0.0;  // filled by the caller if it times the fit
};

// What each measurement family holds, and the first missing one (nullopt when complete):
// marker views in both elbow configurations, at several wrist angles and
// heights, each stepper joint approached from both sides, touch-offs at two wrist angles.
std::optional<std::string> missing_measurement(const RobotModel& base, const Measurements& m);

// The fit. Marker points more than `outlier_px` off the best fit (a marker partly hidden or
// mistaken) are set aside, the worst first, and the fit repeated. Errors name the problem:
// too few or degenerate measurements (which one is missing), a parameter the measurements do
// not determine, too many outliers or a residual above its threshold (likely a slipped belt
// or a lost step during the routine).
Result<Fit> fit(const RobotModel& base, const CameraPrior& camera, const Measurements& m,
                const FitOptions& options = {});

// The base description with the fit applied: link lengths, jaw offset, joint map, webcam.
RobotModel apply(const RobotModel& base, const Fit& fit);

// The true joints the model of the fit gives for firmware joints reached moving `dir`.
JointVector true_joints(const RobotModel& calibrated, const JointVector& q_fw, const Directions& dir);

// The markers' positions in B (the magenta one on the wrist axis, the cyan flag).
std::array<double, 3> axis_marker_B(const RobotModel& model, const JointVector& q);
std::array<double, 3> flag_marker_B(const RobotModel& model, const JointVector& q);

// The overlay description (TOML) that records a fit: `base` (the path of the base description
// as the overlay should name it, usually relative to the overlay), when, from how many
// measurements, with what residual, each identified value with its standard error, and the
// calibrated webcam. `load_robot_config` of it gives apply(base, fit).
std::string overlay_text(const RobotModel& base, const Fit& fit, const std::string& base_ref,
                         const std::string& date_utc);

WebcamCalibration to_description(const WebcamModel& camera);
WebcamModel from_description(const WebcamCalibration& w);

}  // namespace scaratwin::calib
