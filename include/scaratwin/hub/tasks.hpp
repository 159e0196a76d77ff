// The twin's tasks, built from the hub's statements: moving the physical robot to a target
// with the virtual robot following (digital control), and the colour-sorting task planned from
// a camera picture, run first in the simulator and then replayed on the robot (digital
// prediction). Each returns the figures the paper reports.
#pragma once

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

// Cubes from a camera picture (the paper's colour recognition).
Result<std::vector<SortItem>> recognise_cubes(Hub& hub, const RobotModel& model);

// How many cubes of the scene lie inside the tray of their colour.
int cubes_in_trays(const RobotModel& model, const std::vector<protocol::ObjectPose>& objects);

}  // namespace scaratwin
