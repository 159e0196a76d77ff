// scaratwin-robot, the emulator of the physical robot: the robot's mechanics as the firmware's
// pins see them. Counts STEP edges per axis in the direction of the DIR pin (the true motor
// positions, independent of what the firmware reports), decodes the servo pulse widths into
// wrist and gripper angles, and closes the endstop switches from the modelled positions.
// Also the mechanical faults: a slipping belt that loses steps.
//
// SPDX-License-Identifier: GPL-3.0-or-later
// Part of the scaratwin-robot emulator, which links libsimavr (GPL-3.0) and is therefore
// distributed under the GNU General Public License, version 3 or later.
#pragma once

#include <array>
#include <cstdint>

namespace scaratwin::robot {

inline constexpr int kAxes = 3;  // Z, J2, J3 steppers

// Mechanical parameters, in motor steps and the servos' pulse ranges. They have no defaults of
// their own: scaratwin-robot (main.cpp) fills every field from the robot description, with the
// conversions of scaratwin/kinematics/motor.hpp.
struct MechanicsConfig {
  std::array<std::int32_t, kAxes> start_steps{};  // true position at power-up
  // Endstop switches: Z closes at z >= z_endstop, J2 at j2 >= j2_endstop, J3 (a joint switch,
  // so the J2 motor's belt coupling counts) at j3 - coupling * j2 <= j3_endstop.
  std::int32_t z_endstop = 0;
  std::int32_t j2_endstop = 0;
  std::int32_t j3_endstop = 0;
  std::int32_t coupling_permille = 0;  // J3 motor steps per 1000 J2 motor steps
  // Servos: pulse widths at the ends of the angle range (deg).
  double servo_min_us = 0.0;
  double servo_max_us = 0.0;
  double servo_min_deg = 0.0;
  double servo_max_deg = 0.0;
};

class Mechanics {
 public:
  explicit Mechanics(const MechanicsConfig& config);

  // Pin events, with the time in simulated microseconds.
  void on_dir(int axis, bool high);
  void on_step(int axis, bool high, std::uint64_t sim_us);
  // Servo 0 gripper, 1 wrist; edges with the time in CPU cycles for sub-us resolution.
  void on_servo(int servo, bool high, std::uint64_t cycle, double cycles_per_us);

  // Fault: the next n STEP pulses of `axis` move nothing (a slipping belt).
  void lose_steps(int axis, std::int32_t n) { to_lose_[axis] += n; }

  const std::array<std::int32_t, kAxes>& steps() const { return steps_; }
  // Endstop switch states, bit i = axis i closed.
  std::uint8_t endstops() const;
  // Servo angles in centidegrees from the last complete pulse (-1 before any pulse).
  std::int32_t servo_cdeg(int servo) const { return servo_cdeg_[servo]; }
  double servo_pulse_us(int servo) const { return pulse_us_[servo]; }
  std::uint64_t last_step_sim_us() const { return last_step_us_; }
  std::uint64_t step_count(int axis) const { return step_count_[axis]; }
  // Emulated times (us) of each axis's first and last STEP pulse since mark() (0 = none).
  void mark() {
    first_us_ = {};
    last_us_ = {};
  }
  std::uint64_t first_step_us(int axis) const { return first_us_[axis]; }
  std::uint64_t last_step_us(int axis) const { return last_us_[axis]; }

 private:
  MechanicsConfig config_;
  std::array<std::int32_t, kAxes> steps_{};
  std::array<bool, kAxes> dir_positive_{true, true, true};
  std::array<bool, kAxes> step_level_{};
  std::array<std::int32_t, kAxes> to_lose_{};
  std::array<std::uint64_t, kAxes> step_count_{};
  std::uint64_t last_step_us_ = 0;
  std::array<std::uint64_t, kAxes> first_us_{};
  std::array<std::uint64_t, kAxes> last_us_{};
  std::array<std::uint64_t, 2> rise_cycle_{};
  std::array<bool, 2> servo_level_{};
  std::array<std::int32_t, 2> servo_cdeg_{-1, -1};
  std::array<double, 2> pulse_us_{};
};

}  // namespace scaratwin::robot
