#include "motion.h"

namespace fw {
namespace {

float absf(float x) { return x < 0 ? -x : x; }

}  // namespace

uint16_t hold_decrement_q16(uint16_t max_abs_delta, uint16_t dt_ms, uint16_t accel) {
  if (max_abs_delta == 0) return 65535;
  // speed v = d / dt; the scale falls from 1 to 0 in v / a seconds = v / a * kTickHz ticks
  float v = (float)max_abs_delta * 1000.0f / (float)dt_ms;
  float ticks = v / (float)accel * (float)kTickHz;
  float dec = 65536.0f / ticks;
  if (dec < 1.0f) return 1;
  if (dec > 65535.0f) return 65535;
  return (uint16_t)dec;
}

PlanError plan_point(const MotorLimits& limits, PlanState& state, const TimedPoint& p, Segment& out,
                     uint8_t* axis) {
  if (p.dt_ms == 0 || p.dt_ms > kMaxPointMs) {
    *axis = 0;
    return kPlanBadDuration;
  }
  const float dt_s = (float)p.dt_ms / 1000.0f;
  float velocity[kNumAxes];
  uint16_t max_abs = 0;
  uint16_t worst_accel = 0xffff;
  for (uint8_t i = 0; i < kNumAxes; ++i) {
    int32_t d = p.target[i] - state.position[i];
    if (d > 32767 || d < -32767) {
      *axis = i;
      return kPlanTooFar;
    }
    uint16_t ad = (uint16_t)(d < 0 ? -d : d);
    if (ad > max_abs) max_abs = ad;
    if (limits.max_accel[i] < worst_accel) worst_accel = limits.max_accel[i];
    // speed: one step of quantisation allowed
    if ((float)ad > (float)limits.max_speed[i] * dt_s + 1.0f) {
      *axis = i;
      return kPlanSpeed;
    }
    velocity[i] = (float)d / dt_s;
    // acceleration: the average speeds of consecutive segments of a trajectory sampled from a
    // profile with acceleration a differ by about a * dt; allow 25 % plus the whole-step
    // quantisation of both segments
    float a = (float)limits.max_accel[i];
    float allowed = a * dt_s * 1.25f + 2.0f / dt_s;
    if (absf(velocity[i] - state.velocity[i]) > allowed) {
      *axis = i;
      return kPlanAccel;
    }
    // the last point must come to rest within one segment
    if (p.last && absf(velocity[i]) > allowed) {
      *axis = i;
      return kPlanAccel;
    }
  }
  for (uint8_t i = 0; i < kNumAxes; ++i) {
    out.delta[i] = (int16_t)(p.target[i] - state.position[i]);
    state.position[i] = p.target[i];
    state.velocity[i] = p.last ? 0.0f : velocity[i];
  }
  out.length_q8 = (uint32_t)p.dt_ms * kTicksPerMs * 256u;
  out.hold_dec_q16 = hold_decrement_q16(max_abs, p.dt_ms, worst_accel);
  out.wrist_cdeg = p.wrist_cdeg;
  out.grip_cdeg = p.grip_cdeg < 0 ? 0 : p.grip_cdeg;
  out.seq = p.seq;
  out.flags =
      (uint8_t)(kSegTrajectory | (p.last ? kSegLast : 0) | (p.grip_cdeg >= 0 ? kSegGrip : 0));
  return kPlanOk;
}

}  // namespace fw
