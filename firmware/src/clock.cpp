#include "clock.h"

#include <avr/interrupt.h>
#include <avr/io.h>

namespace fw {
namespace {
volatile uint32_t g_overflows = 0;
}

ISR(TIMER0_OVF_vect) { g_overflows = g_overflows + 1; }

void clock_init() {
  TCCR0A = 0;
  TCCR0B = (1 << CS01) | (1 << CS00);  // F_CPU / 64
  TIMSK0 = (1 << TOIE0);
}

uint32_t clock_micros() {
  uint8_t sreg = SREG;
  cli();
  uint32_t ovf = g_overflows;
  uint8_t t = TCNT0;
  if ((TIFR0 & (1 << TOV0)) && t < 255) ovf++;
  SREG = sreg;
  return ((ovf << 8) + t) * (64u / (F_CPU / 1000000u));
}

}  // namespace fw
