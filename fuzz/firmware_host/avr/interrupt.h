// The firmware built for the host: an interrupt handler is a plain function the harness calls
// (fw_isr_<vector>), interrupts are never taken on their own, so cli() and sei() do nothing.
#pragma once

#include "avr/io.h"

#define FW_HOST_ISR_(vector) extern "C" void fw_isr_##vector(void)
#define ISR(vector) FW_HOST_ISR_(vector)

inline void cli() {}
inline void sei() {}
