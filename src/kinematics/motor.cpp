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

JointVector firmware_to_joints(const RobotModel& model, const JointVector& q_fw) {
  const JointCalibration& c = model.calibration;
  const auto& hd = model.endstops.homing_dir;
  JointVector q;
  q[0] = q_fw[0] + c.z_offset_m + c.z_scale * (q_fw[0] - model.endstops.closes_at[0]) +
         0.5 * hd[0] * c.backlash[0];
  q[1] = q_fw[1] + c.j2_zero_rad + 0.5 * hd[1] * c.backlash[1];
  q[2] = q_fw[2] + c.j3_zero_rad + 0.5 * hd[2] * c.backlash[2];
  q[3] = (1.0 + c.wrist_gain) * q_fw[3] + c.wrist_offset_rad;
  return q;
}

JointVector joints_to_firmware(const RobotModel& model, const JointVector& q) {
  const JointCalibration& c = model.calibration;
  const auto& hd = model.endstops.homing_dir;
  JointVector f;
  const double sw = model.endstops.closes_at[0];
  f[0] = sw + (q[0] - 0.5 * hd[0] * c.backlash[0] - c.z_offset_m - sw) / (1.0 + c.z_scale);
  f[1] = q[1] - c.j2_zero_rad - 0.5 * hd[1] * c.backlash[1];
  f[2] = q[2] - c.j3_zero_rad - 0.5 * hd[2] * c.backlash[2];
  f[3] = (q[3] - c.wrist_offset_rad) / (1.0 + c.wrist_gain);
  return f;
}

JointVector backlash_shift(const RobotModel& model, const std::array<int, kNumSteppers>& dir) {
  JointVector s{};
  for (int i = 0; i < kNumSteppers; ++i) s[i] = -0.5 * dir[i] * model.calibration.backlash[i];
  return s;
}

MotionDirections homed_directions(const RobotModel& model) {
  const auto& hd = model.endstops.homing_dir;
  return {-hd[0], -hd[1], -hd[2]};
}

void track_directions(MotionDirections& dir, const JointVector& from, const JointVector& to) {
  for (int i = 0; i < kNumSteppers; ++i) {
    const double d = to[i] - from[i];
    if (std::abs(d) > 1e-9) dir[i] = d > 0.0 ? 1 : -1;
  }
}

MotorPosition joints_to_motors(const RobotModel& model, const JointVector& q_joints) {
  const JointVector q = joints_to_firmware(model, q_joints);
  MotorPosition m;
  m.steps[0] = q[0] * model.motors.z.steps_per_unit;
  m.steps[1] = q[1] * model.motors.j2.steps_per_unit;
  m.steps[2] = q[2] * model.motors.j3.steps_per_unit + model.motors.j3_per_j2_coupling * m.steps[1];
  m.wrist_deg = rad_to_deg(q[3]);
  // a calibrated horn offset may put a joint limit a degree or two past the servo's travel:
  // the servo stops at its end (its true angle is then the calibrated end, not a refusal)
  const JointCalibration& c = model.calibration;
  if (c.wrist_offset_rad != 0.0 || c.wrist_gain != 0.0) {
    const ServoSpec& w = model.motors.wrist;
    if (m.wrist_deg < w.min_deg && m.wrist_deg > w.min_deg - 5.0) m.wrist_deg = w.min_deg;
    if (m.wrist_deg > w.max_deg && m.wrist_deg < w.max_deg + 5.0) m.wrist_deg = w.max_deg;
  }
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
  return firmware_to_joints(model, q);
}

}  // namespace scaratwin
