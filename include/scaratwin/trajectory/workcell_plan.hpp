// Several arms sorting together (docs/workcell.md "Sorting together"): which robot takes each
// pick-and-place (by reach), each robot's trajectories one after the other, and when each
// starts so that no two arms come closer than the clearance on their paths (checked by
// check_clearance, trajectory/clearance.hpp) before anything moves. Pure: no I/O, no clock.
#pragma once

#include <string>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/trajectory/clearance.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {

// One object to carry: tool poses in the world frame W (m, rad about z).
struct WorkcellTask {
  std::string what;  // for messages, e.g. "red cube 0"
  ToolPose pick_W;
  ToolPose place_W;
};

struct WorkcellPlanOptions {
  PickPlaceRequest pick_place;  // heights, dwell, speed (its pick and place are ignored)
  ClearanceOptions clearance;
  double delay_step_s = 0.1;   // a task that would come too close waits in steps of this
  double max_delay_s = 120.0;  // after which it is refused (PlanError::kCollision)
  // Each robot goes home after each of its tasks, so that an arm waiting for its next task
  // stands where the workcell keeps the arms apart, not over a tray the other arm needs.
  bool home_after_each = false;
};

// One planned pick-and-place of one robot.
struct PlannedTask {
  int task = 0;                // index into the tasks
  int robot = 0;               // index into the workcell's robots
  double start_s = 0;          // in the common time
  JointTrajectory trajectory;  // in the robot's own joints, from its pose at start_s
};

struct WorkcellPlan {
  std::vector<int> robot_of_task;         // which robot takes each task
  std::vector<PlannedTask> tasks;         // in the order they were scheduled
  std::vector<JointTrajectory> timeline;  // per robot: its whole motion from time 0 (standing
                                          // while it waits), for check_clearance and to send
  ClearanceReport clearance;              // of the timelines, as planned
  double makespan_s = 0.0;                // when the last robot is done
};

// Robot of each task: of the robots that reach both its pick and its place (inverse
// kinematics within the joint limits, in the robot's base frame; a grasp is the same turned by
// a quarter turn, so the yaw may be), the one with the fewest tasks so far, then the one whose
// base is nearest the pick. PlanError::kUnreachable naming the task when no robot reaches both.
Result<std::vector<int>> assign_by_reach(const Workcell& workcell,
                                         const std::vector<WorkcellTask>& tasks);

// Assigns, plans each robot's pick-and-places in the tasks' order from `start[robot]` (each
// followed by its way home with `home_after_each`), and schedules them: each task starts when
// its robot is free, later when another arm's motion (as already scheduled) would come too
// close, by `delay_step_s` at a time. A task its robot cannot start within `max_delay_s` (an
// arm stands in its way) goes to the next robot that reaches it, in the workcell's order
// (robot_of_task says who took it). Errors: those of assign_by_reach and of the pick-and-place
// planner (naming the task), PlanError::kCollision when no robot that reaches a task can start
// it within `max_delay_s` (the error of the robot it was assigned), kBadArgument for a start
// count that is not the workcell's. The returned timelines keep the clearance.
Result<WorkcellPlan> plan_workcell_sort(const Workcell& workcell,
                                        const std::vector<WorkcellTask>& tasks,
                                        const std::vector<JointVector>& start,
                                        const WorkcellPlanOptions& options = {});

}  // namespace scaratwin
