// Jog motion: the generator behind the JG command, the jog buttons and homing. Each stepper
// has an AxisRamp (ramp.h); while any of them moves, the main loop samples them every
// kJogSegmentMs into segments and keeps a few queued ahead of the step generator, so a jog
// starts and stops at the acceleration limit and a released button stops within its ramp.
#pragma once

#include <stdint.h>

#include "ramp.h"

namespace fw {

struct Settings;

// Starts a relative move of `steps` on `axis` (position mode).
void jog_move(uint8_t axis, int32_t steps);
// Runs `axis` at `speed` steps/s (velocity mode); 0 decelerates to rest.
void jog_run(uint8_t axis, float speed);
// Forgets every ramp (after a stop or an endstop hit: the step generator already stopped).
void jog_reset();
// True while a ramp is moving or generated segments are still queued.
bool jog_active();
// True while a ramp is moving (segments still to generate).
bool jog_ramping();
// Once per main-loop pass: queues the next segments. `speed` is the ramps' top speed.
void jog_feed(const Settings& s, uint16_t speed);

}  // namespace fw
