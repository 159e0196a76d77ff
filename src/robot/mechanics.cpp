// SPDX-License-Identifier: GPL-3.0-or-later (scaratwin-robot emulator, see mechanics.hpp)
#include "mechanics.hpp"

#include <cmath>

#include "scaratwin/core/result.hpp"

namespace scaratwin::robot {

Mechanics::Mechanics(const MechanicsConfig& config) : config_(config) {
  SCARATWIN_CHECK(
      config.servo_max_us > config.servo_min_us && config.servo_max_deg > config.servo_min_deg,
      "MechanicsConfig not filled from the robot description");
  steps_ = config.start_steps;
}

void Mechanics::on_dir(int axis, bool high) { dir_positive_[axis] = high; }

void Mechanics::on_step(int axis, bool high, std::uint64_t sim_us) {
  const bool rising = high && !step_level_[axis];
  step_level_[axis] = high;
  if (!rising) return;
  ++step_count_[axis];
  last_step_us_ = sim_us;
  if (first_us_[axis] == 0) first_us_[axis] = sim_us;
  last_us_[axis] = sim_us;
  if (to_lose_[axis] > 0) {
    --to_lose_[axis];
    return;
  }
  steps_[axis] += dir_positive_[axis] ? 1 : -1;
}

void Mechanics::on_servo(int servo, bool high, std::uint64_t cycle, double cycles_per_us) {
  if (high == servo_level_[servo]) return;
  servo_level_[servo] = high;
  if (high) {
    rise_cycle_[servo] = cycle;
    return;
  }
  const double width_us = static_cast<double>(cycle - rise_cycle_[servo]) / cycles_per_us;
  pulse_us_[servo] = width_us;
  const double span_us = config_.servo_max_us - config_.servo_min_us;
  double deg = config_.servo_min_deg + (width_us - config_.servo_min_us) / span_us *
                                           (config_.servo_max_deg - config_.servo_min_deg);
  servo_cdeg_[servo] = static_cast<std::int32_t>(std::lround(deg * 100.0));
}

std::uint8_t Mechanics::endstops() const {
  std::uint8_t m = 0;
  if (steps_[0] >= config_.z_endstop) m |= 1;
  if (steps_[1] >= config_.j2_endstop) m |= 2;
  const std::int64_t joint_milli =
      1000LL * steps_[2] - std::int64_t{config_.coupling_permille} * steps_[1];
  if (joint_milli <= 1000LL * config_.j3_endstop) m |= 4;
  return m;
}

}  // namespace scaratwin::robot
