// Joint-space profiles: the paper's quintic (jtraj) and a synchronised trapezoid.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"
#include "time_scaling.hpp"

namespace scaratwin {
namespace {

// Peak normalised velocity and acceleration of the quintic s(tau) = 10 tau^3 - 15 tau^4 +
// 6 tau^5 for a unit duration.
constexpr double kQuinticPeakVel = 15.0 / 8.0;
const double kQuinticPeakAcc = 10.0 / std::sqrt(3.0);

// Two doubles in one SSE2 / NEON register (GCC/clang vector extension: portable, no machine
// flag), and unaligned loads and stores of two joint values.
using V2d = double __attribute__((vector_size(16)));
V2d load2(const double* p) {
  V2d v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
void store2(double* p, V2d v) { std::memcpy(p, &v, sizeof v); }

Error plan_error(PlanError code, std::string message) {
  return Error{static_cast<int>(code), std::move(message)};
}

Status check_endpoints(const RobotModel& model, const JointVector& q0, const JointVector& q1) {
  for (const JointVector* q : {&q0, &q1}) {
    for (int j = 0; j < kNumJoints; ++j) {
      if (!std::isfinite((*q)[j])) {
        return plan_error(PlanError::kBadArgument, fmt::format("{} is not finite", joint_name(j)));
      }
    }
    if (int j = first_joint_outside_limits(model, *q); j >= 0) {
      return plan_error(
          PlanError::kJointLimit,
          fmt::format("{} {} = {} is outside its limits [{}, {}]", q == &q0 ? "start" : "goal",
                      joint_name(j), (*q)[j], model.limits[j].min, model.limits[j].max));
    }
  }
  return Ok{};
}

// Motor deltas (steps for the steppers, degrees for the wrist) of a joint move.
std::array<double, 4> motor_deltas(const RobotModel& model, const JointVector& q0,
                                   const JointVector& q1) {
  JointVector d;
  for (int j = 0; j < kNumJoints; ++j) d[j] = q1[j] - q0[j];
  return motor_rates(model, d);
}

}  // namespace

void quintic_into(const JointVector& q0, const JointVector& q1, double duration_s,
                  std::span<JointSample> out) {
  SCARATWIN_CHECK(out.size() >= 2 && duration_s > 0.0, "quintic needs >= 2 samples and T > 0");
  const size_t n = out.size();
  const double inv_t = 1.0 / duration_s;
  const double inv_t2 = inv_t * inv_t;
  const double step = 1.0 / static_cast<double>(n - 1);
  // per joint: position q0 + d s(tau), velocity d s'(tau) / T, acceleration d s''(tau) / T^2,
  // with s = 10 tau^3 - 15 tau^4 + 6 tau^5. The profile is evaluated for two samples at once
  // and the joints two at a time (the same operations as one by one, so the same results).
  const V2d a01 = load2(&q0[0]), a23 = load2(&q0[2]);
  const V2d d01 = load2(&q1[0]) - a01, d23 = load2(&q1[2]) - a23;
  const auto write = [&](JointSample& smp, double tau, double s, double sd, double sdd) {
    smp.t_s = tau * duration_s;
    store2(&smp.q[0], a01 + d01 * s);
    store2(&smp.q[2], a23 + d23 * s);
    store2(&smp.qd[0], d01 * sd);
    store2(&smp.qd[2], d23 * sd);
    store2(&smp.qdd[0], d01 * sdd);
    store2(&smp.qdd[2], d23 * sdd);
  };
  V2d k = {0.0, 1.0};
  size_t i = 0;
  for (; i + 1 < n; i += 2, k += 2.0) {
    const V2d tau = k * step;
    const V2d t2 = tau * tau, t3 = t2 * tau;
    const V2d s = t3 * (10.0 - 15.0 * tau + 6.0 * t2);
    const V2d sd = 30.0 * t2 * (1.0 - 2.0 * tau + t2) * inv_t;
    const V2d sdd = 60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2) * inv_t2;
    write(out[i], tau[0], s[0], sd[0], sdd[0]);
    write(out[i + 1], tau[1], s[1], sd[1], sdd[1]);
  }
  if (i < n) {
    const double tau = static_cast<double>(i) * step;
    const double t2 = tau * tau, t3 = t2 * tau;
    write(out[i], tau, t3 * (10.0 - 15.0 * tau + 6.0 * t2),
          30.0 * t2 * (1.0 - 2.0 * tau + t2) * inv_t,
          60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2) * inv_t2);
  }
  out.back().q = q1;  // exact end point
}

JointTrajectory quintic(const JointVector& q0, const JointVector& q1, double duration_s,
                        int samples) {
  SCARATWIN_CHECK(samples >= 2 && duration_s > 0.0, "quintic needs >= 2 samples and T > 0");
  JointTrajectory out;
  out.samples.resize(static_cast<size_t>(samples));
  quintic_into(q0, q1, duration_s, out.samples);
  return out;
}

