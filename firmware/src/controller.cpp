#include "controller.h"

#include <avr/interrupt.h>

#include "board.h"
#include "buttons.h"
#include "clock.h"
#include "companion.h"
#include "fw_config.h"
#include "homing.h"
#include "jog.h"
#include "motion.h"
#include "report.h"
#include "scaratwin/protocol/codec_core.h"
#include "serial.h"
#include "servo.h"
#include "settings.h"
#include "settings_store.h"
#include "stepper.h"

namespace fw {
namespace {

namespace core = scaratwin::protocol::core;
using core::code_id;

// unsolicited events (docs/protocol.md section 8)
enum Event : uint8_t {
  kEvHomed = 1,
  kEvEndstopHit = 2,
  kEvTrajectoryDone = 3,
  kEvJogButton = 4,
  kEvUnderrun = 5,
  kEvStoppedEv = 6,
  kEvHeldEv = 7,
  kEvResumed = 8,
  kEvHomingFailed = 9,
  kEvHomingOffsetZ = 10,  // 11 J2, 12 J3: re-homing found the count this many steps off
};

// ST flag bits (the endstop bits 32/64/128 are added by report.cpp)
enum Flag : uint8_t {
  kFlagHomed = 1,
  kFlagMoving = 2,
  kFlagTrajectory = 4,
  kFlagHold = 8,
  kFlagHalted = 16
};

Settings g_settings;
char g_line[kLineMax];
core::Decoder g_decoder(core::kSerialHostToDevice, g_line, kLineMax);

bool g_homed = false;
bool g_rehoming = false;  // HM while homed: report the offsets the switches show
bool g_halted = false;
volatile bool g_rt_stop = false;    // set by '!' in the receive interrupt
volatile bool g_rt_resume = false;  // set by '~'
// EV 6 once the step generator confirms; set with the stop's request (for '!' in the receive
// interrupt), so that a tick that confirms the stop before the main loop next looks at the
// real-time flags cannot leave the confirmation unsent
volatile bool g_stop_pending = false;
bool g_baud_pending = false;  // CF 11 changed the rate: switch once its AK has left
uint32_t g_baud_idle_us = 0;  // when the transmit ring was first seen empty

struct Trajectory {
  bool active;
  uint16_t n;
  uint16_t next_seq;  // next TP expected
  uint16_t done;      // points reached
  bool underrun_sent;
  PlanState plan;
} g_traj;

// the companion dialect (setting 10, companion.h)
struct Companion {
  bool in_line;  // the current line is a companion line
  bool at_line_start;
  bool overlong;
  uint8_t len;
  bool busy;                 // a homing at power-up or an m move: nothing is read until it ends
  bool moving;               // an m move runs (at the speed limit)
  int32_t target[kNumAxes];  // companion frame
} g_comp;
// A companion line is kept in g_line, the v1 decoder's buffer: a companion line starts only at a
// line start, where the decoder holds nothing (the Uno's RAM is short).
static_assert(kCompanionLineMax <= kLineMax, "a companion line must fit the line buffer");

// ---- replies ----

void send(core::Encoder& enc) {
  if (enc.end()) serial_write(enc.data(), (uint8_t)enc.size());
}

void reply_ak(char a, char b, bool with_value, int32_t value) {
  char buf[24];
  const char code[2] = {a, b};
  core::Encoder enc(core::kSerialDeviceToHost, buf, sizeof buf);
  enc.begin(code_id('A', 'K'));
  enc.add_text(code, 2);
  if (with_value) enc.add_i32(value);
  send(enc);
}

void reply_er(uint8_t err, bool with_detail, int32_t detail) {
  char buf[24];
  core::Encoder enc(core::kSerialDeviceToHost, buf, sizeof buf);
  enc.begin(code_id('E', 'R'));
  enc.add_i32(err);
  if (with_detail) enc.add_i32(detail);
  send(enc);
}

void send_ev(uint8_t event, bool with_value, int32_t value) {
  char buf[24];
  core::Encoder enc(core::kSerialDeviceToHost, buf, sizeof buf);
  enc.begin(code_id('E', 'V'));
  enc.add_i32(event);
  if (with_value) enc.add_i32(value);
  send(enc);
}

// The hello; `described`: answering a hello that carried the host's description hash, so the
// host reads this one's (docs/protocol.md section 11). The hello after reset has none.
void send_hello(bool described) {
  char buf[48];
  core::Encoder enc(core::kSerialDeviceToHost, buf, sizeof buf);
  enc.begin(code_id('H', 'I'));
  enc.add_i32(FW_PROTO_VERSION);
  enc.add_text(FW_BOARD_NAME);
  enc.add_text(FW_VERSION);
  if (described) enc.add_text(desc::kDescriptionHash);
  send(enc);
}

// ---- state ----

bool moving() { return jog_active() || homing_active() || stepper_active(); }

uint8_t flags() {
  uint8_t f = 0;
  if (g_homed) f |= kFlagHomed;
  if (moving()) f |= kFlagMoving;
  if (g_traj.active) f |= kFlagTrajectory;
  if (stepper_holding()) f |= kFlagHold;
  if (g_halted) f |= kFlagHalted;
  return f;
}

uint8_t queue_free() { return stepper_queue().free_slots(); }

MotorLimits limits() {
  MotorLimits l;
  for (uint8_t i = 0; i < kNumAxes; ++i) {
    l.max_speed[i] = g_settings.max_speed;
    l.max_accel[i] = g_settings.max_accel;
  }
  return l;
}

void end_trajectory() {
  g_traj.active = false;
  stepper_set_run(true);
}

// Everything a stop cancels; the step generator already dropped its queue.
void cancel_motion() {
  end_trajectory();
  homing_abort();
  jog_reset();
}

// Whether the motors run (or are about to) for a motion that is not given up: a segment
// steps, segments will start by themselves, homing or a jog generates them. A hold at rest
// is no motion; neither is a trajectory at rest whose points stopped coming (its host gave
// up: a queue underrun, a load never finished).
bool motors_running() {
  if (stepper_moving()) return true;
  return !stepper_holding() && (homing_active() || jog_ramping());
}

// Drops what an earlier motion left at rest (a trajectory and its queue, a hold, a homing or
// jog held at rest). False while the motors run or a stop is being carried out.
bool discard_motion() {
  if (motors_running() || !stepper_discard()) return false;
  cancel_motion();
  return true;
}

// A motion command is refused while halted or held (14), or busy with another motion (9).
// A trajectory left at rest by a host that gave up does not make the robot busy: it is
// discarded (docs/protocol.md: TB clears the queue; the host never has to know it was there).
bool motion_refused(bool allow_jog) {
  if (g_halted || stepper_holding()) {
    reply_er(core::kErrHalted, false, 0);
    return true;
  }
  const bool jogging = jog_ramping() || (!g_traj.active && stepper_moving());
  if (homing_active() || (g_traj.active && stepper_moving()) || (!allow_jog && jogging)) {
    reply_er(core::kErrBusy, false, 0);
    return true;
  }
  if (g_traj.active && !discard_motion()) {
    reply_er(core::kErrBusy, false, 0);
    return true;
  }
  return false;
}

// ---- commands ----

void cmd_tb(const core::Packet& p) {
  int32_t n = p.i32(0);
  if (n < 1 || n > 65535) return reply_er(core::kErrBadValue, true, 0);
  if (motion_refused(false)) return;
  if (!g_homed) return reply_er(core::kErrNotHomed, false, 0);
  g_traj.active = true;
  g_traj.n = (uint16_t)n;
  g_traj.next_seq = 0;
  g_traj.done = 0;
  g_traj.underrun_sent = false;
  stepper_positions(g_traj.plan.position);
  for (uint8_t i = 0; i < kNumAxes; ++i) g_traj.plan.velocity[i] = 0;
  stepper_set_run(false);  // pre-fill: starts when full or complete
  stepper_set_wrist_base(servo_target(kServoWrist));
  reply_ak('T', 'B', true, queue_free());
}

void cmd_tp(const core::Packet& p) {
  if (g_halted || stepper_holding()) return reply_er(core::kErrHalted, false, 0);
  if (!g_traj.active) return reply_er(core::kErrSequence, true, 0);
  if (p.i32(0) != (int32_t)g_traj.next_seq)
    return reply_er(core::kErrSequence, true, g_traj.next_seq);
  const MotionQueue& q = stepper_queue();
  if (q.free_slots() == 0) return reply_er(core::kErrQueueFull, true, 0);
  TimedPoint pt;
  pt.seq = g_traj.next_seq;
  int32_t dt = p.i32(1);
  if (dt < 1 || dt > (int32_t)kMaxPointMs) return reply_er(core::kErrBadValue, true, 1);
  pt.dt_ms = (uint16_t)dt;
  for (uint8_t i = 0; i < kNumAxes; ++i) pt.target[i] = p.i32((uint8_t)(2 + i));
  int32_t wrist = p.i32(5);
  if (wrist < 0 || wrist > 18000) return reply_er(core::kErrJointLimit, true, 3);
  pt.wrist_cdeg = (int16_t)wrist;
  pt.grip_cdeg = -1;
  if (p.field_count > 6) {
    int32_t grip = p.i32(6);
    if (grip < 0 || grip > 18000) return reply_er(core::kErrBadValue, true, 6);
    pt.grip_cdeg = (int16_t)grip;
  }
  pt.last = g_traj.next_seq + 1u == g_traj.n;
  Segment seg;
  uint8_t axis = 0;
  PlanError e = plan_point(limits(), g_traj.plan, pt, seg, &axis);
  if (e != kPlanOk) return reply_er(core::kErrBadValue, true, 2 + axis);
  stepper_push(seg);
  g_traj.next_seq++;
  g_traj.underrun_sent = false;
  if (pt.last || q.free_slots() == 0) stepper_set_run(true);
  reply_ak('T', 'P', true, q.free_slots());
}

void cmd_cf(const core::Packet& p) {
  int32_t value = 0;
  if (p.field_count == 1) {
    if (settings_get(g_settings, p.i32(0), &value) != kSettingOk)
      return reply_er(core::kErrBadValue, true, 0);
    return reply_ak('C', 'F', true, value);
  }
  SettingError e = settings_set(g_settings, p.i32(0), p.i32(1));
  if (e == kSettingUnknownKey) return reply_er(core::kErrBadValue, true, 0);
  if (e == kSettingBadValue) return reply_er(core::kErrBadValue, true, 1);
  settings_save(g_settings);
  settings_get(g_settings, p.i32(0), &value);
  reply_ak('C', 'F', true, value);
  if (p.i32(0) == 10) report_set_single_class(g_settings.companion == 2);
  if (p.i32(0) == 11) {
    g_baud_pending = true;  // the reply goes out at the old rate
    g_baud_idle_us = 0;
  }
}

// Switches the serial rate once the CF 11 reply has left: the ring empty, then 3 ms for the
// UART's last two bytes (2.1 ms at 9600 baud).
void handle_baud(uint32_t now) {
  if (!g_baud_pending) return;
  if (!serial_tx_empty()) {
    g_baud_idle_us = 0;
    return;
  }
  if (g_baud_idle_us == 0) g_baud_idle_us = now | 1u;
  if ((uint32_t)(now - g_baud_idle_us) < 3000u) return;
  serial_set_baud((uint32_t)g_settings.baud_hundreds * 100u);
  g_baud_pending = false;
}

void cmd_jg(const core::Packet& p) {
  int32_t axis = p.i32(0);
  int32_t delta = p.i32(1);
  if (axis < 0 || axis > 3) return reply_er(core::kErrBadValue, true, 0);
  if (delta < -1000000 || delta > 1000000) return reply_er(core::kErrBadValue, true, 1);
  if (motion_refused(true)) return;
  if (axis == 3) {
    int32_t w = (int32_t)servo_target(kServoWrist) + delta;
    if (w < 0 || w > 18000) return reply_er(core::kErrJointLimit, true, 3);
    servo_set_target(kServoWrist, (int16_t)w);
  } else {
    jog_move((uint8_t)axis, delta);
  }
  reply_ak('J', 'G', false, 0);
}

// ---- the companion dialect ----

void companion_error(CompanionError why, int32_t lo = 0, int32_t hi = 0, int8_t axis = -1,
                     int32_t target = 0) {
  char buf[kCompanionReserve];
  const uint8_t n =
      companion_error_line(buf, sizeof buf, g_line, g_comp.len, why, lo, hi, axis, target);
  serial_write(buf, n);
}

// The targets of the companion frame now (after homing: where the robot is).
void companion_targets_from_position() {
  int32_t p[kNumAxes];
  stepper_positions(p);
  for (uint8_t i = 0; i < kNumAxes; ++i) g_comp.target[i] = p[i] - homing_switch_counts()[i];
}

// False (and an error line) if target t of `axis` is beyond its limits; J3 with J2 target j2.
// For m the error line names the target.
bool companion_within(uint8_t axis, int32_t t, int32_t j2, bool for_move) {
  int32_t lo = 0, hi = 0;
  companion_range(homing_switch_counts(), j2, g_settings.coupling_permille, axis, &lo, &hi);
  if (t >= lo && t <= hi) return true;
  companion_error(kCompErrLimit, lo, hi, for_move ? (int8_t)axis : (int8_t)-1, t);
  return false;
}

void companion_move() {
  if (!g_homed) return companion_error(kCompErrNotHomed);
  if (g_halted || stepper_holding()) return companion_error(kCompErrHalted);
  if (homing_active() || g_traj.active || jog_active()) return companion_error(kCompErrBusy);
  // a J2 target changed after the x line may carry J3 beyond its limits: check all again
  for (uint8_t i = 0; i < kNumAxes; ++i)
    if (!companion_within(i, g_comp.target[i], g_comp.target[1], true)) return;
  int32_t p[kNumAxes];
  stepper_positions(p);
  const int32_t* zero = homing_switch_counts();
  for (uint8_t i = 0; i < kNumAxes; ++i) jog_move(i, zero[i] + g_comp.target[i] - p[i]);
  g_comp.busy = true;
  g_comp.moving = true;
}

void companion_line() {
  if (g_comp.overlong) return companion_error(kCompErrTooLong);
  uint8_t axis = 0;
  int32_t steps = 0;
  switch (companion_parse(g_line, g_comp.len, &axis, &steps)) {
    case kCompanionTarget: {
      // before homing the frame has no zero yet: targets wait for m, which needs homing
      if (g_homed && !companion_within(axis, steps, axis == 1 ? steps : g_comp.target[1], false))
        return;
      g_comp.target[axis] = steps;
      return;
    }
    case kCompanionMove:
      return companion_move();
    case kCompanionBadLine:
      return companion_error(kCompErrBadNumber);
    case kCompanionUnknown:
      return companion_error(kCompErrUnknown);
  }
}

// True if the next received byte starts a companion line.
bool companion_line_next() {
  const int16_t b = serial_peek();
  return g_settings.companion != 0 && b >= 'a' && b <= 'z';
}

// Routes one received byte of a companion line; true if the byte was one.
bool companion_byte(uint8_t b) {
  const bool start = g_comp.at_line_start;
  g_comp.at_line_start = b == '\n';
  if (start) {
    g_comp.in_line = g_settings.companion != 0 && b >= 'a' && b <= 'z';
    g_comp.len = 0;
    g_comp.overlong = false;
  }
  if (!g_comp.in_line) return false;
  if (b == '\n') {
    if (g_comp.len > 0 && g_line[g_comp.len - 1] == '\r') --g_comp.len;
    companion_line();
    g_comp.in_line = false;
  } else if (g_comp.len < kCompanionLineMax) {
    g_line[g_comp.len++] = (char)b;
  } else {
    g_comp.overlong = true;
  }
  return true;
}

void handle_packet(const core::Packet& p) {
  switch (p.code) {
    case code_id('H', 'I'):
      if (p.i32(0) != FW_PROTO_VERSION) return reply_er(core::kErrVersion, true, FW_PROTO_VERSION);
      return send_hello(p.field_count > 1);
    case code_id('P', 'I'):
      return reply_ak('P', 'I', p.field_count > 0, p.field_count > 0 ? p.i32(0) : 0);
    case code_id('S', 'R'): {
      int32_t r = p.i32(0);
      if (r < 0 || r > 1000) return reply_er(core::kErrBadValue, true, 0);
      report_set_rate((uint16_t)r, clock_micros());
      return reply_ak('S', 'R', true, r);
    }
    case code_id('Q', 'S'):
      report_now(flags(), queue_free());
      return;
    case code_id('H', 'M'):
      // recovers from any state at rest: halted, held, a trajectory its host gave up; only a
      // motion still running (or a stop being carried out) makes it wait
      if (!discard_motion()) return reply_er(core::kErrBusy, false, 0);
      g_halted = false;
      g_rehoming = g_homed;  // the switches will tell how far the counts drifted
      g_homed = false;
      homing_start(g_settings);
      return reply_ak('H', 'M', false, 0);
    case code_id('T', 'B'):
      return cmd_tb(p);
    case code_id('T', 'P'):
      return cmd_tp(p);
    case code_id('G', 'R'): {
      int32_t g = p.i32(0);
      if (g < 0 || g > 18000) return reply_er(core::kErrBadValue, true, 0);
      servo_set_target(kServoGrip, (int16_t)g);
      return reply_ak('G', 'R', true, g);
    }
    case code_id('J', 'G'):
      return cmd_jg(p);
    case code_id('S', 'P'):
      stepper_request_stop();
      g_halted = true;
      g_stop_pending = true;
      cancel_motion();
      return reply_ak('S', 'P', false, 0);
    case code_id('C', 'F'):
      return cmd_cf(p);
    default:
      return reply_er(core::kErrUnknownCode, false, 0);
  }
}

uint8_t g_lost_lines = 0;  // lines the full receive ring dropped, not yet answered

void read_serial() {
  if (g_baud_pending) return;  // replies wait for the new rate
  // a companion error line is longer than a v1 reply
  while (serial_tx_free() >= (g_comp.in_line ? kCompanionReserve : kReplyReserve)) {
    if (g_lost_lines != 0) {
      // a line that lost bytes gets ER=6=0= in the place of its reply, in order
      --g_lost_lines;
      reply_er(core::kErrQueueFull, true, 0);
      continue;
    }
    // while a companion homing or move runs, the next companion line waits in the ring, as
    // the companion sketch reads nothing then; v1 packets (and lost lines) are served meanwhile
    if (g_comp.busy && g_comp.at_line_start && companion_line_next()) return;
    uint8_t lost = 0;
    int16_t b = serial_read(&lost);
    if (b == kSerialLost) {
      g_decoder.reset();       // the start of the first lost line
      g_comp.in_line = false;  // a companion line lost too; the next byte starts a line
      g_comp.at_line_start = true;
      g_lost_lines = lost;
      continue;
    }
    if (b < 0) return;
    if (companion_byte((uint8_t)b)) continue;
    core::Event ev;
    uint8_t type = g_decoder.push((uint8_t)b, &ev);
    if (type == core::kEventPacket) {
      handle_packet(g_decoder.packet());
      // one packet per pass: a burst of trajectory points (each planned here) must not hold
      // the loop past the next state report's deadline.
      return;
    } else if (type == core::kEventError) {
      reply_er(ev.error, ev.error != core::kErrUnknownCode, ev.detail);
    }
  }
}

void handle_realtime() {
  if (g_rt_stop) {
    g_rt_stop = false;
    g_halted = true;  // the confirmation was asked for in the interrupt (g_stop_pending)
    cancel_motion();
  }
  if (g_rt_resume) {
    g_rt_resume = false;
    bool was = g_halted || stepper_holding();
    g_halted = false;
    stepper_request_resume();
    if (was) send_ev(kEvResumed, false, 0);
  }
}

void handle_stepper_events() {
  uint8_t hit = 0;
  uint16_t done_seq = 0;
  int16_t grip = 0;
  uint8_t ev = stepper_take_events(&hit, &done_seq, &grip);
  if ((ev & kEvStopped) && g_stop_pending) {
    g_stop_pending = false;
    send_ev(kEvStoppedEv, false, 0);
  }
  if (ev & kEvHeld) send_ev(kEvHeldEv, false, 0);
  if (ev & kEvGrip) servo_set_target(kServoGrip, grip);
  if (g_traj.active && (ev & kEvPointDone)) g_traj.done = (uint16_t)(done_seq + 1);
  if (g_traj.active && (ev & kEvLastDone)) {
    end_trajectory();
    send_ev(kEvTrajectoryDone, true, g_traj.n);
  }
  uint8_t failed_axis = 0;
  HomingResult h = homing_update(g_settings, ev, hit, &failed_axis);
  if (h == kHomingDone || h == kHomingFailed) g_comp.busy = false;
  if (h == kHomingDone) {
    g_homed = true;
    companion_targets_from_position();
    if (g_rehoming) {
      for (uint8_t i = 0; i < kNumAxes; ++i)
        send_ev((uint8_t)(kEvHomingOffsetZ + i), true, homing_offset(i));
    }
    send_ev(kEvHomed, false, 0);
  } else if (h == kHomingFailed) {
    g_halted = true;
    jog_reset();
    send_ev(kEvHomingFailed, true, failed_axis);
  } else if ((ev & kEvEndstop) && h == kHomingIdle) {
    // a switch closed during normal motion: the generator stopped; lost position
    cancel_motion();
    g_halted = true;
    g_homed = false;
    for (uint8_t i = 0; i < kNumAxes; ++i)
      if (hit & (1u << i)) send_ev(kEvEndstopHit, true, i);
  }
  if (ev & (kEvStopped | kEvEndstop)) stepper_release();
  // a trajectory whose queue ran dry before its last point holds there (EV 5 once)
  if (g_traj.active && !stepper_active() && g_traj.next_seq < g_traj.n &&
      g_traj.done == g_traj.next_seq && g_traj.done > 0 && !g_traj.underrun_sent) {
    g_traj.underrun_sent = true;
    send_ev(kEvUnderrun, true, g_traj.next_seq);
  }
}

// An m move ends when its ramps are done (or a stop or an endstop cut it short).
void handle_companion() {
  if (g_comp.moving && !jog_active()) {
    g_comp.moving = false;
    g_comp.busy = false;
  }
  if (g_comp.busy && g_halted) g_comp.busy = g_comp.moving = false;
}

void handle_buttons(uint32_t now) {
  uint8_t pressed = 0, released = 0;
  if (!buttons_poll(now, &pressed, &released)) return;
  const bool allowed = !g_halted && !stepper_holding() && !g_traj.active && !homing_active();
  for (uint8_t b = 0; b < kNumButtons; ++b) {
    const uint8_t bit = (uint8_t)(1u << b);
    const uint8_t axis = b / 2;
    const float dir = (b & 1) ? -1.0f : 1.0f;
    if (pressed & bit) {
      send_ev(kEvJogButton, true, b);
      if (allowed) jog_run(axis, dir * (float)g_settings.jog_speed);
    }
    if ((released & bit) && allowed) jog_run(axis, 0);
  }
}

}  // namespace

void controller_realtime(uint8_t byte) {
  if (byte == core::kRealtimeStop) {
    g_stop_pending = true;
    stepper_request_stop();
    g_rt_stop = true;
  } else if (byte == core::kRealtimeHold) {
    stepper_request_hold();
  } else if (byte == core::kRealtimeResume) {
    g_rt_resume = true;
  }
}

void controller_init() {
  settings_load(g_settings);
  clock_init();
  serial_init((uint32_t)g_settings.baud_hundreds * 100u, controller_realtime);
  stepper_init();
  buttons_init();
  servo_init(g_settings.servo_min_us, g_settings.servo_max_us, (int16_t)g_settings.grip_open_cdeg,
             0);
  g_traj.active = false;
  g_comp.at_line_start = true;
  stepper_set_run(true);
  sei();
  report_set_rate(g_settings.report_hz, clock_micros());
  report_set_single_class(g_settings.companion == 2);
  send_hello(false);
  if (g_settings.companion) {
    // the companion sketch homes in setup(): its scripts expect a homed robot
    homing_start(g_settings);
    g_comp.busy = true;
  }
}

void controller_poll() {
  const uint32_t now = clock_micros();
  handle_realtime();
  read_serial();
  stepper_poll();
  handle_stepper_events();
  handle_companion();
  handle_buttons(now);
  jog_feed(g_settings, homing_active() ? g_settings.homing_speed
                       : g_comp.moving ? g_settings.max_speed
                                       : g_settings.jog_speed);
  if (g_traj.active) servo_set_target(kServoWrist, stepper_wrist_goal());
  servo_update(now, g_settings.servo_speed);
  // while the rate changes nothing new is sent: the line must fall quiet first
  if (!g_baud_pending) report_poll(now, flags(), queue_free());
  handle_baud(now);
}

bool controller_busy() {
  return g_rt_stop || g_rt_resume || g_lost_lines != 0 || serial_available();
}

}  // namespace fw
