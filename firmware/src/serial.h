// Serial link: USART0 at 115200 baud 8N1 with interrupt-driven ring buffers for both
// directions. The receive interrupt picks the real-time command bytes ('!' stop, '#' hold,
// '~' resume) out of the stream and hands them to a callback at once, from the interrupt, so
// they take effect even in the middle of a line; every other byte goes to the receive ring
// (128 bytes, twice the host's 64-byte window). Writes never block: the caller asks for room
// first, so a slow host cannot stall the control loop.
#pragma once

#include <stdint.h>

namespace fw {

using RealtimeHandler = void (*)(uint8_t byte);

void serial_init(uint32_t baud, RealtimeHandler on_realtime);
// Next received byte, or -1 when none is waiting.
int16_t serial_read();
// True if a received byte is waiting.
bool serial_available();
// True (once) if received bytes were dropped because the ring was full.
bool serial_take_overrun();
// Free bytes in the transmit ring.
uint8_t serial_tx_free();
// Queues n bytes if all fit; returns false (and queues nothing) otherwise.
bool serial_write(const char* data, uint8_t n);

}  // namespace fw
