// Forward and inverse kinematics of the 4-axis SCARA (prismatic Z, shoulder, elbow, wrist),
// from the standard DH table of the robot model. Pure: no I/O, no clock, no allocation.
//
// Frames: B is the robot base (z up, x forward), T is the tool (grasp point). Joint order and
// units: d1 (m), q2, q3, q4 (rad). A tool pose is x, y, z (m) of the tool in B and yaw (rad),
// the rotation of T about B's z axis.
#pragma once

#include <array>

#include <Eigen/Core>

#include "scaratwin/core/result.hpp"
#include "scaratwin/kinematics/robot_model.hpp"

namespace scaratwin {

// Position and heading of the tool T in the base B.
struct ToolPose {
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
  double yaw_rad = 0.0;
};

// Error codes of inverse kinematics: IkError (scaratwin/core/error_codes.hpp, 1..9).

// 4x4 homogeneous transform X_BT of the tool in the base (the DH product).
Eigen::Matrix4d forward_transform(const RobotModel& model, const JointVector& q);

// The links of make_urdf() (sim/mjcf.hpp), each in its parent, at joints q: [0] carriage in
// base_link, [1] link1 in carriage, [2] link2 in link1, [3] wrist in link2, [4] tool in wrist.
// A joint's frame turns (or slides, for the prismatic J1) with its joint; their product is
// forward_transform(model, q).
std::array<Eigen::Matrix4d, kNumJoints + 1> link_transforms(const RobotModel& model,
                                                            const JointVector& q);

// Tool pose from joints (closed form of the DH product for a SCARA).
ToolPose forward(const RobotModel& model, const JointVector& q);

// Both elbow solutions of a pose, before limits are applied. Angles are wrapped into the joint
// limits where a 2*pi shift allows it. solutions[0] has the elbow angle q3 >= 0, solutions[1]
// has q3 <= 0 (the same when the arm is stretched or folded).
struct IkBranches {
  std::array<JointVector, 2> solutions{};
};
Result<IkBranches> inverse_branches(const RobotModel& model, const ToolPose& pose);

// Every elbow solution of a pose that lies inside the joint limits (one or two; never zero on
// success), nearest to `seed` first.
struct IkSolutions {
  int count = 0;
  std::array<JointVector, 2> solutions{};
};
Result<IkSolutions> inverse_all(const RobotModel& model, const ToolPose& pose,
                                const JointVector& seed);

// The solution inside the limits nearest to `seed` (the current joint state).
Result<JointVector> inverse(const RobotModel& model, const ToolPose& pose, const JointVector& seed);

// Analytic Jacobian d(x, y, z, yaw) / d(d1, q2, q3, q4) at q.
Eigen::Matrix4d jacobian(const RobotModel& model, const JointVector& q);

// Distance used to pick the nearest solution: sum of squared joint differences, with d1 in
// metres and angles in radians.
double joint_distance2(const JointVector& a, const JointVector& b);

// First joint outside its limits, or -1 when all are inside.
int first_joint_outside_limits(const RobotModel& model, const JointVector& q);

// Name of a joint index ("j1".."j4").
const char* joint_name(int index);

// Wraps an angle to (-pi, pi].
double wrap_angle(double rad);

}  // namespace scaratwin
