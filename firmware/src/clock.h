// Device clock: Timer0 runs free at F_CPU/64 (4 us per count) and counts its overflows, which
// gives micros() for the state reports' timestamps (wrapping modulo 2^32 us, 71.6 minutes) and
// a 1 ms heartbeat flag for the main loop. Timer0 is used by nothing else.
#pragma once

#include <stdint.h>

namespace fw {

void clock_init();
// Microseconds since reset, modulo 2^32; 4 us resolution. Safe from the main loop and ISRs.
uint32_t clock_micros();

}  // namespace fw
