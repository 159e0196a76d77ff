#include "scaratwin/kinematics/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "fast_trig.hpp"
#include "scaratwin/core/units.hpp"

namespace scaratwin {
namespace {

using detail::Mask2;
using detail::select;
using detail::splat;
using detail::V2d;

constexpr double kTwoPi = 2.0 * kPi;
// Relative slack on the reach test so that targets exactly on the workspace boundary (computed
// by FK) are accepted despite rounding.
constexpr double kReachSlack = 1e-12;
// A joint range below this (rad) holds at most one turn of an angle, with margin for rounding.
constexpr double kNarrowRange = 6.0;
// Below this yaw magnitude (rad) the hot path of inverse() takes its angles without range
// checks.
constexpr double kBoundedAngle = 1e9;
// Below this magnitude the turn count of an angle fits the 1.5 * 2^52 rounding trick.
constexpr double kTurnRange = 1e15;

Error ik_error(IkError code, std::string message) {
  return Error{static_cast<int>(code), std::move(message)};
}

// wrap_angle for every finite angle (and NaN), with a floor: the out-of-line fallback.
[[gnu::noinline]] double wrap_angle_any(double rad) {
  if (rad > -kPi && rad <= kPi) return rad;
  double r = rad - kTwoPi * std::floor((rad + kPi) / kTwoPi);  // in [-pi, pi)
  if (r <= -kPi) r += kTwoPi;
  if (r > kPi) r -= kTwoPi;
  return r;
}

// wrap_angle without data-dependent branches (FK wraps the yaw of random poses): the nearest
// whole turn by the rounding trick, then the ends fixed to (-pi, pi]. Angles already inside
// come back bit-exact (k = 0).
inline double wrap_angle_inline(double rad) {
  if (!(std::abs(rad) < kTurnRange)) return wrap_angle_any(rad);
  const double k = (rad * (1.0 / kTwoPi) + detail::trig::kRoundShift) - detail::trig::kRoundShift;
  const double r = rad - k * kTwoPi;
  return select(r <= -kPi, r + kTwoPi, select(r > kPi, r - kTwoPi, r));
}

// The two elbow branches side by side: lane b of q[j] is joint j of branch b.
using BranchLanes = std::array<V2d, kNumJoints>;

// Shifts each lane of `q` by whole turns into [lim.min, lim.max], choosing the turn nearest to
// `near`. Returns the mask of the lanes that fit. With kKeep the others are left unchanged and
// any angle is handled; without it (the hot path, which never reads the lanes that do not fit)
// |q| must stay below kBoundedAngle. No data-dependent branches: random targets defeat branch
// prediction.
template <bool kKeep>
Mask2 wrap_into(V2d& q, const JointLimit& lim, double near) {
  constexpr double kShift = detail::trig::kRoundShift;
  const V2d max = splat(lim.max);
  if (lim.max - lim.min < kNarrowRange) {
    // one turn at most fits: the one nearest the middle of the range, if inside (k = 0 leaves
    // q bit-exact).
    const V2d v = (q - 0.5 * (lim.min + lim.max)) * (1.0 / kTwoPi);
    const V2d c = q - ((v + kShift) - kShift) * kTwoPi;
    Mask2 ok = detail::mask_and(detail::le(splat(lim.min), c), detail::le(c, max));
    if constexpr (kKeep) {
      ok = detail::mask_and(ok, detail::lt(detail::abs(v), splat(kTurnRange)));
      q = select(ok, c, q);
    } else {
      q = c;
    }
    return ok;
  }
  // the lowest turn at or above lim.min, and the next one if it fits and is nearer.
  const V2d u = (q - lim.min) * (1.0 / kTwoPi);
  const V2d r = (u + kShift) - kShift;
  const V2d k = r - select(detail::lt(u, r), splat(1.0), splat(0.0));
  const V2d c0 = q - k * kTwoPi;
  const V2d c1 = c0 + kTwoPi;
  const Mask2 use_c1 = detail::mask_and(detail::le(c1, max),
                                        detail::lt(detail::abs(c1 - near), detail::abs(c0 - near)));
  Mask2 ok = detail::le(c0, max);
  const V2d c = select(use_c1, c1, c0);
  if constexpr (kKeep) {
    ok = detail::mask_and(ok, detail::lt(detail::abs(u), splat(kTurnRange)));
    q = select(ok, c, q);
  } else {
    q = c;
  }
  return ok;
}

// Wraps the revolute joints of both branches near `near`; fit[j - 1] is the mask of the lanes
// where joint j fits its limits.
template <bool kKeep>
std::array<Mask2, kNumJoints - 1> wrap_lanes(const RobotModel& model, BranchLanes& q,
                                             const JointVector& near) {
  std::array<Mask2, kNumJoints - 1> fit;
  for (int j = 1; j < kNumJoints; ++j) {
    fit[j - 1] = wrap_into<kKeep>(q[j], model.limits[j], near[j]);
  }
  return fit;
}

// The branches as joint vectors; joints that did not fit are wrapped to (-pi, pi] instead, and
// bad[b] is the first such joint of branch b (or -1).
void unpack(const BranchLanes& q, const std::array<Mask2, kNumJoints - 1>& fit,
            std::array<JointVector, 2>& out, std::array<int, 2>& bad) {
  for (int b = 0; b < 2; ++b) {
    bad[b] = -1;
    for (int j = 0; j < kNumJoints; ++j) {
      out[b][j] = q[j][b];
      if (j > 0 && (detail::lanes(fit[j - 1]) & (1 << b)) == 0) {
        out[b][j] = wrap_angle_inline(out[b][j]);
        if (bad[b] < 0) bad[b] = j;
      }
    }
  }
}

// The closed-form solution without limits: both elbow branches, angles not wrapped. Returns
// 0 or the IkError code of a pose no elbow can reach. Without kChecked (the hot path, whose
// yaw is known finite) a failure of any kind returns kUnchecked, and the caller asks the
// checked form which one it was: a NaN or infinity in x, y or z fails the Z or reach test.
constexpr int kUnchecked = -1;
template <bool kChecked>
[[gnu::always_inline]] inline int solve_raw(const RobotModel& model, const ToolPose& pose,
                                            BranchLanes& q, double& r_m) {
  const auto& dh = model.dh;
  if constexpr (kChecked) {
    if (!std::isfinite(pose.x_m) || !std::isfinite(pose.y_m) || !std::isfinite(pose.z_m) ||
        !std::isfinite(pose.yaw_rad)) {
      return static_cast<int>(IkError::kNotFinite);
    }
  }
  // z: the prismatic joint alone.
  const double d1 = pose.z_m - dh[0].d_m - dh[1].d_m - dh[2].d_m - dh[3].d_m;
  if (!model.limits[0].contains(d1)) {
    return kChecked ? static_cast<int>(IkError::kZOutOfTravel) : kUnchecked;
  }
  // planar part: wrist centre relative to the shoulder axis.
  double ux = pose.x_m, uy = pose.y_m;
  if (dh[3].a_m != 0.0) {
    double s, c;
    detail::sincos_fast(pose.yaw_rad, s, c);
    ux -= dh[3].a_m * c;
    uy -= dh[3].a_m * s;
  }
  if (dh[0].theta_rad == 0.0) {
    ux -= dh[0].a_m;
  } else {
    ux -= dh[0].a_m * std::cos(dh[0].theta_rad);
    uy -= dh[0].a_m * std::sin(dh[0].theta_rad);
  }
  const double a2 = dh[1].a_m, a3 = dh[2].a_m;
  const double r2 = ux * ux + uy * uy;
  // the division depends on the model alone: it runs while the target is being read.
  double c3 = (r2 - (a2 * a2 + a3 * a3)) * (1.0 / (2.0 * a2 * a3));
  if (!(c3 <= 1.0 + kReachSlack && c3 >= -1.0 - kReachSlack)) [[unlikely]] {
    if constexpr (!kChecked) return kUnchecked;  // also NaN
    r_m = std::sqrt(r2);                         // for the message
    return static_cast<int>(c3 > 0.0 ? IkError::kBeyondReach : IkError::kInsideDeadZone);
  }
  c3 = std::clamp(c3, -1.0, 1.0);
  const double s3 = std::sqrt((1.0 - c3) * (1.0 + c3));
  // shoulder angle phi = atan2(uy, ux) -/+ atan2(k2, k1) for the elbow +/-q3, and the elbow
  // angle itself: three atan2 in the lanes of two.
  const double k1 = a2 + a3 * c3, k2 = a3 * s3;
  V2d angles, elbows;
  // past the reach test every input is finite; (0, 0) only at the shoulder axis of an arm with
  // a2 = a3, which goes through the checked path.
  const bool regular = a2 != a3 || (r2 > 0.0 && std::abs(k1) + k2 > 0.0);
  detail::atan2_fast(V2d{uy, k2}, V2d{ux, k1}, splat(s3), splat(c3), angles, elbows, !regular);
  const V2d plus_minus = {1.0, -1.0};  // branch 0 has the elbow up (q3 >= 0)
  const V2d phi = splat(angles[0]) - splat(angles[1]) * plus_minus;
  const V2d elbow = elbows * plus_minus;
  q[0] = splat(d1);
  q[1] = phi - (dh[0].theta_rad + dh[1].theta_rad);
  q[2] = elbow - dh[2].theta_rad;
  q[3] = (pose.yaw_rad - dh[3].theta_rad) - (phi + elbow);
  return 0;
}

// The message of a solve_raw failure (out of line: formatting stays off the hot path).
[[gnu::cold, gnu::noinline]] Error raw_error(const RobotModel& model, const ToolPose& pose,
                                             int code, double r_m) {
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

}  // namespace

const char* joint_name(int index) {
  static constexpr const char* kNames[] = {"j1", "j2", "j3", "j4"};
  return (index >= 0 && index < kNumJoints) ? kNames[index] : "j?";
}

double wrap_angle(double rad) { return wrap_angle_inline(rad); }

double joint_distance2(const JointVector& a, const JointVector& b) {
  // summed in pairs (the IK hot path sums the same way, two branches at a time).
  const double e0 = a[0] - b[0], e1 = a[1] - b[1], e2 = a[2] - b[2], e3 = a[3] - b[3];
  return (e0 * e0 + e1 * e1) + (e2 * e2 + e3 * e3);
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

std::array<Eigen::Matrix4d, kNumJoints + 1> link_transforms(const RobotModel& model,
                                                            const JointVector& q) {
  // each DH row Rz(theta) Tz(d) Tx(a) Rx(alpha) splits after its joint: the URDF's joint i
  // turns its child by Rz(theta_i + q_i) (J1: Rz(theta_1) Tz(d_1 + q_1)), and the row's rest,
  // Tz(d_i) Tx(a_i) Rx(alpha_i), is where joint i+1 (or the tool) sits in that child
  const auto rz = [](double theta, double d) {
    const double c = std::cos(theta), s = std::sin(theta);
    Eigen::Matrix4d m;
    m << c, -s, 0, 0,  //
        s, c, 0, 0,    //
        0, 0, 1, d,    //
        0, 0, 0, 1;
    return m;
  };
  const auto rest = [](const DhRow& r, double d) {
    const double c = std::cos(r.alpha_rad), s = std::sin(r.alpha_rad);
    Eigen::Matrix4d m;
    m << 1, 0, 0, r.a_m,  //
        0, c, -s, 0,      //
        0, s, c, d,       //
        0, 0, 0, 1;
    return m;
  };
  std::array<Eigen::Matrix4d, kNumJoints + 1> out;
  Eigen::Matrix4d before = Eigen::Matrix4d::Identity();  // the previous row's rest
  for (int i = 0; i < kNumJoints; ++i) {
    const DhRow& r = model.dh[i];
    const double theta = r.type == JointType::kRevolute ? r.theta_rad + q[i] : r.theta_rad;
    const double d = r.type == JointType::kPrismatic ? r.d_m + q[i] : r.d_m;
    // J1's d is its joint's slide; a later row's d belongs to where the next joint sits
    out[i] = before * rz(theta, i == 0 ? d : 0.0);
    before = rest(r, i == 0 ? 0.0 : d);
  }
  out[kNumJoints] = before;
  return out;
}

ToolPose forward(const RobotModel& model, const JointVector& q) {
  const auto& dh = model.dh;
  const double p0 = dh[0].theta_rad;
  const double p1 = p0 + q[1] + dh[1].theta_rad;
  const double p2 = p1 + q[2] + dh[2].theta_rad;
  const double p3 = p2 + q[3] + dh[3].theta_rad;
  ToolPose p;
  // both link angles in the two lanes of one sine/cosine.
  V2d s, c;
  detail::sincos_fast(V2d{p1, p2}, s, c);
  p.x_m = dh[1].a_m * c[0] + dh[2].a_m * c[1];
  p.y_m = dh[1].a_m * s[0] + dh[2].a_m * s[1];
  if (p0 == 0.0) {
    p.x_m += dh[0].a_m;
  } else {
    p.x_m += dh[0].a_m * std::cos(p0);
    p.y_m += dh[0].a_m * std::sin(p0);
  }
  if (dh[3].a_m != 0.0) {
    double s3, c3;
    detail::sincos_fast(p3, s3, c3);
    p.x_m += dh[3].a_m * c3;
    p.y_m += dh[3].a_m * s3;
  }
  p.z_m = q[0] + dh[0].d_m + dh[1].d_m + dh[2].d_m + dh[3].d_m;
  p.yaw_rad = wrap_angle_inline(p3);
  return p;
}

namespace {

// Both branches wrapped near `near` as joint vectors, with the first failing joint of each.
int solve_unpacked(const RobotModel& model, const ToolPose& pose, const JointVector& near,
                   std::array<JointVector, 2>& q, std::array<int, 2>& bad, double& r_m) {
  BranchLanes lanes;
  if (int code = solve_raw<true>(model, pose, lanes, r_m); code != 0) return code;
  unpack(lanes, wrap_lanes<true>(model, lanes, near), q, bad);
  return 0;
}

// The valid branches first and nearest the seed first. Returns the number of valid solutions.
int order_valid(std::array<JointVector, 2>& q, const JointVector& seed,
                const std::array<int, 2>& bad) {
  if (bad[0] >= 0 && bad[1] >= 0) return 0;
  if (bad[0] >= 0) {
    q[0] = q[1];
    return 1;
  }
  if (bad[1] >= 0 || q[0] == q[1]) return 1;  // one valid, or stretched/folded (same pose)
  if (joint_distance2(q[1], seed) < joint_distance2(q[0], seed)) std::swap(q[0], q[1]);
  return 2;
}

// No branch within the limits (out of line: formatting stays off the hot path).
[[gnu::cold, gnu::noinline]] Error limit_error(const RobotModel& model,
                                               const std::array<JointVector, 2>& q,
                                               const std::array<int, 2>& bad,
                                               const JointVector& seed) {
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

// inverse() through inverse_all: for the error paths and for angles too large for the hot
// path (out of line).
[[gnu::cold, gnu::noinline]] Result<JointVector> inverse_general(const RobotModel& model,
                                                                 const ToolPose& pose,
                                                                 const JointVector& seed) {
  Result<IkSolutions> all = inverse_all(model, pose, seed);
  if (!all) return all.error();
  return all->solutions[0];
}

}  // namespace

Result<IkBranches> inverse_branches(const RobotModel& model, const ToolPose& pose) {
  IkBranches out;
  std::array<int, 2> bad;
  double r_m = 0.0;
  if (int code = solve_unpacked(model, pose, model.home, out.solutions, bad, r_m); code != 0) {
    return raw_error(model, pose, code, r_m);
  }
  return out;
}

Result<IkSolutions> inverse_all(const RobotModel& model, const ToolPose& pose,
                                const JointVector& seed) {
  IkSolutions out;
  std::array<int, 2> bad;
  double r_m = 0.0;
  if (int code = solve_unpacked(model, pose, seed, out.solutions, bad, r_m); code != 0) {
    return raw_error(model, pose, code, r_m);
  }
  out.count = order_valid(out.solutions, seed, bad);
  if (out.count == 0) return limit_error(model, out.solutions, bad, seed);
  return out;
}

// The hot path: the same choice as inverse_all's first solution, with the branches kept in
// the two lanes and the choice made without branching on the data.
Result<JointVector> inverse(const RobotModel& model, const ToolPose& pose,
                            const JointVector& seed) {
  // the joint angles before wrapping are the yaw and a few turns plus the DH offsets (the
  // offsets of any real table are small; above about 1e15 rad no double angle means anything).
  const bool bounded = std::abs(pose.yaw_rad) < kBoundedAngle;  // false for NaN
  if (!bounded) [[unlikely]] {
    return inverse_general(model, pose, seed);
  }
  BranchLanes q;
  double r_m = 0.0;
  if (solve_raw<false>(model, pose, q, r_m) != 0) [[unlikely]] {
    return inverse_general(model, pose, seed);
  }
  const std::array<Mask2, kNumJoints - 1> fit = wrap_lanes<false>(model, q, seed);
  if (detail::lanes(detail::mask_and(detail::mask_and(fit[0], fit[1]), fit[2])) == 0) {
    return inverse_general(model, pose, seed);
  }
  // joint_distance2 of each branch to the seed, in the same order of operations, and the
  // choice of branch as a lane mask: branch 1 when branch 0 does not fit, or when both fit and
  // branch 1 is strictly nearer.
  V2d e[kNumJoints];
  for (int j = 0; j < kNumJoints; ++j) e[j] = q[j] - seed[j];
  const V2d d2 = (e[0] * e[0] + e[1] * e[1]) + (e[2] * e[2] + e[3] * e[3]);
  const Mask2 fits = detail::mask_and(detail::mask_and(fit[0], fit[1]), fit[2]);
  const Mask2 nearer1 = detail::lt(V2d{d2[1], d2[1]}, V2d{d2[0], d2[0]});
  const Mask2 fit0 = V2d{fits[0], fits[0]}, fit1 = V2d{fits[1], fits[1]};
  const Mask2 pick1 =
      detail::mask_or(detail::mask_andnot(fit0, fit1), detail::mask_and(fit1, nearer1));
  // joints (0, 1) and (2, 3) of the chosen branch.
  const V2d j01 = select(pick1, V2d{q[0][1], q[1][1]}, V2d{q[0][0], q[1][0]});
  const V2d j23 = select(pick1, V2d{q[2][1], q[3][1]}, V2d{q[2][0], q[3][0]});
  JointVector out;
  std::memcpy(&out[0], &j01, sizeof j01);
  std::memcpy(&out[2], &j23, sizeof j23);
  return out;
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
