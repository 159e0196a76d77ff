// A workcell: the scene (table, trays, cubes, camera, pattern) once, in the world frame W, and
// the robots that share it, each with its own description and the pose of its base B_i in W.
// The paper's setup is a workcell of one robot whose base frame is the world frame. Pure: no
// I/O (config/workcell_config.hpp reads the file; docs/workcell.md describes it).
//
// Frames: W is robot 0's base frame (validate() refuses a first robot elsewhere), z up. Every
// base B_i stands at (x_m, y_m, z_m) in W, turned by yaw_rad about W's z axis; its x axis is
// the direction the arm points at q2 = q3 = 0.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

// Pose X_WB of a robot base in the world: position (m) and rotation about W's z axis (rad).
struct BasePose {
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
  double yaw_rad = 0.0;
};

// One robot of the workcell. `model.scene` is ignored: the workcell's scene is the one truth
// (scene_in_base() gives the robot its view of it).
struct RobotInstance {
  std::string name;              // unique; prefixes the robot's names in the MJCF and URDF
  BasePose base;                 // X_WB
  RobotModel model;              // the robot's description
  std::string description_file;  // where `model` came from (for messages); may be empty
};

struct Workcell {
  SceneModel scene;  // in the world frame W
  std::vector<RobotInstance> robots;
};

// Limits that validate() enforces between robots.
inline constexpr double kMinBaseDistanceM = 0.120;  // between two bases, seen from above
inline constexpr double kMinArmDistanceM = 0.050;   // between two arms at home, seen from above
inline constexpr std::size_t kMaxRobotNameLength = 32;

// The paper's setup: one robot named "robot" at the origin, the scene its description's.
Workcell single_robot_workcell(const RobotModel& model);

// Refuses (ConfigError::kInvalid, naming the robots and the figures): no robot; a robot whose
// description fails validate(RobotModel); a base pose that is not finite; a name used twice;
// with more than one robot, a name that is not 1..32 characters of [a-z0-9_-]; a first robot
// not at the origin with yaw 0; two bases closer than kMinBaseDistanceM; two arms at their home
// poses closer than kMinArmDistanceM (the base -> shoulder -> elbow -> wrist -> tool polyline of
// each, seen from above); a base inside a tray's footprint.
Status validate(const Workcell& workcell);

// The robots' names for messages: "'left', 'right'" (empty for no robot).
std::string robot_names(const Workcell& workcell);

// Index of the robot called `name`; ConfigError::kUnknownRobot, listing the robots, otherwise.
Result<int> robot_index(const Workcell& workcell, std::string_view name);

// p_W from p_B (m) for a base at `base`, and the inverse.
std::array<double, 3> base_to_world(const BasePose& base, const std::array<double, 3>& p_B);
std::array<double, 3> world_to_base(const BasePose& base, const std::array<double, 3>& p_W);

// The points of robot `robot`'s arm at joints `q` (m, rad), in W (m): base, shoulder (J2
// axis), elbow (J3 axis), wrist (J4 axis), tool, at the height of their DH frames.
std::array<std::array<double, 3>, 5> arm_points(const Workcell& workcell, int robot,
                                                const JointVector& q);
// The same at the robot's home pose.
std::array<std::array<double, 3>, 5> home_arm_points(const Workcell& workcell, int robot);

// The distance (m) from p to the segment a-b seen from above (in the xy plane; z ignored).
double distance_to_segment_xy(const std::array<double, 3>& p, const std::array<double, 3>& a,
                              const std::array<double, 3>& b);

// The distance (m) between robot a's arm at q_a and robot b's at q_b seen from above: the
// closest approach of their base -> shoulder -> elbow -> wrist -> tool polylines in W's xy
// plane (0 when they cross). A SCARA's links sweep the same band of heights, so two arms that
// meet seen from above collide.
double arm_distance(const Workcell& workcell, int a, const JointVector& q_a, int b,
                    const JointVector& q_b);

// Robot `robot`'s description with the workcell's scene expressed in its base frame: table,
// grasp height, trays' centres, the camera (its image turns with the base: a camera looking
// straight down gets its roll reduced by the base's yaw) and the pattern. Each tray keeps its
// edges parallel to W's axes in the MJCF; a robot turned by a yaw that is not a multiple of 90
// degrees sees them turned.
RobotModel scene_in_base(const Workcell& workcell, int robot);

}  // namespace scaratwin
