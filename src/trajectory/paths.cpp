// Cartesian straight-line paths: IK at every sample, timed within the motor limits.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "time_scaling.hpp"

namespace scaratwin {
namespace {

// Largest joint change allowed between two dense samples (about 1 mm apart): more than this
// means the line passes through a singularity or a wrap of a joint.
constexpr double kMaxJumpRad = 0.2;
constexpr double kMaxYawStepRad = 0.02;
constexpr int kMaxRetiming = 40;

ToolPose lerp_pose(const ToolPose& a, const ToolPose& b, double dyaw, double s) {
  return {a.x_m + s * (b.x_m - a.x_m), a.y_m + s * (b.y_m - a.y_m), a.z_m + s * (b.z_m - a.z_m),
          a.yaw_rad + s * dyaw};
}

}  // namespace

Result<JointTrajectory> plan_line(const RobotModel& model, const JointVector& q0,
                                  const ToolPose& goal, const LineOptions& o) {
  const auto bad = [](std::string m) {
    return Error{static_cast<int>(PlanError::kBadArgument), std::move(m)};
  };
  if (!(o.max_step_m > 0.0) || !(o.dt_s > 0.0 && o.dt_s <= 1.0)) {
    return bad(fmt::format("line step {} m / dt {} s: both must be > 0 (dt <= 1 s)", o.max_step_m,
                           o.dt_s));
  }
  if (!(o.speed_scale > 0.0 && o.speed_scale <= 1.0) ||
      !(o.accel_scale > 0.0 && o.accel_scale <= 1.0)) {
    return bad(
        fmt::format("speed/accel scale {}/{}: must be in (0, 1]", o.speed_scale, o.accel_scale));
  }
  if (int j = first_joint_outside_limits(model, q0); j >= 0) {
    return Error{static_cast<int>(PlanError::kJointLimit),
                 fmt::format("start {} = {} is outside its limits", joint_name(j), q0[j])};
  }
  const ToolPose p0 = forward(model, q0);
  const double dyaw = wrap_angle(goal.yaw_rad - p0.yaw_rad);
  const double len = std::hypot(goal.x_m - p0.x_m, goal.y_m - p0.y_m, goal.z_m - p0.z_m);
  if (!std::isfinite(len) || !std::isfinite(dyaw)) {
    return Error{static_cast<int>(IkError::kNotFinite), "line goal is not finite"};
  }
  const int n = std::max(
      2,
      static_cast<int>(std::ceil(std::max(len / o.max_step_m, std::abs(dyaw) / kMaxYawStepRad))));
  if (n > 2000000) return bad(fmt::format("line needs {} samples: step too small", n));
  JointTrajectory out;
  if (len == 0.0 && dyaw == 0.0) {
    out.samples.push_back(JointSample{0.0, q0, {}, {}});
    return out;
  }

  // dense IK along the line, each sample seeded by the previous one.
  std::vector<JointVector> dense(n + 1);
  dense[0] = q0;
  for (int k = 1; k <= n; ++k) {
    const double s = static_cast<double>(k) / n;
    const ToolPose p = lerp_pose(p0, goal, dyaw, s);
    auto q = inverse(model, p, dense[k - 1]);
    if (!q) {
      return Error{static_cast<int>(PlanError::kUnreachable),
                   fmt::format("line sample {} of {} at ({:.4f}, {:.4f}, {:.4f}) m is "
                               "unreachable: {}",
                               k, n, p.x_m, p.y_m, p.z_m, q.error().message)};
    }
    for (int j = 1; j < kNumJoints; ++j) {
      if (std::abs((*q)[j] - dense[k - 1][j]) > kMaxJumpRad) {
        return Error{
            static_cast<int>(PlanError::kDiscontinuous),
            fmt::format("line sample {} of {} at ({:.4f}, {:.4f}) m: {} would jump by "
                        "{:.1f} deg (singularity or joint wrap); plan a joint move",
                        k, n, p.x_m, p.y_m, joint_name(j), rad_to_deg((*q)[j] - dense[k - 1][j]))};
      }
    }
    dense[k] = *q;
  }
  // derivatives of the joints along the path parameter s (finite differences).
  const double h = 1.0 / n;
  std::vector<JointVector> dq(n + 1), ddq(n + 1);
  for (int k = 0; k <= n; ++k) {
    const int a = std::max(0, k - 1), b = std::min(n, k + 1);
    for (int j = 0; j < kNumJoints; ++j) {
      dq[k][j] = (dense[b][j] - dense[a][j]) / ((b - a) * h);
      const int c = std::clamp(k, 1, n - 1);
      ddq[k][j] = (dense[c + 1][j] - 2.0 * dense[c][j] + dense[c - 1][j]) / (h * h);
    }
  }
  // path speed and acceleration limits from the steepest motor along the path.
  const StepperAxis* axes[] = {&model.motors.z, &model.motors.j2, &model.motors.j3};
  double v = INFINITY, acc = INFINITY;
  for (int k = 0; k <= n; ++k) {
    const auto r = motor_rates(model, dq[k]);
    const auto r2 = motor_rates(model, ddq[k]);
    for (int i = 0; i < kNumSteppers; ++i) {
      if (r[i] != 0.0) v = std::min(v, axes[i]->max_speed_steps_s / std::abs(r[i]));
      if (r[i] != 0.0) acc = std::min(acc, axes[i]->max_accel_steps_s2 / std::abs(r[i]));
      // curvature term: a * sd^2 must stay within the limit as well.
      if (r2[i] != 0.0) v = std::min(v, std::sqrt(axes[i]->max_accel_steps_s2 / std::abs(r2[i])));
    }
    if (r[3] != 0.0) v = std::min(v, model.motors.wrist.max_speed_deg_s / std::abs(r[3]));
  }
  if (!std::isfinite(v)) v = 1.0;
  if (!std::isfinite(acc)) acc = 4.0 * v * v;
  v *= o.speed_scale;
  acc *= o.accel_scale;

  const auto interp = [&](const std::vector<JointVector>& tab, double s) {
    const double x = std::clamp(s, 0.0, 1.0) * n;
    const int k = std::min(n - 1, static_cast<int>(x));
    const double u = x - k;
    JointVector r;
    for (int j = 0; j < kNumJoints; ++j) r[j] = tab[k][j] + u * (tab[k + 1][j] - tab[k][j]);
    return r;
  };

  for (int attempt = 0; attempt < kMaxRetiming; ++attempt) {
    const detail::TrapezoidScaling prof = detail::TrapezoidScaling::make(v, acc);
    const int m = prof.intervals(o.dt_s);
    out.samples.clear();
    out.samples.reserve(m + 1);
    JointVector seed = q0;
    for (int k = 0; k <= m; ++k) {
      const double t = k == m ? prof.total_s : k * o.dt_s;
      double s, sd, sdd;
      prof.eval(t, s, sd, sdd);
      JointSample smp;
      smp.t_s = t;
      if (k == 0) {
        smp.q = q0;
      } else {
        auto q = inverse(model, lerp_pose(p0, goal, dyaw, s), seed);
        smp.q = q ? *q : interp(dense, s);  // dense samples around s were all reachable
      }
      seed = smp.q;
      const JointVector d1 = interp(dq, s), d2 = interp(ddq, s);
      for (int j = 0; j < kNumJoints; ++j) {
        smp.qd[j] = k == m ? 0.0 : d1[j] * sd;
        smp.qdd[j] = d2[j] * sd * sd + d1[j] * sdd;
      }
      out.samples.push_back(smp);
    }
    Status st = check_limits(model, out);
    if (st) return out;
    if (st.error().code != static_cast<int>(PlanError::kMotorLimit)) return st.error();
    v *= 0.85;
    acc *= 0.85;
  }
  return Error{static_cast<int>(PlanError::kMotorLimit),
               "line could not be timed within the motor limits"};
}

}  // namespace scaratwin
