#include "scaratwin/kinematics/kinematics.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

constexpr double kTwoPi = 2.0 * kPi;
// Relative slack on the reach test so that targets exactly on the workspace boundary (computed
// by FK) are accepted despite rounding.
constexpr double kReachSlack = 1e-12;

Error ik_error(IkError code, std::string message) {
  return Error{static_cast<int>(code), std::move(message)};
}

// Shifts `q` by whole turns into [lim.min, lim.max], choosing the shift nearest to `near`.
// Returns false (leaving q unchanged) when no shift fits.
bool wrap_into(double& q, const JointLimit& lim, double near) {
  double best = 0.0;
  double best_d = INFINITY;
  const double base = wrap_angle(q);
  for (int k = -2; k <= 2; ++k) {
    const double c = base + kTwoPi * k;
    if (!lim.contains(c)) continue;
    const double d = std::abs(c - near);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  if (best_d == INFINITY) return false;
  q = best;
  return true;
}

}  // namespace

const char* joint_name(int index) {
  static constexpr const char* kNames[] = {"j1", "j2", "j3", "j4"};
  return (index >= 0 && index < kNumJoints) ? kNames[index] : "j?";
}

double wrap_angle(double rad) {
  double r = std::remainder(rad, kTwoPi);  // in [-pi, pi]
  if (r <= -kPi) r += kTwoPi;
  return r;
}

double joint_distance2(const JointVector& a, const JointVector& b) {
  double s = 0.0;
  for (int i = 0; i < kNumJoints; ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return s;
}

int first_joint_outside_limits(const RobotModel& model, const JointVector& q) {
  for (int i = 0; i < kNumJoints; ++i) {
    if (!model.limits[i].contains(q[i])) return i;
  }
  return -1;
}

Eigen::Matrix4d forward_transform(const RobotModel& model, const JointVector& q) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  for (int i = 0; i < kNumJoints; ++i) {
    const DhRow& r = model.dh[i];
    const double theta = r.type == JointType::kRevolute ? r.theta_rad + q[i] : r.theta_rad;
    const double d = r.type == JointType::kPrismatic ? r.d_m + q[i] : r.d_m;
    const double ct = std::cos(theta), st = std::sin(theta);
    const double ca = std::cos(r.alpha_rad), sa = std::sin(r.alpha_rad);
    Eigen::Matrix4d a;
    a << ct, -st * ca, st * sa, r.a_m * ct,  //
        st, ct * ca, -ct * sa, r.a_m * st,   //
        0, sa, ca, d,                        //
        0, 0, 0, 1;
    t = t * a;
  }
  return t;
}

ToolPose forward(const RobotModel& model, const JointVector& q) {
  const auto& dh = model.dh;
  const double p0 = dh[0].theta_rad;
  const double p1 = p0 + q[1] + dh[1].theta_rad;
  const double p2 = p1 + q[2] + dh[2].theta_rad;
  const double p3 = p2 + q[3] + dh[3].theta_rad;
  ToolPose p;
  p.x_m = dh[0].a_m * std::cos(p0) + dh[1].a_m * std::cos(p1) + dh[2].a_m * std::cos(p2);
  p.y_m = dh[0].a_m * std::sin(p0) + dh[1].a_m * std::sin(p1) + dh[2].a_m * std::sin(p2);
  if (dh[3].a_m != 0.0) {
    p.x_m += dh[3].a_m * std::cos(p3);
    p.y_m += dh[3].a_m * std::sin(p3);
  }
  p.z_m = q[0] + dh[0].d_m + dh[1].d_m + dh[2].d_m + dh[3].d_m;
  p.yaw_rad = wrap_angle(p3);
  return p;
}

