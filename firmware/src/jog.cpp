#include "jog.h"

#include "motion.h"
#include "settings.h"
#include "stepper.h"

namespace fw {
namespace {

AxisRamp g_ramps[kNumAxes];
constexpr uint8_t kLookahead = 3;  // segments queued ahead (30 ms)

bool ramps_idle() {
  for (uint8_t i = 0; i < kNumAxes; ++i)
    if (!g_ramps[i].idle()) return false;
  return true;
}

}  // namespace

void jog_move(uint8_t axis, int32_t steps) { g_ramps[axis].move_by(steps); }
void jog_run(uint8_t axis, float speed) { g_ramps[axis].run_at(speed); }

void jog_reset() {
  for (uint8_t i = 0; i < kNumAxes; ++i) g_ramps[i].reset();
}

bool jog_active() { return !ramps_idle() || stepper_active(); }
bool jog_ramping() { return !ramps_idle(); }

void jog_feed(const Settings& s, uint16_t speed) {
  if (ramps_idle()) return;
  const MotionQueue& q = stepper_queue();
  const float dt_s = (float)kJogSegmentMs / 1000.0f;
  while (q.count() < kLookahead && !ramps_idle()) {
    Segment seg;
    uint16_t max_abs = 0;
    for (uint8_t i = 0; i < kNumAxes; ++i) {
      seg.delta[i] = g_ramps[i].next(dt_s, (float)speed, (float)s.max_accel);
      uint16_t a = (uint16_t)(seg.delta[i] < 0 ? -seg.delta[i] : seg.delta[i]);
      if (a > max_abs) max_abs = a;
    }
    seg.length_q8 = (uint32_t)kJogSegmentMs * kTicksPerMs * 256u;
    seg.hold_dec_q16 = hold_decrement_q16(max_abs, kJogSegmentMs, s.max_accel);
    seg.wrist_cdeg = 0;
    seg.grip_cdeg = 0;
    seg.seq = 0;
    seg.flags = 0;
    stepper_push(seg);
  }
  stepper_set_run(true);
}

}  // namespace fw
