#include "homing.h"

#include "jog.h"
#include "settings.h"
#include "stepper.h"

namespace fw {
namespace {

constexpr int32_t kMaxSearch = 60000;
enum Phase : uint8_t { kIdle, kClear, kSeek, kBackoff, kGoHome };
Phase g_phase = kIdle;
uint8_t g_axis = 0;
int32_t g_seek_from = 0;
int32_t g_offset[kNumAxes] = {0, 0, 0};
int32_t g_switch[kNumAxes] = {0, 0, 0};  // the counts set at the switches
bool g_clear_stopping = false;           // kClear: the switch opened, the axis is coming to rest

int32_t position(uint8_t axis) {
  int32_t p[kNumAxes];
  stepper_positions(p);
  return p[axis];
}

// floor(a / b) for b > 0
int32_t floor_div(int32_t a, int32_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

void begin_axis(const Settings& s) {
  const uint8_t bit = (uint8_t)(1u << g_axis);
  if (stepper_endstops() & bit) {
    // already on (or past) its switch, as J3 can be after J2 homed and the belt coupling
    // turned it: run away from the switch until it opens, then seek it as usual
    g_phase = kClear;
    g_clear_stopping = false;
    g_seek_from = position(g_axis);
    stepper_guard_endstops(0);
    jog_run(g_axis, -(float)s.homing_dir[g_axis] * (float)s.homing_speed);
    return;
  }
  g_phase = kSeek;
  g_seek_from = position(g_axis);
  stepper_guard_endstops(bit);
  jog_run(g_axis, (float)s.homing_dir[g_axis] * (float)s.homing_speed);
}

}  // namespace

void homing_start(const Settings& s) {
  jog_reset();
  g_axis = 0;
  begin_axis(s);
}

void homing_abort() {
  g_phase = kIdle;
  stepper_guard_endstops(0);
}

bool homing_active() { return g_phase != kIdle; }

int32_t homing_offset(uint8_t axis) { return axis < kNumAxes ? g_offset[axis] : 0; }
const int32_t* homing_switch_counts() { return g_switch; }

HomingResult homing_update(const Settings& s, uint8_t events, uint8_t endstops_hit,
                           uint8_t* failed_axis) {
  switch (g_phase) {
    case kIdle:
      return kHomingIdle;
    case kClear: {
      if (stepper_endstops() & (1u << g_axis)) {
        const int32_t travelled = position(g_axis) - g_seek_from;
        if (travelled > kMaxSearch || travelled < -kMaxSearch || !jog_active()) {
          *failed_axis = g_axis;
          g_phase = kIdle;
          stepper_request_stop();
          return kHomingFailed;
        }
        return kHomingRunning;
      }
      if (!g_clear_stopping) {
        g_clear_stopping = true;
        jog_run(g_axis, 0.0f);  // decelerate to rest a little past the opening point
        return kHomingRunning;
      }
      if (!jog_active()) begin_axis(s);
      return kHomingRunning;
    }
    case kSeek: {
      if ((events & kEvEndstop) && (endstops_hit & (1u << g_axis))) {
        jog_reset();
        stepper_guard_endstops(0);
        int32_t value = s.endstop[g_axis];
        if (g_axis == 2) {
          int32_t j2 = position(1);
          value += floor_div(j2 * (int32_t)s.coupling_permille, 1000);
        }
        g_offset[g_axis] = position(g_axis) - value;
        g_switch[g_axis] = value;
        stepper_set_position(g_axis, value);
        g_phase = kBackoff;
        jog_move(g_axis, -(int32_t)s.homing_dir[g_axis] * (int32_t)s.pulloff);
        return kHomingRunning;
      }
      int32_t travelled = position(g_axis) - g_seek_from;
      if (travelled > kMaxSearch || travelled < -kMaxSearch) {
        *failed_axis = g_axis;
        g_phase = kIdle;
        stepper_guard_endstops(0);
        stepper_request_stop();
        return kHomingFailed;
      }
      return kHomingRunning;
    }
    case kBackoff:
      if (jog_active()) return kHomingRunning;
      if (g_axis + 1 < kNumAxes) {
        ++g_axis;
        begin_axis(s);
        return kHomingRunning;
      }
      {
        int32_t p[kNumAxes];
        stepper_positions(p);
        for (uint8_t i = 0; i < kNumAxes; ++i) jog_move(i, s.home[i] - p[i]);
      }
      g_phase = kGoHome;
      return kHomingRunning;
    case kGoHome:
      if (jog_active()) return kHomingRunning;
      g_phase = kIdle;
      stepper_guard_endstops(7);
      return kHomingDone;
  }
  return kHomingIdle;
}

}  // namespace fw