Result<IkBranches> inverse_branches(const RobotModel& model, const ToolPose& pose) {
  const auto& dh = model.dh;
  if (!std::isfinite(pose.x_m) || !std::isfinite(pose.y_m) || !std::isfinite(pose.z_m) ||
      !std::isfinite(pose.yaw_rad)) {
    return ik_error(IkError::kNotFinite, fmt::format("target ({}, {}, {}, {}) is not finite",
                                                     pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad));
  }
  // z: the prismatic joint alone.
  const double d1 = pose.z_m - dh[0].d_m - dh[1].d_m - dh[2].d_m - dh[3].d_m;
  if (!model.limits[0].contains(d1)) {
    return ik_error(
        IkError::kZOutOfTravel,
        fmt::format("z = {:.6f} m needs d1 = {:.6f} m, outside the Z travel "
                    "[{}, {}] m (tool z from {:.4f} to {:.4f} m)",
                    pose.z_m, d1, model.limits[0].min, model.limits[0].max,
                    pose.z_m - d1 + model.limits[0].min, pose.z_m - d1 + model.limits[0].max));
  }
  // planar part: wrist centre relative to the shoulder axis.
  double px = pose.x_m, py = pose.y_m;
  if (dh[3].a_m != 0.0) {
    px -= dh[3].a_m * std::cos(pose.yaw_rad);
    py -= dh[3].a_m * std::sin(pose.yaw_rad);
  }
  const double ux = px - dh[0].a_m * std::cos(dh[0].theta_rad);
  const double uy = py - dh[0].a_m * std::sin(dh[0].theta_rad);
  const double a2 = dh[1].a_m, a3 = dh[2].a_m;
  const double r2 = ux * ux + uy * uy;
  double c3 = (r2 - a2 * a2 - a3 * a3) / (2.0 * a2 * a3);
  if (c3 > 1.0 + kReachSlack) {
    return ik_error(IkError::kBeyondReach,
                    fmt::format("target ({:.6f}, {:.6f}) m is {:.6f} m from the shoulder axis, "
                                "beyond the reach of {:.6f} m",
                                pose.x_m, pose.y_m, std::sqrt(r2), a2 + a3));
  }
  if (c3 < -1.0 - kReachSlack) {
    return ik_error(IkError::kInsideDeadZone,
                    fmt::format("target ({:.6f}, {:.6f}) m is {:.6f} m from the shoulder axis, "
                                "inside the dead zone of radius {:.6f} m",
                                pose.x_m, pose.y_m, std::sqrt(r2), std::abs(a2 - a3)));
  }
  c3 = std::clamp(c3, -1.0, 1.0);
  const double s3 = std::sqrt((1.0 - c3) * (1.0 + c3));
  const double base_angle = std::atan2(uy, ux);
  IkBranches out;
  for (int b = 0; b < 2; ++b) {
    const double s = b == 0 ? s3 : -s3;
    const double q3p = std::atan2(s, c3);
    const double phi1 = base_angle - std::atan2(a3 * s, a2 + a3 * c3);
    const double phi2 = phi1 + q3p;
    JointVector& q = out.solutions[b];
    q[0] = d1;
    q[1] = phi1 - dh[0].theta_rad - dh[1].theta_rad;
    q[2] = q3p - dh[2].theta_rad;
    q[3] = pose.yaw_rad - phi2 - dh[3].theta_rad;
    for (int j = 1; j < kNumJoints; ++j) {
      if (!wrap_into(q[j], model.limits[j], model.home[j])) q[j] = wrap_angle(q[j]);
    }
  }
  return out;
}

Result<IkSolutions> inverse_all(const RobotModel& model, const ToolPose& pose,
                                const JointVector& seed) {
  auto branches = inverse_branches(model, pose);
  if (!branches) return branches.error();
  IkSolutions out;
  std::array<int, 2> bad_joint{-1, -1};
  for (int b = 0; b < 2; ++b) {
    JointVector q = branches->solutions[b];
    // choose the turn of each angle nearest to the seed.
    for (int j = 1; j < kNumJoints; ++j) wrap_into(q[j], model.limits[j], seed[j]);
    bad_joint[b] = first_joint_outside_limits(model, q);
    if (bad_joint[b] >= 0) continue;
    if (out.count == 1 && joint_distance2(out.solutions[0], q) == 0.0) continue;  // same pose
    out.solutions[out.count++] = q;
  }
  if (out.count == 0) {
    // report the branch nearer the seed.
    const int b = joint_distance2(branches->solutions[0], seed) <=
                          joint_distance2(branches->solutions[1], seed)
                      ? 0
                      : 1;
    const int j = bad_joint[b];
    const JointVector& q = branches->solutions[b];
    const IkError code = j == 1   ? IkError::kJ2Limit
                         : j == 2 ? IkError::kJ3Limit
                                  : IkError::kJ4Limit;
    return ik_error(code,
                    fmt::format("no elbow solution within the joint limits: {} = {:.3f} deg is "
                                "outside [{:.1f}, {:.1f}] deg (other elbow: {} out of limits)",
                                joint_name(j), rad_to_deg(q[j]), rad_to_deg(model.limits[j].min),
                                rad_to_deg(model.limits[j].max), joint_name(bad_joint[1 - b])));
  }
  if (out.count == 2 &&
      joint_distance2(out.solutions[1], seed) < joint_distance2(out.solutions[0], seed)) {
    std::swap(out.solutions[0], out.solutions[1]);
  }
  return out;
}

Result<JointVector> inverse(const RobotModel& model, const ToolPose& pose,
                            const JointVector& seed) {
  auto all = inverse_all(model, pose, seed);
  if (!all) return all.error();
  return all->solutions[0];
}

Eigen::Matrix4d jacobian(const RobotModel& model, const JointVector& q) {
  const auto& dh = model.dh;
  const double p1 = dh[0].theta_rad + q[1] + dh[1].theta_rad;
  const double p2 = p1 + q[2] + dh[2].theta_rad;
  const double p3 = p2 + q[3] + dh[3].theta_rad;
  const double a2 = dh[1].a_m, a3 = dh[2].a_m, a4 = dh[3].a_m;
  const double s1 = std::sin(p1), c1 = std::cos(p1), s2 = std::sin(p2), c2 = std::cos(p2);
  const double s3 = std::sin(p3), c3 = std::cos(p3);
  Eigen::Matrix4d j = Eigen::Matrix4d::Zero();
  // columns: d1, q2, q3, q4; rows: x, y, z, yaw.
  j(2, 0) = 1.0;
  j(0, 1) = -(a2 * s1 + a3 * s2 + a4 * s3);
  j(1, 1) = a2 * c1 + a3 * c2 + a4 * c3;
  j(0, 2) = -(a3 * s2 + a4 * s3);
  j(1, 2) = a3 * c2 + a4 * c3;
  j(0, 3) = -a4 * s3;
  j(1, 3) = a4 * c3;
  j(3, 1) = j(3, 2) = j(3, 3) = 1.0;
  return j;
}

}  // namespace scaratwin
