#include "scaratwin/plant/stepper.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace scaratwin::plant {

StepperMotor::StepperMotor(const StepperDrive& motor, double supply_v)
    : motor_(motor),
      supply_v_(supply_v),
      kt_(motor.holding_torque_nm / motor.rated_current_a),
      pole_pairs_(motor.full_steps_per_rev / 4.0),
      microstep_rad_(2.0 * std::numbers::pi / (motor.full_steps_per_rev * motor.microsteps)) {}

void StepperMotor::reset(std::int64_t microsteps) {
  commanded_ = microsteps;
  theta_ = static_cast<double>(microsteps) * microstep_rad_;
  omega_ = 0.0;
}

double StepperMotor::pull_out_torque_nm(double omega) const {
  // phase current: the chopper holds current_a while the supply can drive it through the
  // back EMF and the winding's impedance at the electrical frequency
  const double w = std::abs(omega);
  const double headroom_v = std::max(0.0, supply_v_ - kt_ * w);
  const double x_l = pole_pairs_ * w * motor_.inductance_h;
  const double z = std::sqrt(motor_.resistance_ohm * motor_.resistance_ohm + x_l * x_l);
  const double current = std::min(motor_.current_a, headroom_v / z);
  return kt_ * current;
}

double StepperMotor::magnetic_torque_nm() const {
  const double lag = theta_ - static_cast<double>(commanded_) * microstep_rad_;
  const double phases = -pull_out_torque_nm(omega_) * std::sin(pole_pairs_ * lag);
  // detent: one period per full step
  const double detent = -motor_.detent_torque_nm * std::sin(4.0 * pole_pairs_ * theta_);
  return phases + detent;
}

void StepperMotor::advance(double dt_s, double load_nm) {
  // Coulomb friction smoothed over 0.05 rad/s so that a rotor at rest does not chatter
  const double friction = motor_.friction_nm * std::tanh(omega_ / 0.05);
  const double torque = magnetic_torque_nm() - friction - motor_.viscous_nms * omega_ - load_nm;
  omega_ += dt_s * torque / motor_.rotor_inertia_kgm2;
  theta_ += dt_s * omega_;
}

std::int64_t StepperMotor::lost_microsteps() const {
  const double behind = static_cast<double>(commanded_) - angle_microsteps();
  const double cycle = microsteps_per_cycle();
  return static_cast<std::int64_t>(std::llround(behind / cycle)) * microsteps_per_cycle();
}

}  // namespace scaratwin::plant
