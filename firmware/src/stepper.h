// Step generator: Timer2 interrupts at kTickHz (20 kHz) and runs the DDA of segment.h on the
// segment at the head of the motion queue, so the three steppers move in lock-step, start and
// end each segment together and emit exactly the planned step counts. STEP pulses are one
// tick (50 us) wide; DIR is set one tick before a segment's first step. The step counters
// here are the positions the state reports carry: they change only when a STEP pulse is
// actually output.
//
// Stop ('!', SP) and hold ('#') are requests the interrupt acts on at its next tick: a stop
// ends the pulses at once and drops the queue (a hard stop: within one tick, 50 us); a hold
// ramps the segment clock down at the motor acceleration limit and keeps the queue; resume
// ('~') ramps it back up. An endstop that closes while it is guarded also stops everything.
//
// The timer runs only while there is something to do: after the tick that leaves no pulse to
// end, no segment to run or start and no request pending, it stops (at rest the AVR then
// sleeps between the clock's interrupts). Every call below that can give it work (a push, run,
// stop, hold, resume) starts it again, its first tick one period later; while it is stopped,
// stepper_poll() from the main loop watches the switches and starts it when one changes, so
// the tick sees the change (and a guarded switch still stops everything).
#pragma once

#include <stdint.h>

#include "motion.h"

namespace fw {

// Event bits collected by the interrupt, taken by the main loop.
enum StepperEvent : uint8_t {
  kEvStopped = 1,    // a stop request took effect
  kEvEndstop = 2,    // a guarded endstop closed (motion stopped)
  kEvPointDone = 4,  // a trajectory point was reached
  kEvLastDone = 8,   // the last point of a trajectory was reached
  kEvHeld = 16,      // a hold reached rest
  kEvGrip = 32,      // a point asked for a gripper angle
};

void stepper_init();
// The queue, to read (count, free slots); segments go in through stepper_push.
const MotionQueue& stepper_queue();
// Queues a segment (false if the queue is full) and starts the timer if it was stopped.
bool stepper_push(const Segment& s);
// Main loop: starts the timer when a switch changed while it was stopped.
void stepper_poll();

// Step counters (steps from the joint zero, as homed).
void stepper_positions(int32_t out[kNumAxes]);
// Sets a counter (homing); only while that axis is at rest.
void stepper_set_position(uint8_t axis, int32_t value);

// Lets the interrupt start queued segments (false keeps them queued: trajectory pre-fill).
void stepper_set_run(bool run);
void stepper_request_stop();  // safe from any interrupt
void stepper_request_hold();
void stepper_request_resume();

// After kEvStopped or kEvEndstop the generator starts nothing until the main loop has reset
// whatever feeds the queue and calls this; it also drops what was queued meanwhile.
void stepper_release();

// At rest, drops whatever a trajectory, jog or hold left behind: the queued segments, a
// segment held at rest, the hold itself. Returns false (and changes nothing) while a motor
// steps or is about to (stepper_moving()), or while a stop is still being carried out.
bool stepper_discard();
// A motor steps now, or queued segments will start by themselves (not held, not pre-filling).
bool stepper_moving();
bool stepper_active();   // executing a segment, or segments queued and allowed to run
bool stepper_held();     // a hold reached rest
bool stepper_holding();  // a hold was requested and not resumed
// Takes (and clears) the event bits; *endstops gets the switches that stopped the motion,
// *done_seq the last point reached, *grip_cdeg the last gripper request.
uint8_t stepper_take_events(uint8_t* endstops, uint16_t* done_seq, int16_t* grip_cdeg);

// Endstop switch states (bit i: axis i's switch closed).
uint8_t stepper_endstops();
// Switches whose closing stops all motion.
void stepper_guard_endstops(uint8_t mask);

// Wrist servo angle the current trajectory segment asks for now (interpolated linearly
// between its start and end); `base` is the angle before the first segment.
int16_t stepper_wrist_goal();
void stepper_set_wrist_base(int16_t cdeg);

}  // namespace fw
