// The robot description as a constant model: the DH table, joint limits, home pose, motor
// conversions, servo ranges and the scene. It is loaded and validated once (see
// scaratwin/config/robot_config.hpp) and passed by const reference everywhere. Every field is
// SI unless its name says otherwise. The defaults are the paper's robot (Zhang et al., Sensors
// 2024, 24, 7183, Table 1) as described in DESIGN.md.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/core/robot_types.hpp"
#include "scaratwin/kinematics/physical.hpp"

namespace scaratwin {

// kNumJoints, JointVector, CubeColor and color_name(): core/robot_types.hpp.

enum class JointType { kPrismatic, kRevolute };

// One row of the standard DH table (Craig: Rz(theta) Tz(d) Tx(a) Rx(alpha)). For a prismatic
// joint `d_m` is an offset added to the joint variable; for a revolute joint `theta_rad` is an
// offset added to the joint variable.
struct DhRow {
  JointType type = JointType::kRevolute;
  double theta_rad = 0.0;
  double d_m = 0.0;
  double a_m = 0.0;
  double alpha_rad = 0.0;
};

// Travel of one joint, in the joint's SI unit (m or rad).
struct JointLimit {
  double min = 0.0;
  double max = 0.0;
  bool contains(double v) const { return v >= min && v <= max; }
};

// A stepper motor axis: conversion and limits in motor steps.
struct StepperAxis {
  double steps_per_unit = 1.0;  // steps per metre (Z) or per radian (J2, J3)
  double max_speed_steps_s = 5000.0;
  double max_accel_steps_s2 = 1500.0;
};

// A hobby servo: angle range (deg, as the servo sees it) and pulse widths (us) at both ends.
struct ServoSpec {
  double min_deg = 0.0;
  double max_deg = 180.0;
  double pulse_min_us = 544.0;
  double pulse_max_us = 2400.0;
  double max_speed_deg_s = 300.0;
};

// Motor conversions: Z, J2 and J3 are steppers; J4 (wrist) and the gripper are servos.
struct MotorModel {
  StepperAxis z;
  StepperAxis j2;
  StepperAxis j3;
  // The J3 motor must also move this many steps per J2 motor step (belt coupling).
  double j3_per_j2_coupling = 0.8;
  ServoSpec wrist;
  ServoSpec gripper;
  double gripper_open_deg = 0.0;
  double gripper_closed_deg = 75.0;
};

// The endstop switches of the three steppers (Z, J2, J3, in stepper order), which homing seeks.
// Each closes just beyond one end of its joint's travel, on the side homing moves towards.
struct EndstopModel {
  // Joint value at which each switch closes: d1 (m), q2 and q3 (rad). J3's switch senses the
  // joint, so the J2 motor's belt coupling does not move it.
  std::array<double, 3> closes_at{};
  // Direction each axis moves to find its switch: +1 (beyond the upper limit) or -1.
  std::array<int, 3> homing_dir{+1, +1, -1};
  // Motor steps homing backs off a switch after it has closed (every axis).
  int pulloff_steps = 40;
};

// What calibration found about this robot (`scaratwin calibrate` writes it into an overlay
// description, docs/calibration.md). The firmware counts steps from where each endstop closes
// in the description; the robot as built has its switches, lead screw and servo horn a little
// elsewhere. These map the firmware's joint values (its step counts through the description's
// conversions) to the robot's true joints; all zero (the identity) until calibrated.
//   d1 = d1_fw + z_offset + z_scale (d1_fw - z switch)
//   q2 = q2_fw + j2_zero + (homing_dir - dir) backlash / 2     (q3 alike)
//   q4 = (1 + wrist_gain) q4_fw + wrist_offset
// where dir is the direction the joint last moved (+1 / -1; 0 when unknown: the middle of the
// dead band): a belt's output trails its motor by half the dead band.
struct JointCalibration {
  double z_offset_m = 0.0;
  double z_scale = 0.0;
  double j2_zero_rad = 0.0;
  double j3_zero_rad = 0.0;
  double wrist_offset_rad = 0.0;
  double wrist_gain = 0.0;
  std::array<double, 3> backlash{};  // Z (m), J2, J3 (rad): full dead band
  // What calibration added to each DH row's a_m (the links a2, a3 and the jaw offset; m), so
  // that the nominal description stays known (description_identity()).
  std::array<double, kNumJoints> a_delta_m{};
};

// The physical overhead webcam as calibrated (pinhole + radial distortion k1, k2 on normalised
// coordinates, as vision/webcam.hpp's WebcamModel defines them), when the description has one;
// the virtual scene camera stays `camera`.
struct WebcamCalibration {
  bool valid = false;
  std::array<double, 3> pos_m{};
  std::array<double, 9> r_bc{};  // rotation B <- camera, row-major (x right, y up, looks along -z)
  double f_px = 0.0, cx_px = 0.0, cy_px = 0.0;
  double k1 = 0.0, k2 = 0.0;
  int width_px = 640, height_px = 480;
};

// A sorting tray: centre in the base frame and inner size.
struct Tray {
  double x_m = 0.0;
  double y_m = 0.0;
  double size_m = 0.05;
};

// The fixed overhead camera: position, look-at point, vertical field of view, image size and
// roll (a rotation of the camera about its optical axis, right-handed about the camera's z axis,
// which points out of the back of the camera: the picture's content turns the other way).
struct CameraModel {
  std::array<double, 3> pos_m{0.12, 0.0, 0.45};
  std::array<double, 3> look_at_m{0.12, 0.0, -0.03};
  double fovy_deg = 60.0;
  int width_px = 640;
  int height_px = 480;
  double roll_rad = 0.0;
};

// The printed calibration pattern: a board of AprilTags (family tag36h11) lying flat on the
// table, registered to the base (dowels in the base plate). Tag ids run 0, 1, ... along the
// board's x axis, then row by row towards its -y side; each tag's black square is tag_size_m
// across, its white border one eighth of that. The operator puts it down to calibrate the camera
// and takes it away after.
struct PatternModel {
  double x_m = 0.19;  // centre of the board in B
  double y_m = 0.11;
  double yaw_rad = 0.0;         // the board's x axis from B's x axis, about z
  double tag_size_m = 0.04;     // edge of each tag's black square
  double spacing_m = 0.015;     // gap between neighbouring black squares
  int columns = 5;              // tags along the board's x axis
  int rows = 4;                 // and along its y axis
  double thickness_m = 0.0002;  // the printed sheet: its surface is this far above the table
};

// The work scene, in the robot base frame (z = 0 at the base; the table top below it).
struct SceneModel {
  double table_z_m = -0.04;              // table top height
  double cube_size_m = 0.02;             // edge length of the cubes
  double grasp_z_m = -0.02;              // tool z at which a cube on the table is grasped
  double approach_height_m = 0.04;       // clearance above pick/place points
  std::array<Tray, kNumColors> trays{};  // indexed by CubeColor
  CameraModel camera;
  PatternModel pattern;
};

struct RobotModel {
  std::string name = "scara";
  std::array<DhRow, kNumJoints> dh{};
  std::array<JointLimit, kNumJoints> limits{};
  JointVector home{};
  MotorModel motors;
  EndstopModel endstops;
  SceneModel scene;
  PhysicalModel physical;        // the robot as built: only the emulated plant reads it
  JointCalibration calibration;  // identity until `scaratwin calibrate` measured the robot
  WebcamCalibration webcam;      // the physical camera, once calibrated
};

// The paper's robot with every default of DESIGN.md.
RobotModel paper_robot();

// Checks the invariants the rest of scaratwin relies on (SCARA structure, ordered limits,
// positive conversions, home inside limits). The error message names the field and the value.
Status validate(const RobotModel& model);

Result<CubeColor> parse_color(std::string_view name);

// --- description identity (docs/protocol.md section 11) ------------------------------------
//
// What a hub, a simulator and a firmware built from one description share: the nominal
// geometry and motor constants. Not the name, not the scene (the hub's and the simulator's
// business alone), not the as-built `physical` section, not `calibration` or `webcam` (they
// change the hub's view of the robot, not the robot).
//
// A calibrated model's link lengths are the nominal ones plus calibration.a_delta_m; the
// identity takes the nominal ones (dh a_m - a_delta_m).
// The canonical text, one line per item, each ending in '\n', fields separated by ',':
//   dh<i>=<p|r>,theta_rad,d_m,a_m,alpha_rad        i = 1..4 (p prismatic, r revolute)
//   limit<i>=min,max                               i = 1..4 (m or rad)
//   home=d1_m,q2_rad,q3_rad,q4_rad
//   steps_per_unit=z,j2,j3                         (steps per m; per rad)
//   coupling=j3_per_j2
//   servo_wrist=min_deg,max_deg,pulse_min_us,pulse_max_us
//   servo_gripper=min_deg,max_deg,pulse_min_us,pulse_max_us
//   endstop_closes_at=z_m,j2_rad,j3_rad
//   endstop_homing_dir=z,j2,j3                      (+1 / -1, written as integers)
// Numbers are written as C's printf("%.9g") writes them, independent of the locale ("0.067",
// "-1.83259571", "205560", "1e-05"); -0 is written "0".
std::string description_identity(const RobotModel& model);

// The 32-bit FNV-1a hash (offset basis 2166136261, prime 16777619) of `bytes`.
std::uint32_t fnv1a32(std::string_view bytes);

// fnv1a32(description_identity(model)) as 8 lower-case hex digits ("c6e454cc"): the robot
// description's hash that the hello carries.
std::string description_hash(const RobotModel& model);

}  // namespace scaratwin
