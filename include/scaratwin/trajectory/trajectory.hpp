// Trajectory planning in joint space and along Cartesian lines, the paper's "jtraj" and more.
// Pure: no I/O, no clock. Every planner either returns a trajectory that stays inside every
// joint limit and every motor speed and acceleration limit of the robot model, or an error
// that says which limit or which sample failed.
//
// Units: time s, d1 m, angles rad; derivatives per second and per second squared.
#pragma once

#include <span>
#include <vector>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/kinematics.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

// One sample of a joint trajectory.
struct JointSample {
  double t_s = 0.0;
  JointVector q{};    // position (m, rad)
  JointVector qd{};   // velocity (m/s, rad/s)
  JointVector qdd{};  // acceleration (m/s^2, rad/s^2)
};

enum class GripperAction { kGrip, kRelease };

// A gripper command at a time of the trajectory.
struct GripperEvent {
  double t_s = 0.0;
  GripperAction action = GripperAction::kGrip;
};

struct JointTrajectory {
  std::vector<JointSample> samples;  // strictly increasing t_s, first at t = 0
  std::vector<GripperEvent> events;  // sorted by t_s
  double duration_s() const { return samples.empty() ? 0.0 : samples.back().t_s; }
};

// Error codes of the planners: PlanError (scaratwin/core/error_codes.hpp, 10..19).

// The paper's jtraj: fifth-order polynomial from q0 to q1 with zero velocity and acceleration
// at both ends, `samples` samples evenly spaced over `duration_s`. No limit check.
JointTrajectory quintic(const JointVector& q0, const JointVector& q1, double duration_s,
                        int samples = 60);

// The same samples written into `out` (out.size() >= 2 samples over `duration_s`), without
// allocating: for callers that replan often into a buffer they keep.
void quintic_into(const JointVector& q0, const JointVector& q1, double duration_s,
                  std::span<JointSample> out);

// Shortest duration for which a quintic from q0 to q1 honours every motor's limits.
double quintic_min_duration(const RobotModel& model, const JointVector& q0, const JointVector& q1);

struct QuinticOptions {
  int samples = 60;         // the paper's 60 samples
  double duration_s = 0.0;  // 0: the shortest duration that honours the motor limits
};
Result<JointTrajectory> plan_quintic(const RobotModel& model, const JointVector& q0,
                                     const JointVector& q1, const QuinticOptions& options = {});

// Synchronised trapezoidal (linear segments, parabolic blends) motion: every motor follows the
// same normalised profile, so all joints start and arrive together and the slowest motor runs
// at its speed or acceleration limit. Sampled every `dt_s` plus the final point.
struct TrapezoidOptions {
  double dt_s = 0.01;
  double speed_scale = 1.0;  // fraction (0, 1] of the motor speed limits to use
  double accel_scale = 1.0;  // fraction (0, 1] of the motor acceleration limits to use
};
Result<JointTrajectory> plan_trapezoid(const RobotModel& model, const JointVector& q0,
                                       const JointVector& q1, const TrapezoidOptions& options = {});

enum class Profile { kQuintic, kTrapezoid };

// Through a list of joint points, stopping at each (start = points[0]).
struct ViaOptions {
  Profile profile = Profile::kTrapezoid;
  TrapezoidOptions trapezoid;
  int quintic_samples = 60;  // per segment
};
Result<JointTrajectory> plan_via_points(const RobotModel& model,
                                        const std::vector<JointVector>& points,
                                        const ViaOptions& options = {});

// Straight tool line from the tool pose at q0 to `goal` (yaw interpolated the short way), IK
// at every sample seeded by the previous one, timed so that no motor limit is exceeded.
struct LineOptions {
  double max_step_m = 0.001;  // spacing of the IK samples along the line
  double dt_s = 0.01;         // spacing of the output samples in time
  double speed_scale = 1.0;
  double accel_scale = 1.0;
};
Result<JointTrajectory> plan_line(const RobotModel& model, const JointVector& q0,
                                  const ToolPose& goal, const LineOptions& options = {});

// Pick and place: approach above the pick point, descend in a line, grip, lift, travel in
// joint space to above the place point, descend, release, retreat. One timed trajectory with
// the gripper events.
struct PickPlaceRequest {
  ToolPose pick;   // tool pose at which the object is gripped
  ToolPose place;  // tool pose at which it is released
  double approach_height_m = 0.04;
  double grip_dwell_s = 0.4;  // time standing still while the gripper closes or opens
  double speed_scale = 1.0;
  double accel_scale = 1.0;
  double dt_s = 0.01;
};
Result<JointTrajectory> plan_pick_place(const RobotModel& model, const JointVector& q0,
                                        const PickPlaceRequest& request);

// Checks every sample against the joint limits and the motor speed and acceleration limits
// (relative slack `tolerance`). The error names the sample, the time, the joint or motor and
// the limit.
Status check_limits(const RobotModel& model, const JointTrajectory& trajectory,
                    double tolerance = 1e-6);

// Motor velocities (steps/s for Z, J2, J3; deg/s for the wrist) of a joint velocity.
std::array<double, 4> motor_rates(const RobotModel& model, const JointVector& qd);

// Appends `segment` after `trajectory`, shifting its times (and events) by the current end.
// The first sample of `segment` is dropped when it repeats the last one.
void append(JointTrajectory& trajectory, const JointTrajectory& segment);

// Adds a stationary sample `dwell_s` after the end.
void append_dwell(JointTrajectory& trajectory, double dwell_s);

// Linear interpolation of the trajectory's position at time t (clamped to its ends).
JointVector sample_at(const JointTrajectory& trajectory, double t_s);

}  // namespace scaratwin
