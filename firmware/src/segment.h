// Motion segments and their step distribution (pure: no hardware, built for the host's unit
// tests too). A segment moves the three steppers by whole step counts in a fixed time, all
// axes starting and ending together. The step generator runs a digital differential analyser
// (DDA, Bresenham's line) per axis at the fixed tick rate: each tick advances the segment's
// clock by `rate` (256 = full speed, less while a feed hold decelerates) and an axis steps
// whenever its accumulator passes the segment length. The last tick is clamped to the
// segment's end, so a segment always emits exactly |delta| steps per axis, evenly spaced,
// whatever the rate profile was: a trajectory ends at exactly its planned step counts.
#pragma once

#include <stdint.h>

#include "fw_config.h"

namespace fw {

enum SegmentFlags : uint8_t {
  kSegTrajectory = 1,  // a point of a TB/TP trajectory (else a generated jog / homing segment)
  kSegLast = 2,        // the last point of its trajectory
  kSegGrip = 4,        // set the gripper to grip_cdeg when the point is reached
};

struct Segment {
  int16_t delta[kNumAxes];  // steps per axis
  uint32_t length_q8;       // duration in 1/256 ticks: dt_ms * kTicksPerMs * 256
  uint16_t hold_dec_q16;    // speed-scale decrement per tick that decelerates at max accel
  int16_t wrist_cdeg;       // wrist servo angle reached at the end of the segment
  int16_t grip_cdeg;        // gripper angle set at the end (with kSegGrip)
  uint16_t seq;             // trajectory point number
  uint8_t flags;
};

// Step distribution of the segment being executed.
struct Dda {
  uint32_t length = 0;  // segment length, 1/256 ticks
  uint32_t time = 0;    // elapsed, 1/256 ticks
  uint32_t acc[kNumAxes] = {0, 0, 0};
  uint16_t abs_delta[kNumAxes] = {0, 0, 0};
  uint8_t dir_negative = 0;  // bit i: axis i moves towards negative counts

  void start(const Segment& s) {
    length = s.length_q8;
    time = 0;
    dir_negative = 0;
    for (uint8_t i = 0; i < kNumAxes; ++i) {
      int16_t d = s.delta[i];
      if (d < 0) dir_negative |= (uint8_t)(1u << i);
      abs_delta[i] = (uint16_t)(d < 0 ? -d : d);
      acc[i] = length / 2;  // centred: the steps fall in the middle of their slots
    }
  }

  bool done() const { return time >= length; }

  // Advances the segment clock by `rate` (1..256) 1/256 ticks; returns the mask of axes that
  // step now. At most one step per axis per tick while |delta| <= ticks (checked by the
  // planner: the speed limit is far below the tick rate).
  uint8_t tick(uint16_t rate) {
    if (rate == 256 && length - time >= 256) {
      // the common case, full speed inside the segment: shifts instead of multiplications
      // (an 8-bit AVR multiplies 16 x 32 bits in a library call; this runs 20,000 times a
      // second in the step interrupt)
      time += 256;
      uint8_t mask = 0;
      for (uint8_t i = 0; i < kNumAxes; ++i) {
        acc[i] += (uint32_t)abs_delta[i] << 8;
        if (acc[i] >= length) {
          acc[i] -= length;
          mask |= (uint8_t)(1u << i);
        }
      }
      return mask;
    }
    uint32_t r = rate;
    uint32_t rest = length - time;
    if (r > rest) r = rest;
    time += r;
    uint8_t mask = 0;
    for (uint8_t i = 0; i < kNumAxes; ++i) {
      acc[i] += (uint32_t)abs_delta[i] * r;
      if (acc[i] >= length) {
        acc[i] -= length;
        mask |= (uint8_t)(1u << i);
      }
    }
    return mask;
  }
};

}  // namespace fw
