// Homing against the endstops (HM). One axis after the other, Z first (lifts the tool clear),
// then J2, then J3: run towards the switch at the homing speed with the switch guarded, so
// the step generator stops on the tick after the step that closed it; set that axis's counter
// to the switch position of the settings (for J3 a joint count, plus the J2 motor's coupling
// share); back off the pull-off distance; next axis. Finally all axes move to the home pose.
// A switch that is already closed is first run away from until it opens. A search (either
// way) that runs further than kMaxSearch steps fails (broken switch or cable) and stops.
#pragma once

#include <stdint.h>

namespace fw {

struct Settings;

enum HomingResult : uint8_t { kHomingRunning, kHomingDone, kHomingFailed, kHomingIdle };

void homing_start(const Settings& s);
void homing_abort();
bool homing_active();
// Once per main-loop pass with the stepper events of that pass. Returns kHomingDone or
// kHomingFailed once (*failed_axis set), kHomingRunning while busy, kHomingIdle otherwise.
HomingResult homing_update(const Settings& s, uint8_t events, uint8_t endstops_hit,
                           uint8_t* failed_axis);
// After kHomingDone: the axis's count when its switch closed minus the switch position
// (steps). The switch marks the true position, so if the robot was homed before this is the
// count minus where the motor really was: the steps it lost since (0 if none), with the sign
// of the counts it made that the motor did not.
int32_t homing_offset(uint8_t axis);
// The counts the axes were set to when their switches closed in the latest homing (J3 with the J2
// motor's coupling share): the zero of the companion dialect's step frame.
const int32_t* homing_switch_counts();

}  // namespace fw
