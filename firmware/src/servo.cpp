#include "servo.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "fw_config.h"
#include "servo_math.h"

namespace fw {
namespace {

constexpr uint16_t kFrameHalfUs = 40000;  // 20 ms
constexpr uint32_t kFrameUs = 20000;

volatile uint16_t g_pulse[2] = {3000, 3000};  // 0.5 us units, read by the ISR once per frame
int16_t g_out_cdeg[2] = {0, 0};               // angle being output (before conversion)
int16_t g_target[2] = {0, 0};
uint16_t g_min_us = kDefaultServoMinUs;  // until servo_init() sets the stored settings
uint16_t g_max_us = kDefaultServoMaxUs;
uint32_t g_last_update_us = 0;
uint8_t g_phase = 0;
uint16_t g_frame_start = 0;
uint16_t g_frame_pulse[2] = {3000, 3000};

}  // namespace

ISR(TIMER1_COMPA_vect) {
  switch (g_phase) {
    case 0:  // frame start: gripper pulse (the edge first, the bookkeeping after)
      PIN_HIGH(PIN_SERVO_GRIP);
      g_frame_start = OCR1A;
      g_frame_pulse[0] = g_pulse[0];
      g_frame_pulse[1] = g_pulse[1];
      OCR1A = (uint16_t)(g_frame_start + g_frame_pulse[0]);
      g_phase = 1;
      break;
    case 1:  // wrist pulse
      PIN_LOW(PIN_SERVO_GRIP);
      PIN_HIGH(PIN_SERVO_WRIST);
      OCR1A = (uint16_t)(OCR1A + g_frame_pulse[1]);
      g_phase = 2;
      break;
    default:  // rest of the frame
      PIN_LOW(PIN_SERVO_WRIST);
      OCR1A = (uint16_t)(g_frame_start + kFrameHalfUs);
      g_phase = 0;
      break;
  }
}

static void apply(uint8_t s) {
  uint16_t p = servo_cdeg_to_halfus(g_out_cdeg[s], g_min_us, g_max_us);
  uint8_t sreg = SREG;
  cli();
  g_pulse[s] = p;
  SREG = sreg;
}

void servo_init(uint16_t min_us, uint16_t max_us, int16_t grip_cdeg, int16_t wrist_cdeg) {
  g_min_us = min_us;
  g_max_us = max_us;
  g_out_cdeg[kServoGrip] = g_target[kServoGrip] = grip_cdeg;
  g_out_cdeg[kServoWrist] = g_target[kServoWrist] = wrist_cdeg;
  apply(kServoGrip);
  apply(kServoWrist);
  PIN_OUTPUT(PIN_SERVO_GRIP);
  PIN_OUTPUT(PIN_SERVO_WRIST);
  PIN_LOW(PIN_SERVO_GRIP);
  PIN_LOW(PIN_SERVO_WRIST);
  TCCR1A = 0;
  TCCR1B = (1 << CS11);  // F_CPU / 8, normal mode
  OCR1A = (uint16_t)(TCNT1 + 200);
  g_phase = 0;
  TIMSK1 = (1 << OCIE1A);
}

void servo_set_range(uint16_t min_us, uint16_t max_us) {
  g_min_us = min_us;
  g_max_us = max_us;
  apply(kServoGrip);
  apply(kServoWrist);
}

void servo_set_target(uint8_t servo, int16_t cdeg) {
  if (cdeg < 0) cdeg = 0;
  if (cdeg > kServoFullCdeg) cdeg = kServoFullCdeg;
  g_target[servo] = cdeg;
}

int16_t servo_target(uint8_t servo) { return g_target[servo]; }

void servo_update(uint32_t now_us, uint16_t speed_cdeg_s) {
  if ((uint32_t)(now_us - g_last_update_us) < kFrameUs) return;
  g_last_update_us = now_us;
  const int16_t max_step = (int16_t)((uint32_t)speed_cdeg_s * kFrameUs / 1000000u);
  for (uint8_t s = 0; s < 2; ++s) {
    int16_t diff = (int16_t)(g_target[s] - g_out_cdeg[s]);
    if (diff == 0) continue;
    if (diff > max_step) diff = max_step;
    if (diff < -max_step) diff = (int16_t)-max_step;
    g_out_cdeg[s] = (int16_t)(g_out_cdeg[s] + diff);
    apply(s);
  }
}

int16_t servo_output_cdeg(uint8_t servo) {
  uint8_t sreg = SREG;
  cli();
  uint16_t p = g_frame_pulse[servo];
  SREG = sreg;
  return servo_halfus_to_cdeg(p, g_min_us, g_max_us);
}

}  // namespace fw
