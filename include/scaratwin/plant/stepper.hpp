// A hybrid stepper motor on a chopper driver, as physics: the driver turns each STEP pulse
// into a new electrical angle (one microstep), the rotor follows through the magnetic
// torque of the phases, its own inertia, detent and friction, and whatever load its shaft
// carries. The torque the phases can give falls with speed (pull-out curve): the driver's
// current limit at low speed, then the supply voltage against the back EMF and the winding
// inductance. When the load asks for more, the rotor falls behind by a whole electrical
// cycle (four full steps) at a time: a lost step comes out of this model, not out of a counter.
//
// Pure and deterministic: no clock, no I/O. Units: rotor angle in rad, speed in rad/s,
// torque in N m, time in s.
#pragma once

#include <cstdint>

#include "scaratwin/kinematics/physical.hpp"

namespace scaratwin::plant {

class StepperMotor {
 public:
  StepperMotor(const StepperDrive& motor, double supply_v);

  // The driver: one microstep forward (+1) or back (-1).
  void step(int direction) { commanded_ += direction; }
  // Advances the rotor by dt_s with `load_nm` opposing its motion (the shaft's load torque,
  // positive when it pushes the rotor backwards). Semi-implicit Euler; keep dt_s <= 50 us.
  void advance(double dt_s, double load_nm);

  // Peak torque the phases can give at rotor speed `omega` (the pull-out curve).
  double pull_out_torque_nm(double omega_rad_s) const;
  // Torque of the phases and the detent at the present state (without friction or load).
  double magnetic_torque_nm() const;

  std::int64_t commanded_microsteps() const { return commanded_; }
  double angle_rad() const { return theta_; }
  double speed_rad_s() const { return omega_; }
  // The rotor angle in microsteps (continuous).
  double angle_microsteps() const { return theta_ / microstep_rad_; }
  // Microsteps lost: commanded minus where the rotor is, rounded to whole electrical cycles
  // (the only positions a slipped rotor can settle in); positive when the rotor is behind.
  std::int64_t lost_microsteps() const;
  double microstep_rad() const { return microstep_rad_; }
  int microsteps_per_cycle() const { return 4 * motor_.microsteps; }
  // Sets the rotor and the command to `microsteps` at rest (power-up position).
  void reset(std::int64_t microsteps);

 private:
  StepperDrive motor_;
  double supply_v_;
  double kt_;             // N m per A (also the back-EMF constant, V s/rad)
  double pole_pairs_;     // rotor teeth: electrical angle = pole_pairs * mechanical
  double microstep_rad_;  // rotor angle of one microstep
  std::int64_t commanded_ = 0;
  double theta_ = 0.0;
  double omega_ = 0.0;
};

}  // namespace scaratwin::plant
