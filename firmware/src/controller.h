// The firmware's command layer: decodes the host's packets with the shared codec core
// (scaratwin/protocol/codec_core.h, the same code the host uses), acts on each one and
// answers it with exactly one reply in order (docs/protocol.md section 8), and turns what the
// step generator, homing and the buttons report into unsolicited EV packets. It owns the
// robot's modes: homed, trajectory loading and running, jogging, hold and halted after a stop.
#pragma once

#include <stdint.h>

namespace fw {

void controller_init();
// Called from the serial receive interrupt for '!', '#' and '~'.
void controller_realtime(uint8_t byte);
// One pass of the main loop.
void controller_poll();
// True while a pass has more to do at once (bytes waiting, a reply pending).
bool controller_busy();

}  // namespace fw
