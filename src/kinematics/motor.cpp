#include "scaratwin/kinematics/motor.hpp"

#include <cmath>

#include "scaratwin/core/units.hpp"

namespace scaratwin {

double steps_per_unit(const RobotModel& model, int stepper) {
  switch (stepper) {
    case 0:
      return model.motors.z.steps_per_unit;
    case 1:
      return model.motors.j2.steps_per_unit;
    default:
      return model.motors.j3.steps_per_unit;
  }
}

MotorPosition joints_to_motors(const RobotModel& model, const JointVector& q) {
  MotorPosition m;
  m.steps[0] = q[0] * model.motors.z.steps_per_unit;
  m.steps[1] = q[1] * model.motors.j2.steps_per_unit;
  m.steps[2] = q[2] * model.motors.j3.steps_per_unit + model.motors.j3_per_j2_coupling * m.steps[1];
  m.wrist_deg = rad_to_deg(q[3]);
  return m;
}

std::array<std::int32_t, kNumSteppers> joints_to_steps(const RobotModel& model,
                                                       const JointVector& q) {
  const MotorPosition m = joints_to_motors(model, q);
  std::array<std::int32_t, kNumSteppers> s{};
  for (int i = 0; i < kNumSteppers; ++i) s[i] = static_cast<std::int32_t>(std::lround(m.steps[i]));
  return s;
}

std::array<std::int32_t, kNumSteppers> endstop_steps(const RobotModel& model) {
  std::array<std::int32_t, kNumSteppers> s{};
  for (int i = 0; i < kNumSteppers; ++i) {
    s[i] = static_cast<std::int32_t>(
        std::lround(model.endstops.closes_at[i] * steps_per_unit(model, i)));
  }
  return s;
}

JointVector motors_to_joints(const RobotModel& model, const std::array<double, kNumSteppers>& steps,
                             double wrist_deg) {
  JointVector q;
  q[0] = steps[0] / model.motors.z.steps_per_unit;
  q[1] = steps[1] / model.motors.j2.steps_per_unit;
  q[2] = (steps[2] - model.motors.j3_per_j2_coupling * steps[1]) / model.motors.j3.steps_per_unit;
  q[3] = deg_to_rad(wrist_deg);
  return q;
}

}  // namespace scaratwin
