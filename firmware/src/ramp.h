// Acceleration-limited motion of single axes (pure: no hardware, built for the host's unit
// tests too). Jogs (JG, jog buttons) and homing do not come with a timed trajectory, so the
// firmware makes one: each axis follows a trapezoidal speed profile, either towards a target
// distance (position mode, ends exactly on it) or towards a signed speed (velocity mode, for
// a held button or an endstop search), and is sampled every kJogSegmentMs into segments for
// the same queue and step generator as the host's trajectories.
#pragma once

#include <stdint.h>

namespace fw {

class AxisRamp {
 public:
  enum Mode : uint8_t { kIdle, kVelocity, kPosition };

  // Moves `distance` steps from the current point (position mode).
  void move_by(int32_t distance);
  // Runs towards `speed` steps/s (signed); 0 ramps down to rest and then idles.
  void run_at(float speed);
  // Forgets all motion (after a hard stop).
  void reset();

  bool idle() const { return mode_ == kIdle; }
  Mode mode() const { return mode_; }
  float speed() const { return v_; }

  // Advances by dt_s at most `max_speed` (steps/s) and `accel` (steps/s^2); returns the whole
  // steps to emit for this interval.
  int16_t next(float dt_s, float max_speed, float accel);

 private:
  Mode mode_ = kIdle;
  float v_ = 0;           // steps/s
  float pos_ = 0;         // steps travelled since the move began (fractional)
  int32_t emitted_ = 0;   // whole steps handed out
  int32_t target_ = 0;    // position mode: total distance
  float v_target_ = 0;    // velocity mode: requested speed
  bool arrived_ = false;  // position mode: on target, one interval left to come to rest
};

}  // namespace fw
