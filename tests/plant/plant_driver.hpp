// A step generator for the plant tests: plays synchronised trapezoidal moves of the three
// steppers as STEP pulses at 50 us resolution (as the firmware's 20 kHz tick would) and
// advances the plant along, plus servo pulses at 50 Hz.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "scaratwin/kinematics/motor.hpp"
#include "scaratwin/plant/plant.hpp"

namespace scaratwin::plant::testing {

class Driver {
 public:
  explicit Driver(Plant& plant) : plant_(plant) {
    const auto c = plant.commanded_microsteps();
    for (int i = 0; i < kSteppers; ++i) count_[i] = c[i];
  }

  // Moves every stepper to `target` (microsteps) along trapezoids that share one duration,
  // the longest axis at `speed` steps/s and `accel` steps/s^2.
  void move_to(const std::array<std::int64_t, kSteppers>& target, double speed, double accel) {
    std::array<double, kSteppers> dist{};
    double longest = 0.0;
    for (int i = 0; i < kSteppers; ++i) {
      dist[i] = static_cast<double>(target[i] - count_[i]);
      longest = std::max(longest, std::abs(dist[i]));
    }
    if (longest == 0.0) return;
    // trapezoid (or triangle) of the longest axis, normalised to [0, 1]
    double t_acc = speed / accel, d_acc = 0.5 * accel * t_acc * t_acc, t_total;
    if (2 * d_acc >= longest) {
      t_acc = std::sqrt(longest / accel);
      d_acc = longest / 2;
      t_total = 2 * t_acc;
    } else {
      t_total = 2 * t_acc + (longest - 2 * d_acc) / speed;
    }
    const std::array<std::int64_t, kSteppers> start = count_;
    const double t0 = t_;
    const double vmax = t_acc * accel;
    while (t_ < t0 + t_total) {
      t_ += kTick;
      const double t = std::min(t_ - t0, t_total);
      double s;
      if (t < t_acc) {
        s = 0.5 * accel * t * t;
      } else if (t > t_total - t_acc) {
        const double r = t_total - t;
        s = longest - 0.5 * accel * r * r;
      } else {
        s = d_acc + vmax * (t - t_acc);
      }
      const double frac = s / longest;
      for (int i = 0; i < kSteppers; ++i) {
        // one pulse per axis per tick at most
        const auto want = start[i] + static_cast<std::int64_t>(std::llround(frac * dist[i]));
        if (want != count_[i]) {
          const bool fwd = want > count_[i];
          count_[i] += fwd ? 1 : -1;
          plant_.step_pulse(i, fwd, t_);
        }
      }
      tick_servos();
      (void)plant_.advance_to(t_);
    }
  }

  // Joint targets through the description's conversions.
  void move_joints(const RobotModel& model, const JointVector& q, double speed, double accel) {
    const auto s = joints_to_steps(model, q);
    wrist_us_ = pulse_us(model.motors.wrist, rad_to_deg_(q[3]));
    move_to({s[0], s[1], s[2]}, speed, accel);
  }

  void set_gripper(const RobotModel& model, bool closed) {
    grip_us_ = pulse_us(model.motors.gripper,
                        closed ? model.motors.gripper_closed_deg : model.motors.gripper_open_deg);
  }

  void wait(double seconds) {
    const double end = t_ + seconds;
    while (t_ < end) {
      t_ += kTick;
      tick_servos();
      (void)plant_.advance_to(t_);
    }
  }

  const std::array<std::int64_t, kSteppers>& count() const { return count_; }
  double time_s() const { return t_; }

 private:
  static constexpr double kTick = 50e-6;
  static double rad_to_deg_(double r) { return r * 180.0 / 3.14159265358979323846; }
  static double pulse_us(const ServoSpec& s, double deg) {
    return s.pulse_min_us +
           (deg - s.min_deg) / (s.max_deg - s.min_deg) * (s.pulse_max_us - s.pulse_min_us);
  }
  void tick_servos() {
    if (t_ >= next_servo_) {
      next_servo_ += 0.02;
      if (grip_us_ > 0) plant_.servo_pulse(0, grip_us_);
      if (wrist_us_ > 0) plant_.servo_pulse(1, wrist_us_);
    }
  }

  Plant& plant_;
  std::array<std::int64_t, kSteppers> count_{};
  double t_ = 0.0;
  double next_servo_ = 0.0;
  double grip_us_ = 0.0;
  double wrist_us_ = 0.0;
};

}  // namespace scaratwin::plant::testing
