// Motion buffer (pure: no hardware, built for the host's unit tests too). Holds the queue of
// segments between the main loop (producer) and the step interrupt (consumer), and turns the
// host's timed trajectory points (TP: absolute motor targets reached dt_ms after the previous
// point) into segments after checking them against the motor limits: speed per axis, and the
// change of speed between consecutive points (acceleration), both with a small allowance for
// the whole-step quantisation. The queue's free slots are the host's credit for flow control.
#pragma once

#include <stdint.h>

#include "fw_config.h"
#include "segment.h"

namespace fw {

// Single-producer (main loop), single-consumer (step interrupt) ring of segments.
class MotionQueue {
 public:
  static constexpr uint8_t kCapacity = kQueueSize - 1;  // one slot tells full from empty

  uint8_t count() const { return (uint8_t)((head_ - tail_) & (kQueueSize - 1)); }
  uint8_t free_slots() const { return (uint8_t)(kCapacity - count()); }
  bool empty() const { return head_ == tail_; }
  // Producer side.
  bool push(const Segment& s) {
    uint8_t next = (uint8_t)((head_ + 1) & (kQueueSize - 1));
    if (next == tail_) return false;
    buf_[head_] = s;
    // the segment must be complete before the consumer can see it
    __asm__ __volatile__("" ::: "memory");
    head_ = next;
    return true;
  }
  // Consumer side: the oldest segment, or nullptr.
  const Segment* front() const { return head_ == tail_ ? nullptr : &buf_[tail_]; }
  void pop() {
    __asm__ __volatile__("" ::: "memory");
    if (head_ != tail_) tail_ = (uint8_t)((tail_ + 1) & (kQueueSize - 1));
  }
  // Consumer side (the step interrupt, on a stop): drops everything queued.
  void clear() { tail_ = head_; }

 private:
  Segment buf_[kQueueSize];
  volatile uint8_t head_ = 0;
  volatile uint8_t tail_ = 0;
};

// Motor limits the planner checks points against.
struct MotorLimits {
  uint16_t max_speed[kNumAxes];  // steps/s
  uint16_t max_accel[kNumAxes];  // steps/s^2
};

// One timed point as received (TP).
struct TimedPoint {
  uint16_t seq;
  uint16_t dt_ms;
  int32_t target[kNumAxes];  // absolute motor steps
  int16_t wrist_cdeg;
  int16_t grip_cdeg;  // < 0: none
  bool last;          // last point of its trajectory (must end at rest)
};

// Where the planned motion stands after the points accepted so far.
struct PlanState {
  int32_t position[kNumAxes];  // target of the last accepted point (or the rest position)
  float velocity[kNumAxes];    // steps/s of the last accepted segment (0 at rest)
};

enum PlanError : uint8_t {
  kPlanOk = 0,
  kPlanBadDuration,  // dt_ms outside 1..kMaxPointMs
  kPlanTooFar,       // a delta does not fit a segment (> 32767 steps)
  kPlanSpeed,        // an axis exceeds its speed limit
  kPlanAccel,        // an axis changes speed faster than its acceleration limit
};

// Checks `p` against the limits from `state`; on success fills `out`, advances `state` and
// returns kPlanOk; otherwise returns the error and sets *axis to the offending axis.
PlanError plan_point(const MotorLimits& limits, PlanState& state, const TimedPoint& p, Segment& out,
                     uint8_t* axis);

// Speed-scale decrement per tick (Q16) that brings a segment of `max_abs_delta` steps in
// `dt_ms` to rest at `accel` steps/s^2.
uint16_t hold_decrement_q16(uint16_t max_abs_delta, uint16_t dt_ms, uint16_t accel);

}  // namespace fw
