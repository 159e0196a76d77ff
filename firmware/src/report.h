// State reports (ST): sampled from the actual step counters and the servo pulses being output,
// never from commanded values, each with a sequence number (wrapping at 65536, shared with the
// reports sent for QS) and the device timestamp in microseconds taken at the sample. Periodic
// reports are due every 1e6 / rate_hz us on a fixed grid (no drift), which restarts at each
// report sent for QS (that report stands in for the next periodic one); a report that cannot be
// sent (transmit buffer full because the rate is beyond what the baud rate carries) or a
// deadline the loop missed still uses up its sequence number, so the host sees the loss as a
// gap instead of a silently lower rate.
#pragma once

#include <stdint.h>

namespace fw {

// Transmit space periodic reports leave free, so that replies to commands always find room
// and commands keep being served at any report rate (the controller reads a line only when
// this much space is free). The longest reply is 22 bytes (HI); a larger reserve made the
// reports wait for an almost empty buffer and drop while a trajectory streamed (one AK per
// point in the buffer was enough to push a 55-byte report out of 128 - 64 bytes).
constexpr uint8_t kReplyReserve = 32;
// room a companion error line needs (companion.h)
constexpr uint8_t kCompanionReserve = 64;

void report_set_rate(uint16_t rate_hz, uint32_t now_us);
// The periodic reports' form: false one ST packet per sample (the default), true the
// single-class lines of companion_report_lines (setting 10 = 2). A QS is answered with ST in
// either form. A sample whose lines do not fit the transmit buffer is not sent at all.
void report_set_single_class(bool on);
uint16_t report_rate();
// Sends the periodic report if due. `flags` and `queue_free` as in docs/protocol.md.
void report_poll(uint32_t now_us, uint8_t flags, uint8_t queue_free);
// Sends one report now (QS); false if the transmit buffer had no room (the number is used).
bool report_now(uint8_t flags, uint8_t queue_free);

}  // namespace fw
