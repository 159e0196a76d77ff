// Serial link: USART0 at 115200 baud 8N1 with interrupt-driven ring buffers for both
// directions. The receive interrupt picks the real-time command bytes ('!' stop, '#' hold,
// '~' resume) out of the stream and hands them to a callback at once, from the interrupt, so
// they take effect even in the middle of a line; every other byte goes to the receive ring
// (128 bytes, twice the host's 64-byte window). A host that ignores the window overruns the
// ring: the line that finds it full is dropped whole (the rest of it up to its '\n' too), and
// so is every line after it until the reader has caught up with the place of the loss; the
// reader learns how many lines were lost there, so that their replies can take their place. Writes
// never block: the caller asks for room first, so a slow host cannot stall the control loop.
#pragma once

#include <stdint.h>

namespace fw {

using RealtimeHandler = void (*)(uint8_t byte);

void serial_init(uint32_t baud, RealtimeHandler on_realtime);
// Changes the rate (the caller waits until nothing is being sent: see serial_tx_empty()).
void serial_set_baud(uint32_t baud);
// True when the transmit ring is empty (the UART may still shift out its last two bytes).
bool serial_tx_empty();
constexpr int16_t kSerialLost = -2;
// Next received byte; -1 when none is waiting; kSerialLost when *lost_lines whole lines were
// lost to a full ring at this place in the stream (the bytes of the first one read so far
// belong to it).
int16_t serial_read(uint8_t* lost_lines);
// The next received byte without taking it, -1 or kSerialLost as serial_read() would answer.
int16_t serial_peek();
// True if a received byte (or a loss) is waiting.
bool serial_available();
// Free bytes in the transmit ring.
uint8_t serial_tx_free();
// Queues n bytes if all fit; returns false (and queues nothing) otherwise.
bool serial_write(const char* data, uint8_t n);

}  // namespace fw
