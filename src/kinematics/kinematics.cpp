#include "scaratwin/kinematics/kinematics.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "fast_trig.hpp"
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

// Shifts `q` by whole turns into [lim.min, lim.max], choosing the turn nearest to `near`.
// Returns false (leaving q unchanged) when no shift fits. Written without data-dependent
// branches: it sits in the IK hot path, where random targets defeat branch prediction.
bool wrap_into(double& q, const JointLimit& lim, double near) {
  // the lowest turn at or above lim.min (k = 0 leaves q bit-exact).
  const double u = (q - lim.min) * (1.0 / kTwoPi);
  double k = static_cast<double>(static_cast<long long>(u));
  k -= static_cast<double>(k > u);
  const double c0 = k == 0.0 ? q : q - k * kTwoPi;
  const double c1 = c0 + kTwoPi;  // the next turn, if the range spans more than one turn
  const bool use_c1 = c1 <= lim.max && std::abs(c1 - near) < std::abs(c0 - near);
  const double c = use_c1 ? c1 : c0;
  const bool ok = c0 <= lim.max;
  q = ok ? c : q;
  return ok;
}

// The closed-form solution without limits: both elbow branches, angles not wrapped. Returns
// 0 or the IkError code of a pose no elbow can reach.
int solve_raw(const RobotModel& model, const ToolPose& pose, std::array<JointVector, 2>& raw,
              double& r_m) {
  const auto& dh = model.dh;
  if (!std::isfinite(pose.x_m) || !std::isfinite(pose.y_m) || !std::isfinite(pose.z_m) ||
      !std::isfinite(pose.yaw_rad)) {
    return static_cast<int>(IkError::kNotFinite);
  }
  // z: the prismatic joint alone.
  const double d1 = pose.z_m - dh[0].d_m - dh[1].d_m - dh[2].d_m - dh[3].d_m;
  if (!model.limits[0].contains(d1)) return static_cast<int>(IkError::kZOutOfTravel);
  // planar part: wrist centre relative to the shoulder axis.
  double ux = pose.x_m, uy = pose.y_m;
  if (dh[3].a_m != 0.0) {
    ux -= dh[3].a_m * std::cos(pose.yaw_rad);
    uy -= dh[3].a_m * std::sin(pose.yaw_rad);
  }
  if (dh[0].theta_rad == 0.0) {
    ux -= dh[0].a_m;
  } else {
    ux -= dh[0].a_m * std::cos(dh[0].theta_rad);
    uy -= dh[0].a_m * std::sin(dh[0].theta_rad);
  }
  const double a2 = dh[1].a_m, a3 = dh[2].a_m;
  const double r2 = ux * ux + uy * uy;
  r_m = std::sqrt(r2);
  double c3 = (r2 - a2 * a2 - a3 * a3) / (2.0 * a2 * a3);
  if (c3 > 1.0 + kReachSlack) return static_cast<int>(IkError::kBeyondReach);
  if (c3 < -1.0 - kReachSlack) return static_cast<int>(IkError::kInsideDeadZone);
  c3 = std::clamp(c3, -1.0, 1.0);
  const double s3 = std::sqrt((1.0 - c3) * (1.0 + c3));
  const double q3p = detail::atan2_fast(s3, c3);
  // phi1 = atan2(uy, ux) - atan2(k2, k1), written as one atan2 of the rotated vector.
  const double k1 = a2 + a3 * c3, k2 = a3 * s3;
  const double off1 = dh[0].theta_rad + dh[1].theta_rad;
  for (int b = 0; b < 2; ++b) {
    const double sk2 = b == 0 ? k2 : -k2;
    const double phi1 = detail::atan2_fast(k1 * uy - sk2 * ux, k1 * ux + sk2 * uy);
    const double elbow = b == 0 ? q3p : -q3p;
    JointVector& q = raw[b];
    q[0] = d1;
    q[1] = phi1 - off1;
    q[2] = elbow - dh[2].theta_rad;
    q[3] = pose.yaw_rad - phi1 - elbow - dh[3].theta_rad;
  }
  return 0;
}

// The message of a solve_raw failure.
Error raw_error(const RobotModel& model, const ToolPose& pose, int code, double r_m) {
  const auto& dh = model.dh;
  switch (static_cast<IkError>(code)) {
    case IkError::kNotFinite:
      return ik_error(IkError::kNotFinite, fmt::format("target ({}, {}, {}, {}) is not finite",
                                                       pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad));
    case IkError::kZOutOfTravel: {
      const double off = dh[0].d_m + dh[1].d_m + dh[2].d_m + dh[3].d_m;
      return ik_error(
          IkError::kZOutOfTravel,
          fmt::format("z = {:.6f} m needs d1 = {:.6f} m, outside the Z travel "
                      "[{}, {}] m (tool z from {:.4f} to {:.4f} m)",
                      pose.z_m, pose.z_m - off, model.limits[0].min, model.limits[0].max,
                      model.limits[0].min + off, model.limits[0].max + off));
    }
    case IkError::kBeyondReach:
      return ik_error(IkError::kBeyondReach,
                      fmt::format("target ({:.6f}, {:.6f}) m is {:.6f} m from the shoulder "
                                  "axis, beyond the reach of {:.6f} m",
                                  pose.x_m, pose.y_m, r_m, dh[1].a_m + dh[2].a_m));
    default:
      return ik_error(IkError::kInsideDeadZone,
                      fmt::format("target ({:.6f}, {:.6f}) m is {:.6f} m from the shoulder "
                                  "axis, inside the dead zone of radius {:.6f} m",
                                  pose.x_m, pose.y_m, r_m, std::abs(dh[1].a_m - dh[2].a_m)));
  }
}

