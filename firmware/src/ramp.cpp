#include "ramp.h"

#include <math.h>

namespace fw {
namespace {

float approach(float v, float goal, float dv) {
  if (v < goal) return v + dv < goal ? v + dv : goal;
  return v - dv > goal ? v - dv : goal;
}

int32_t round_to_int(float x) { return (int32_t)(x < 0 ? x - 0.5f : x + 0.5f); }

}  // namespace

void AxisRamp::move_by(int32_t distance) {
  // continue from the current speed if already moving; restart the step count
  pos_ = pos_ - (float)emitted_;
  emitted_ = 0;
  target_ = distance;
  arrived_ = false;
  mode_ = kPosition;
}

void AxisRamp::run_at(float speed) {
  if (mode_ != kVelocity) {
    pos_ = pos_ - (float)emitted_;
    emitted_ = 0;
    arrived_ = false;
  }
  v_target_ = speed;
  mode_ = kVelocity;
}

void AxisRamp::reset() {
  mode_ = kIdle;
  v_ = 0;
  pos_ = 0;
  emitted_ = 0;
  target_ = 0;
  v_target_ = 0;
  arrived_ = false;
}

int16_t AxisRamp::next(float dt_s, float max_speed, float accel) {
  if (mode_ == kIdle) return 0;
  const float dv = accel * dt_s;
  if (mode_ == kVelocity) {
    float goal = v_target_;
    if (goal > max_speed) goal = max_speed;
    if (goal < -max_speed) goal = -max_speed;
    v_ = approach(v_, goal, dv);
    pos_ += v_ * dt_s;
    int32_t whole = round_to_int(pos_);
    int16_t out = (int16_t)(whole - emitted_);
    emitted_ = whole;
    if (v_ == 0 && v_target_ == 0) {
      pos_ = (float)emitted_;
      mode_ = kIdle;
    }
    return out;
  }
  // position mode: the fastest speed from which the rest can still be stopped in, counted in
  // whole intervals of dv less speed each (v, v - dv, ..., dv covers dt dv k (k + 1) / 2)
  float rest = (float)target_ - pos_;
  float sign = rest < 0 ? -1.0f : 1.0f;
  float reach = 0.5f * dv * (sqrtf(1.0f + 8.0f * (rest * sign) / (dv * dt_s)) - 1.0f);
  float goal = sign * (reach < max_speed ? reach : max_speed);
  v_ = approach(v_, goal, dv);
  float step = v_ * dt_s;
  if (arrived_) {
    // the interval after arrival: the speed falls from its last value (<= dv) to rest
    v_ = 0;
    mode_ = kIdle;
  } else if ((step * sign >= rest * sign) || (rest * sign < 0.5f && v_ * sign <= dv)) {
    // arrives in this interval, at a speed no higher than v_
    pos_ = (float)target_;
    arrived_ = true;
  } else {
    pos_ += step;
  }
  int32_t whole = arrived_ ? target_ : round_to_int(pos_);
  int16_t out = (int16_t)(whole - emitted_);
  emitted_ = whole;
  if (mode_ == kIdle) {
    pos_ = 0;
    emitted_ = 0;
    arrived_ = false;
  }
  return out;
}

}  // namespace fw
