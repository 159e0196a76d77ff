// The MuJoCo model of the virtual robot, generated from the robot description so that the
// simulator can never disagree with the kinematics: column, Z carriage, two arm links, wrist, a
// two-finger gripper, the table, one sorting tray per colour, the fixed overhead camera and a
// pool of cubes per colour (MuJoCo 2.2 cannot add bodies at run time, so unused cubes are
// parked far away). Also a URDF of the arm for other tools, and both for a workcell of several
// robots (kinematics/workcell.hpp). Pure: returns text, no I/O.
//
// Frames: the MJCF world frame is the robot base B of kinematics.hpp (z up, x forward). The
// body chain follows the standard DH table row by row, so the site `tool` is exactly the DH
// tool frame T for the joint values j1 (slide, m) and j2, j3, j4 (hinges, rad).
#pragma once

#include <array>
#include <string>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"
#include "scaratwin/kinematics/workcell.hpp"

namespace scaratwin::sim {

// Names used in the generated model (and looked up by the simulator).
inline constexpr const char* kToolSite = "tool";
inline constexpr const char* kCameraName = "overhead";
inline constexpr const char* kGripperBody = "wrist";
inline constexpr const char* kFingerJoints[2] = {"finger_l", "finger_r"};
// The tracking marker: a magenta disc on the wrist axis that the overhead camera follows.
inline constexpr const char* kMarkerGeom = "marker";
inline constexpr double kMarkerRadiusM = 0.006;
// Height of the marker's centre above the wrist body's origin (m).
double marker_above_wrist_m(const RobotModel& model);
// Where the marker's centre is for joints q (in B, m): the wrist axis (the standard DH chain
// of the description for links 1-3; the marker does not turn with q4).
std::array<double, 3> marker_position(const RobotModel& model, const JointVector& q);
// The second marker, which shows the wrist's angle: a cyan disc (rgba 0 1 1) on a thin flag
// fixed to the gripper, kFlagOffsetM off the wrist axis along the gripper's x axis, at the
// magenta marker's height (on top of the elbow link's end, so that the elbow link never hides
// it at any wrist angle).
inline constexpr const char* kFlagMarkerGeom = "flag_marker";
inline constexpr double kFlagMarkerRadiusM = 0.005;
inline constexpr double kFlagOffsetM = 0.025;
// Where its centre is for joints q (in B, m): it turns with q4 (and dh.j4's theta offset).
std::array<double, 3> flag_marker_position(const RobotModel& model, const JointVector& q);

// The printed calibration pattern (scene.pattern): a thin box on the table textured with the
// sheet of vision/webcam.hpp's pattern_sheet(), which the loader supplies as this file.
inline constexpr const char* kPatternGeom = "pattern";
inline constexpr const char* kPatternTextureFile = "scaratwin_pattern.png";

struct MjcfOptions {
  int cubes_per_color = 4;      // size of the cube pool of each colour, >= 1
  double timestep_s = 0.004;    // physics step (4 ms: stable for the servos, welds, 2 cm cubes)
  int offscreen_width_px = 0;   // largest image the camera can render; 0 = camera width
  int offscreen_height_px = 0;  // 0 = camera height
  double cube_mass_kg = 0.008;  // a 2 cm PLA cube
  // Include the pattern (its texture file must then be supplied: Simulation does).
  bool pattern = false;
};

// Geometry of the gripper derived from the cube size (m). Each finger's joint value is its
// extra opening beyond the closed position, in [0, open_travel_m].
struct GripperGeometry {
  double closed_gap_m = 0.0;    // gap between the finger faces when closed (cube + 1 mm)
  double open_travel_m = 0.0;   // travel of each finger from closed to open
  double finger_depth_m = 0.0;  // extent of a finger face along the wrist y axis
  double finger_height_m = 0.0;
};
GripperGeometry gripper_geometry(const RobotModel& model);

// How far the arm's parts reach sideways from its centre line seen from above (the base ->
// shoulder -> elbow -> wrist polyline of workcell.hpp's arm_points), m: the widest of the
// carriage, the two links and the palm (whose corner is farthest, turned any way about the
// wrist axis) and the marker flag. Two arms whose centre lines keep twice this apart do not
// touch.
double arm_half_width_m(const RobotModel& model);

// The MJCF text. Errors: invalid options (message names the option and the valid range).
Result<std::string> make_mjcf(const RobotModel& model, const MjcfOptions& options = {});

// A URDF of the arm (base, carriage, two links, wrist, tool frame) with the joint limits.
Result<std::string> make_urdf(const RobotModel& model);

// The MJCF of a whole workcell (docs/workcell.md). A workcell of one robot is exactly
// make_mjcf() of that robot with the workcell's scene (byte for byte: the simulator's model).
// With more robots: the table (covering every robot's), trays, pattern, camera and cube pool
// once, unprefixed, in the world frame; each robot inside a body "<name>/base_frame" at its base
// pose, every name of the robot prefixed "<name>/" ("left/j1", "right/tool", "left/wrist"), its
// welds "<name>/hold_cube_red_0" and its actuators "<name>/j1". Errors: validate(Workcell)'s,
// and the options' as make_mjcf().
Result<std::string> make_mjcf(const Workcell& workcell, const MjcfOptions& options = {});

// A URDF of the workcell: for one robot, make_urdf() of its model; for more, a link "world"
// with each arm's "<name>/base_link" fixed to it at the base pose (joint "<name>/base_fixed"),
// every link and joint name prefixed "<name>/".
Result<std::string> make_urdf(const Workcell& workcell);

// Body name of a pool cube: "cube_<colour>_<index>".
std::string cube_body_name(CubeColor color, int index);

}  // namespace scaratwin::sim