double quintic_min_duration(const RobotModel& model, const JointVector& q0, const JointVector& q1) {
  const auto dm = motor_deltas(model, q0, q1);
  const StepperAxis* axes[] = {&model.motors.z, &model.motors.j2, &model.motors.j3};
  double t = 0.0;
  for (int i = 0; i < kNumSteppers; ++i) {
    const double d = std::abs(dm[i]);
    t = std::max(t, kQuinticPeakVel * d / axes[i]->max_speed_steps_s);
    t = std::max(t, std::sqrt(kQuinticPeakAcc * d / axes[i]->max_accel_steps_s2));
  }
  t = std::max(t, kQuinticPeakVel * std::abs(dm[3]) / model.motors.wrist.max_speed_deg_s);
  return t * (1.0 + 1e-9);
}

Result<JointTrajectory> plan_quintic(const RobotModel& model, const JointVector& q0,
                                     const JointVector& q1, const QuinticOptions& options) {
  if (options.samples < 2 || options.samples > 1000000) {
    return plan_error(PlanError::kBadArgument,
                      fmt::format("samples = {}: must be between 2 and 1000000", options.samples));
  }
  if (!std::isfinite(options.duration_s) || options.duration_s < 0.0) {
    return plan_error(
        PlanError::kBadArgument,
        fmt::format("duration = {} s: must be >= 0 (0 = shortest)", options.duration_s));
  }
  if (Status s = check_endpoints(model, q0, q1); !s) return s.error();
  const double t_min = quintic_min_duration(model, q0, q1);
  double t = options.duration_s;
  if (t == 0.0) {
    if (t_min == 0.0) {  // no motion: one sample
      JointTrajectory out;
      out.samples.push_back(JointSample{0.0, q0, {}, {}});
      return out;
    }
    t = t_min;
  } else if (t < t_min) {
    return plan_error(PlanError::kMotorLimit,
                      fmt::format("duration {:.4f} s is too short for the motor limits: this move "
                                  "needs at least {:.4f} s",
                                  t, t_min));
  }
  return quintic(q0, q1, t, options.samples);
}

Result<JointTrajectory> plan_trapezoid(const RobotModel& model, const JointVector& q0,
                                       const JointVector& q1, const TrapezoidOptions& o) {
  if (!(o.dt_s > 0.0 && o.dt_s <= 1.0)) {
    return plan_error(PlanError::kBadArgument, fmt::format("dt = {} s: must be in (0, 1]", o.dt_s));
  }
  if (!(o.speed_scale > 0.0 && o.speed_scale <= 1.0) ||
      !(o.accel_scale > 0.0 && o.accel_scale <= 1.0)) {
    return plan_error(
        PlanError::kBadArgument,
        fmt::format("speed/accel scale {}/{}: must be in (0, 1]", o.speed_scale, o.accel_scale));
  }
  if (Status s = check_endpoints(model, q0, q1); !s) return s.error();
  const auto dm = motor_deltas(model, q0, q1);
  const StepperAxis* axes[] = {&model.motors.z, &model.motors.j2, &model.motors.j3};
  // normalised peak speed V (1/s) and acceleration A (1/s^2) of s(t) in [0, 1].
  double v = INFINITY, a = INFINITY;
  for (int i = 0; i < kNumSteppers; ++i) {
    const double d = std::abs(dm[i]);
    if (d == 0.0) continue;
    v = std::min(v, o.speed_scale * axes[i]->max_speed_steps_s / d);
    a = std::min(a, o.accel_scale * axes[i]->max_accel_steps_s2 / d);
  }
  if (dm[3] != 0.0)
    v = std::min(v, o.speed_scale * model.motors.wrist.max_speed_deg_s / std::abs(dm[3]));
  JointTrajectory out;
  if (v == INFINITY) {  // no motion
    out.samples.push_back(JointSample{0.0, q0, {}, {}});
    return out;
  }
  if (a == INFINITY) a = v * v * 4.0;  // wrist only: servo speed limit, no acceleration limit
  const detail::TrapezoidScaling prof = detail::TrapezoidScaling::make(v, a);
  const int n = prof.intervals(o.dt_s);
  out.samples.reserve(n + 1);
  for (int k = 0; k <= n; ++k) {
    const double t = k == n ? prof.total_s : k * o.dt_s;
    double s, sd, sdd;
    prof.eval(t, s, sd, sdd);
    JointSample smp;
    smp.t_s = t;
    for (int j = 0; j < kNumJoints; ++j) {
      const double d = q1[j] - q0[j];
      smp.q[j] = k == n ? q1[j] : q0[j] + d * s;
      smp.qd[j] = k == n ? 0.0 : d * sd;
      smp.qdd[j] = d * sdd;
    }
    out.samples.push_back(smp);
  }
  return out;
}

Result<JointTrajectory> plan_via_points(const RobotModel& model,
                                        const std::vector<JointVector>& points,
                                        const ViaOptions& options) {
  if (points.size() < 2) {
    return plan_error(
        PlanError::kBadArgument,
        fmt::format("a via-point path needs at least 2 points, got {}", points.size()));
  }
  JointTrajectory out;
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    Result<JointTrajectory> seg =
        options.profile == Profile::kQuintic
            ? plan_quintic(model, points[i], points[i + 1], {options.quintic_samples, 0.0})
            : plan_trapezoid(model, points[i], points[i + 1], options.trapezoid);
    if (!seg) {
      return Error{seg.error().code,
                   fmt::format("segment {} -> {}: {}", i, i + 1, seg.error().message)};
    }
    append(out, *seg);
  }
  return out;
}

}  // namespace scaratwin
