// The twin's tasks, built from the hub's statements: moving the physical robot to a target
// with the virtual robot following (digital control), and the colour-sorting task planned from
// a camera picture, run first in the simulator and then replayed on the robot (digital
// prediction). Each returns the figures the paper reports.
#pragma once

#include <cstdint>
#include <vector>

#include "scaratwin/hub/hub.hpp"
#include "scaratwin/vision/vision.hpp"

namespace scaratwin {

// Final tool errors of a control move (m).
struct ControlFigures {
  ToolPose target;
  ToolPose physical;  // FK of the robot's reported step counts
  ToolPose virtual_;  // FK of the simulator's joints
  double target_physical_m = 0.0;
  double target_virtual_m = 0.0;
  double virtual_physical_m = 0.0;
  int points = 0;
};

// Digital control: IK of `target` nearest the robot's current joints, a quintic with the
// paper's 60 samples (timed within the motor limits), loaded into the robot while the mirror
// runs. Nothing moves when the target is unreachable (the error says why).
Result<ControlFigures> move_to(Hub& hub, const ToolPose& target, int samples = 60);

// Like move_to, for a tool position with any feasible heading (tried in 15 degree steps from
// `yaw_rad`).
Result<ControlFigures> move_to_position(Hub& hub, double x_m, double y_m, double z_m,
                                        double yaw_rad = 0.0);

// A cube to sort: where it is and which colour.
struct SortItem {
  CubeColor color = CubeColor::kRed;
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

// The whole sorting task as one timed trajectory with gripper events, from `start`.
struct SortPlan {
  std::vector<SortItem> items;
  JointTrajectory trajectory;
};
Result<SortPlan> plan_sorting(const RobotModel& model, const JointVector& start,
                              const std::vector<SortItem>& items, double speed_scale = 1.0);

// A random layout of `cubes` cubes (red, green, blue, in colour order) drawn from `seed`: each
// at a spot of the paper's workspace that the robot reaches at grasp height with some wrist
// heading (0, 90, 180 or -90 deg), 0.45-0.92 of the arm's reach around the shoulder axis on the
// camera's side, at least 6 cm from the column, off the trays (half a tray plus a cube from
// their centres), in the overhead camera's picture (5 % from its edges), at least
// kArmClearance_m in the table's plane from the arm standing at `arm` (where it is when the
// cameras look: what it hides they cannot find), and more than `min_gap_m` from every other
// cube, centre to centre (room for the gripper's fingers). The same seed and arm give the
// same layout. An error (HubError::kTask) when 1000 draws find no spot for a cube.
inline constexpr double kArmClearance_m = 0.05;
Result<std::vector<SortItem>> random_layout(const RobotModel& model, std::uint64_t seed, int cubes,
                                            const JointVector& arm, double min_gap_m = 0.045);

// Cubes from a camera picture (the paper's colour recognition).
Result<std::vector<SortItem>> recognise_cubes(Hub& hub, const RobotModel& model);

// How many cubes of the scene lie inside the tray of their colour.
int cubes_in_trays(const RobotModel& model, const std::vector<protocol::ObjectPose>& objects);

}  // namespace scaratwin
