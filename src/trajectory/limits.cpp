// Limit checks and small trajectory utilities shared by the planners.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "scaratwin/core/units.hpp"
#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/trajectory/trajectory.hpp"

namespace scaratwin {

std::array<double, 4> motor_rates(const RobotModel& model, const JointVector& qd) {
  const MotorModel& m = model.motors;
  const double j2 = qd[1] * m.j2.steps_per_unit;
  return {qd[0] * m.z.steps_per_unit, j2, qd[2] * m.j3.steps_per_unit + m.j3_per_j2_coupling * j2,
          rad_to_deg(qd[3])};
}

Status check_limits(const RobotModel& model, const JointTrajectory& traj, double tolerance) {
  static constexpr const char* kMotor[] = {"Z", "J2", "J3"};
  const StepperAxis* axes[] = {&model.motors.z, &model.motors.j2, &model.motors.j3};
  for (size_t k = 0; k < traj.samples.size(); ++k) {
    const JointSample& s = traj.samples[k];
    if (k > 0 && !(s.t_s > traj.samples[k - 1].t_s)) {
      return Error{static_cast<int>(PlanError::kBadArgument),
                   fmt::format("sample {}: time {} s does not increase", k, s.t_s)};
    }
    for (int j = 0; j < kNumJoints; ++j) {
      const JointLimit& l = model.limits[j];
      const double slack = 1e-12 * (l.max - l.min);
      if (!(s.q[j] >= l.min - slack && s.q[j] <= l.max + slack)) {
        return Error{static_cast<int>(PlanError::kJointLimit),
                     fmt::format("sample {} (t = {:.3f} s): {} = {} outside [{}, {}]", k, s.t_s,
                                 joint_name(j), s.q[j], l.min, l.max)};
      }
    }
    const auto v = motor_rates(model, s.qd);
    const auto a = motor_rates(model, s.qdd);
    for (int i = 0; i < kNumSteppers; ++i) {
      if (std::abs(v[i]) > axes[i]->max_speed_steps_s * (1.0 + tolerance)) {
        return Error{static_cast<int>(PlanError::kMotorLimit),
                     fmt::format("sample {} (t = {:.3f} s): motor {} at {:.1f} steps/s exceeds "
                                 "its speed limit {:.1f} steps/s",
                                 k, s.t_s, kMotor[i], std::abs(v[i]), axes[i]->max_speed_steps_s)};
      }
      if (std::abs(a[i]) > axes[i]->max_accel_steps_s2 * (1.0 + tolerance)) {
        return Error{static_cast<int>(PlanError::kMotorLimit),
                     fmt::format("sample {} (t = {:.3f} s): motor {} at {:.1f} steps/s^2 exceeds "
                                 "its acceleration limit {:.1f} steps/s^2",
                                 k, s.t_s, kMotor[i], std::abs(a[i]), axes[i]->max_accel_steps_s2)};
      }
    }
    if (std::abs(v[3]) > model.motors.wrist.max_speed_deg_s * (1.0 + tolerance)) {
      return Error{static_cast<int>(PlanError::kMotorLimit),
                   fmt::format("sample {} (t = {:.3f} s): wrist servo at {:.1f} deg/s exceeds "
                               "its speed limit {:.1f} deg/s",
                               k, s.t_s, std::abs(v[3]), model.motors.wrist.max_speed_deg_s)};
    }
  }
  return Ok{};
}

void append(JointTrajectory& traj, const JointTrajectory& seg) {
  const double t0 = traj.duration_s();
  size_t first = 0;
  if (!traj.samples.empty() && !seg.samples.empty() && seg.samples[0].t_s == 0.0) first = 1;
  for (size_t k = first; k < seg.samples.size(); ++k) {
    JointSample s = seg.samples[k];
    s.t_s += t0;
    traj.samples.push_back(s);
  }
  for (GripperEvent e : seg.events) {
    e.t_s += t0;
    traj.events.push_back(e);
  }
}

void append_dwell(JointTrajectory& traj, double dwell_s) {
  SCARATWIN_CHECK(!traj.samples.empty(), "append_dwell on an empty trajectory");
  if (dwell_s <= 0.0) return;
  JointSample s = traj.samples.back();
  s.t_s += dwell_s;
  s.qd = {};
  s.qdd = {};
  traj.samples.push_back(s);
}

JointVector sample_at(const JointTrajectory& traj, double t_s) {
  SCARATWIN_CHECK(!traj.samples.empty(), "sample_at on an empty trajectory");
  const auto& s = traj.samples;
  if (t_s <= s.front().t_s) return s.front().q;
  if (t_s >= s.back().t_s) return s.back().q;
  const auto it = std::upper_bound(s.begin(), s.end(), t_s,
                                   [](double t, const JointSample& x) { return t < x.t_s; });
  const JointSample& b = *it;
  const JointSample& a = *(it - 1);
  const double u = (t_s - a.t_s) / (b.t_s - a.t_s);
  JointVector q;
  for (int j = 0; j < kNumJoints; ++j) q[j] = a.q[j] + u * (b.q[j] - a.q[j]);
  return q;
}

}  // namespace scaratwin
