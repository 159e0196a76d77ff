// Clearance between the arms of a workcell along their planned paths, checked before anything
// moves (docs/workcell.md "Arms apart on their paths"). Pure: no I/O, no clock.
//
// Each robot of the workcell follows a joint trajectory from a start time (before it the robot
// stands at the trajectory's first sample, after it at its last); between samples the joints
// move linearly, as the robot's firmware interpolates its points. The check is exact for that
// motion, not only at samples: on a grid that holds every sample time of every trajectory, it
// bounds how far each arm can move within a step (the elbow travels at most |dq2| a2 on its
// circle, the wrist and the tool at most |dq2| a2 + |dq2 + dq3| a3, and every other point of a
// link at most what its ends do) and subdivides each step until that bound is under
// `max_step_m`; the arms keep `clearance_m` throughout when, at every grid time, their distance
// seen from above minus both bounds is at least `clearance_m`.
#pragma once

#include <optional>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/workcell.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {

// One robot's motion: `trajectory` (at least one sample) from `start_s` on, in the workcell's
// common time (s). A robot that stands still is a trajectory of one sample.
struct RobotMotion {
  const JointTrajectory* trajectory = nullptr;
  double start_s = 0.0;
};

struct ClearanceOptions {
  double clearance_m = 0.020;  // the least distance between two arms seen from above
  double max_step_m = 0.001;   // the most an arm may move between two looks (m)
};

// Where two arms come closest (or closer than the clearance).
struct ArmApproach {
  double t_s = 0.0;  // common time of the look
  int robot_a = 0, robot_b = 1;
  double distance_m = 0.0;  // seen from above, at t_s (0 when the arms cross)
  double bound_m = 0.0;     // the least distance the step after t_s can reach (distance - moves)
  JointVector q_a{}, q_b{};
};

struct ClearanceReport {
  ArmApproach closest;               // the smallest bound over the whole motion
  int looks = 0;                     // grid times looked at
  std::optional<ArmApproach> first;  // the first look whose bound is under the clearance
};

// Checks `motions` (one per robot of `workcell`, in its order) for the whole time they take.
// PlanError::kBadArgument for a count that is not the workcell's, an empty or missing
// trajectory, a start that is not finite, or options that are not positive; the report
// otherwise (first empty: the arms keep the clearance).
Result<ClearanceReport> check_clearance(const Workcell& workcell,
                                        const std::vector<RobotMotion>& motions,
                                        const ClearanceOptions& options = {});

// What a planner answers for `report`: Ok when the arms keep the clearance, else
// PlanError::kCollision naming the two robots, when, how close and the clearance.
Status clearance_status(const Workcell& workcell, const ClearanceReport& report,
                        const ClearanceOptions& options = {});

}  // namespace scaratwin