// Wraps the revolute joints of `q` into their limits near `near`; returns the first joint
// that does not fit, or -1.
int wrap_joints(const RobotModel& model, JointVector& q, const JointVector& near) {
  int bad = -1;
  for (int j = 1; j < kNumJoints; ++j) {
    if (!wrap_into(q[j], model.limits[j], near[j])) {
      q[j] = wrap_angle(q[j]);
      if (bad < 0) bad = j;
    }
  }
  return bad;
}

}  // namespace

const char* joint_name(int index) {
  static constexpr const char* kNames[] = {"j1", "j2", "j3", "j4"};
  return (index >= 0 && index < kNumJoints) ? kNames[index] : "j?";
}

double wrap_angle(double rad) {
  if (rad > -kPi && rad <= kPi) return rad;
  double r = rad - kTwoPi * std::floor((rad + kPi) / kTwoPi);  // in [-pi, pi)
  if (r <= -kPi) r += kTwoPi;
  if (r > kPi) r -= kTwoPi;
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
  double s1, c1, s2, c2;
  detail::sincos_fast(p1, s1, c1);
  detail::sincos_fast(p2, s2, c2);
  p.x_m = dh[1].a_m * c1 + dh[2].a_m * c2;
  p.y_m = dh[1].a_m * s1 + dh[2].a_m * s2;
  if (p0 == 0.0) {
    p.x_m += dh[0].a_m;
  } else {
    p.x_m += dh[0].a_m * std::cos(p0);
    p.y_m += dh[0].a_m * std::sin(p0);
  }
  if (dh[3].a_m != 0.0) {
    p.x_m += dh[3].a_m * std::cos(p3);
    p.y_m += dh[3].a_m * std::sin(p3);
  }
  p.z_m = q[0] + dh[0].d_m + dh[1].d_m + dh[2].d_m + dh[3].d_m;
  p.yaw_rad = wrap_angle(p3);
  return p;
}

Result<IkBranches> inverse_branches(const RobotModel& model, const ToolPose& pose) {
  IkBranches out;
  double r_m = 0.0;
  if (int code = solve_raw(model, pose, out.solutions, r_m); code != 0) {
    return raw_error(model, pose, code, r_m);
  }
  for (JointVector& q : out.solutions) wrap_joints(model, q, model.home);
  return out;
}

namespace {

// Both branches wrapped near the seed, the valid ones first and nearest first. Returns the
// number of valid solutions; on 0, `bad` holds the failing joint of each branch.
int solve_within_limits(const RobotModel& model, std::array<JointVector, 2>& q,
                        const JointVector& seed, std::array<int, 2>& bad) {
  for (int b = 0; b < 2; ++b) {
    bad[b] = wrap_joints(model, q[b], seed);
  }
  if (bad[0] >= 0 && bad[1] >= 0) return 0;
  if (bad[0] >= 0) {
    q[0] = q[1];
    return 1;
  }
  if (bad[1] >= 0 || q[0] == q[1]) return 1;  // one valid, or stretched/folded (same pose)
  if (joint_distance2(q[1], seed) < joint_distance2(q[0], seed)) std::swap(q[0], q[1]);
  return 2;
}

Error limit_error(const RobotModel& model, const std::array<JointVector, 2>& q,
                  const std::array<int, 2>& bad, const JointVector& seed) {
  // report the branch nearer the seed.
  const int b = joint_distance2(q[0], seed) <= joint_distance2(q[1], seed) ? 0 : 1;
  const int j = bad[b];
  const IkError code = j == 1 ? IkError::kJ2Limit : j == 2 ? IkError::kJ3Limit : IkError::kJ4Limit;
  return ik_error(code,
                  fmt::format("no elbow solution within the joint limits: {} = {:.3f} deg is "
                              "outside [{:.1f}, {:.1f}] deg (other elbow: {} out of limits)",
                              joint_name(j), rad_to_deg(q[b][j]), rad_to_deg(model.limits[j].min),
                              rad_to_deg(model.limits[j].max), joint_name(bad[1 - b])));
}

}  // namespace

Result<IkSolutions> inverse_all(const RobotModel& model, const ToolPose& pose,
                                const JointVector& seed) {
  IkSolutions out;
  double r_m = 0.0;
  if (int code = solve_raw(model, pose, out.solutions, r_m); code != 0) {
    return raw_error(model, pose, code, r_m);
  }
  std::array<int, 2> bad{};
  out.count = solve_within_limits(model, out.solutions, seed, bad);
  if (out.count == 0) return limit_error(model, out.solutions, bad, seed);
  return out;
}

Result<JointVector> inverse(const RobotModel& model, const ToolPose& pose,
                            const JointVector& seed) {
  std::array<JointVector, 2> q;
  double r_m = 0.0;
  if (int code = solve_raw(model, pose, q, r_m); code != 0) {
    return raw_error(model, pose, code, r_m);
  }
  std::array<int, 2> bad{};
  if (solve_within_limits(model, q, seed, bad) == 0) return limit_error(model, q, bad, seed);
  return q[0];
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
