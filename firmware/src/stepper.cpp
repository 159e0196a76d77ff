#include "stepper.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"

namespace fw {
namespace {

MotionQueue g_queue;
Dda g_dda;
volatile bool g_active = false;  // g_dda holds a segment being executed
volatile bool g_run = false;
volatile bool g_stop_req = false;
volatile bool g_blocked = false;  // after a stop, until the main loop released the queue
volatile bool g_hold_req = false;
volatile bool g_held = false;
volatile uint32_t g_scale_q16 = 65536;  // speed scale of the segment clock (1.0 = 65536)
uint16_t g_hold_dec = 65535;
uint8_t g_seg_flags = 0;
uint16_t g_seg_seq = 0;
int16_t g_seg_grip = 0;
volatile int16_t g_wrist_from = 0;
volatile int16_t g_wrist_to = 0;
volatile int32_t g_pos[kNumAxes] = {0, 0, 0};
volatile uint8_t g_events = 0;
volatile uint8_t g_endstop_hit = 0;
volatile uint16_t g_done_seq = 0;
volatile int16_t g_grip_req = 0;
volatile uint8_t g_guard = 0;
volatile uint8_t g_endstops_prev = 0;
volatile uint8_t g_endstops = 0;
uint8_t g_step_mask = 0;          // STEP pins the last tick raised (lowered by the next one)
volatile bool g_ticking = false;  // Timer2 runs; it is stopped while there is nothing to step

inline uint8_t read_endstops() {
  // switches pull the input low when closed
  uint8_t m = 0;
  if (!PIN_READ(PIN_ENDSTOP_Z)) m |= 1;
  if (!PIN_READ(PIN_ENDSTOP_J2)) m |= 2;
  if (!PIN_READ(PIN_ENDSTOP_J3)) m |= 4;
  return m;
}

inline void set_dirs(uint8_t negative) {
  // DIR high = towards positive counts
  if (negative & 1)
    PIN_LOW(PIN_DIR_Z);
  else
    PIN_HIGH(PIN_DIR_Z);
  if (negative & 2)
    PIN_LOW(PIN_DIR_J2);
  else
    PIN_HIGH(PIN_DIR_J2);
  if (negative & 4)
    PIN_LOW(PIN_DIR_J3);
  else
    PIN_HIGH(PIN_DIR_J3);
}

// Loads the next queued segment; false if none may start. A hold that is still decelerating
// runs on into the next segment at the speed scale it has reached (stopping at the segment's
// end would be a hard stop from that speed); once held at rest, nothing starts.
inline bool load_next() {
  if (!g_run || g_blocked || (g_hold_req && g_held)) return false;
  const Segment* s = g_queue.front();
  if (s == nullptr) return false;
  g_dda.start(*s);
  g_hold_dec = s->hold_dec_q16;
  g_seg_flags = s->flags;
  g_seg_seq = s->seq;
  g_seg_grip = s->grip_cdeg;
  if (s->flags & kSegTrajectory) {
    g_wrist_from = g_wrist_to;
    g_wrist_to = s->wrist_cdeg;
  }
  g_queue.pop();
  set_dirs(g_dda.dir_negative);
  g_active = true;
  return true;
}

inline void halt_all() {
  g_active = false;
  g_blocked = true;
  g_queue.clear();
  g_scale_q16 = 65536;
}

// Whether a tick would have anything to do: a STEP pulse to end, a request to act on, a
// segment to run (not one held at rest), queued segments allowed to start, or a switch that
// changed since the last tick read it. With interrupts disabled.
inline bool has_work() {
  if (g_step_mask != 0 || g_stop_req || (g_hold_req && !g_held)) return true;
  if (g_active) return !(g_hold_req && g_scale_q16 == 0);
  if (g_run && !g_hold_req && !g_blocked && !g_queue.empty()) return true;
  return read_endstops() != g_endstops_prev;
}

// Starts Timer2 if it is stopped; the first tick comes one period (50 us) later. Safe from
// any context: inside the step interrupt (g_ticking is true there) it does nothing, and the
// interrupt checks has_work() before it stops the timer.
void wake() {
  uint8_t sreg = SREG;
  cli();
  if (!g_ticking) {
    g_ticking = true;
    TCNT2 = 0;
    TIFR2 = (1 << OCF2A);  // a compare flag left from before the stop
    TCCR2B = (1 << CS21);
    TIMSK2 = (1 << OCIE2A);
  }
  SREG = sreg;
}

}  // namespace

static void tick();

// Interruptible so that the servo pulses and the serial port keep their timing, but never by
// itself: its own interrupt is masked while it runs (a tick that comes due meanwhile runs
// right after, late rather than lost, and never on top of a half-updated segment). When the
// tick leaves nothing to do, the timer stops (the idle AVR then sleeps between the clock's
// interrupts instead of waking 20,000 times a second); wake() starts it again.
ISR(TIMER2_COMPA_vect) {
  TIMSK2 = 0;
  sei();
  tick();
  cli();
  if (has_work()) {
    TIMSK2 = (1 << OCIE2A);
  } else {
    TCCR2B = 0;
    g_ticking = false;
  }
}

static void tick() {
  PIN_LOW(PIN_STEP_Z);
  PIN_LOW(PIN_STEP_J2);
  PIN_LOW(PIN_STEP_J3);
  g_step_mask = 0;
  const uint8_t es = read_endstops();
  const uint8_t closed_now = (uint8_t)(es & ~g_endstops_prev);
  g_endstops_prev = es;
  g_endstops = es;
  if (g_stop_req) {
    g_stop_req = false;
    g_hold_req = false;
    g_held = false;
    halt_all();
    g_events = (uint8_t)(g_events | kEvStopped);
    return;
  }
  if (closed_now & g_guard) {
    halt_all();
    g_endstop_hit = (uint8_t)(g_endstop_hit | (closed_now & g_guard));
    g_events = (uint8_t)(g_events | kEvEndstop);
    return;
  }
  if (!g_active) {
    if (g_hold_req && !g_held) {
      g_held = true;
      g_scale_q16 = 0;
      g_events = (uint8_t)(g_events | kEvHeld);
    }
    load_next();
    return;  // the first step comes one tick after DIR was set
  }
  // feed hold: ramp the segment clock at the acceleration limit
  uint32_t scale = g_scale_q16;
  if (g_hold_req) {
    if (scale > g_hold_dec) {
      scale -= g_hold_dec;
    } else {
      scale = 0;
      if (!g_held) {
        g_held = true;
        g_events = (uint8_t)(g_events | kEvHeld);
      }
    }
  } else if (scale < 65536) {
    scale += g_hold_dec;
    if (scale > 65536) scale = 65536;
  }
  g_scale_q16 = scale;
  uint16_t rate = (uint16_t)(scale >> 8);
  if (rate == 0) return;
  const uint8_t mask = g_dda.tick(rate);
  const uint8_t neg = g_dda.dir_negative;
  g_step_mask = mask;
  if (mask & 1) {
    PIN_HIGH(PIN_STEP_Z);
    g_pos[0] += (neg & 1) ? -1 : 1;
  }
  if (mask & 2) {
    PIN_HIGH(PIN_STEP_J2);
    g_pos[1] += (neg & 2) ? -1 : 1;
  }
  if (mask & 4) {
    PIN_HIGH(PIN_STEP_J3);
    g_pos[2] += (neg & 4) ? -1 : 1;
  }
  if (g_dda.done()) {
    g_active = false;
    uint8_t ev = g_events;
    if (g_seg_flags & kSegTrajectory) {
      g_done_seq = g_seg_seq;
      ev |= kEvPointDone;
      if (g_seg_flags & kSegLast) ev |= kEvLastDone;
      if (g_seg_flags & kSegGrip) {
        g_grip_req = g_seg_grip;
        ev |= kEvGrip;
      }
    }
    g_events = ev;
    load_next();  // continues without a gap; its first step is due next tick
  }
}

void stepper_init() {
  PIN_OUTPUT(PIN_STEP_Z);
  PIN_OUTPUT(PIN_STEP_J2);
  PIN_OUTPUT(PIN_STEP_J3);
  PIN_OUTPUT(PIN_DIR_Z);
  PIN_OUTPUT(PIN_DIR_J2);
  PIN_OUTPUT(PIN_DIR_J3);
  PIN_OUTPUT(PIN_ENABLE);
  PIN_LOW(PIN_ENABLE);  // drivers enabled (active low), holding torque from reset
  PIN_INPUT_PULLUP(PIN_ENDSTOP_Z);
  PIN_INPUT_PULLUP(PIN_ENDSTOP_J2);
  PIN_INPUT_PULLUP(PIN_ENDSTOP_J3);
  // Timer2 CTC, F_CPU / 8 = 2 MHz, 100 counts = 20 kHz; started by wake() (the first tick
  // reads the switches)
  TCCR2A = (1 << WGM21);
  TCCR2B = 0;
  OCR2A = (uint8_t)(F_CPU / 8 / kTickHz - 1);
  TIMSK2 = 0;
  wake();
}

const MotionQueue& stepper_queue() { return g_queue; }

bool stepper_push(const Segment& s) {
  const bool ok = g_queue.push(s);
  wake();
  return ok;
}

void stepper_poll() {
  uint8_t sreg = SREG;
  cli();
  const bool changed = !g_ticking && read_endstops() != g_endstops_prev;
  SREG = sreg;
  if (changed) wake();
}

void stepper_positions(int32_t out[kNumAxes]) {
  uint8_t sreg = SREG;
  cli();
  for (uint8_t i = 0; i < kNumAxes; ++i) out[i] = g_pos[i];
  SREG = sreg;
}

void stepper_set_position(uint8_t axis, int32_t value) {
  uint8_t sreg = SREG;
  cli();
  g_pos[axis] = value;
  SREG = sreg;
}

void stepper_set_run(bool run) {
  g_run = run;
  if (run) wake();
}

void stepper_request_stop() {
  g_stop_req = true;
  wake();
}

void stepper_request_hold() {
  g_hold_req = true;
  wake();
}

void stepper_request_resume() {
  uint8_t sreg = SREG;
  cli();
  g_hold_req = false;
  g_held = false;
  SREG = sreg;
  wake();
}

void stepper_release() {
  uint8_t sreg = SREG;
  cli();
  g_queue.clear();  // whatever was queued between the stop and now
  g_blocked = false;
  SREG = sreg;
}

bool stepper_moving() {
  uint8_t sreg = SREG;
  cli();
  const bool held_at_rest = g_hold_req && g_scale_q16 == 0;
  const bool moving = (g_active && !held_at_rest) || (g_run && !g_hold_req && !g_queue.empty());
  SREG = sreg;
  return moving;
}

bool stepper_discard() {
  uint8_t sreg = SREG;
  cli();
  const bool held_at_rest = g_hold_req && g_scale_q16 == 0;
  const bool busy = g_stop_req || g_blocked || (g_active && !held_at_rest) ||
                    (g_run && !g_hold_req && !g_queue.empty());
  if (!busy) {
    g_active = false;
    g_queue.clear();
    g_hold_req = false;
    g_held = false;
    g_scale_q16 = 65536;
  }
  SREG = sreg;
  return !busy;
}

bool stepper_active() { return g_active || (g_run && !g_queue.empty()); }
bool stepper_held() { return g_held; }
bool stepper_holding() { return g_hold_req; }

uint8_t stepper_take_events(uint8_t* endstops, uint16_t* done_seq, int16_t* grip_cdeg) {
  uint8_t sreg = SREG;
  cli();
  uint8_t ev = g_events;
  g_events = 0;
  *endstops = g_endstop_hit;
  g_endstop_hit = 0;
  *done_seq = g_done_seq;
  *grip_cdeg = g_grip_req;
  SREG = sreg;
  return ev;
}

uint8_t stepper_endstops() { return g_endstops; }

void stepper_guard_endstops(uint8_t mask) { g_guard = mask; }

int16_t stepper_wrist_goal() {
  uint8_t sreg = SREG;
  cli();
  bool active = g_active && (g_seg_flags & kSegTrajectory);
  uint32_t t = g_dda.time;
  uint32_t len = g_dda.length;
  int16_t from = g_wrist_from;
  int16_t to = g_wrist_to;
  SREG = sreg;
  if (!active || len == 0) return to;
  float f = (float)t / (float)len;
  return (int16_t)((float)from + (float)(to - from) * f);
}

void stepper_set_wrist_base(int16_t cdeg) {
  uint8_t sreg = SREG;
  cli();
  g_wrist_from = cdeg;
  g_wrist_to = cdeg;
  SREG = sreg;
}

}  // namespace fw
