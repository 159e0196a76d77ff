#include "buttons.h"

#include "board.h"

namespace fw {
namespace {

constexpr uint32_t kSampleUs = 5000;
constexpr uint8_t kStableSamples = 4;
uint32_t g_last_us = 0;
uint8_t g_state = 0;
uint8_t g_candidate = 0;
uint8_t g_count = 0;

uint8_t read_raw() {
  uint8_t m = 0;
  if (!PIN_READ(PIN_JOG_Z_POS)) m |= 1;
  if (!PIN_READ(PIN_JOG_Z_NEG)) m |= 2;
  if (!PIN_READ(PIN_JOG_J2_POS)) m |= 4;
  if (!PIN_READ(PIN_JOG_J2_NEG)) m |= 8;
  if (!PIN_READ(PIN_JOG_J3_POS)) m |= 16;
  if (!PIN_READ(PIN_JOG_J3_NEG)) m |= 32;
  return m;
}

}  // namespace

void buttons_init() {
  PIN_INPUT_PULLUP(PIN_JOG_Z_POS);
  PIN_INPUT_PULLUP(PIN_JOG_Z_NEG);
  PIN_INPUT_PULLUP(PIN_JOG_J2_POS);
  PIN_INPUT_PULLUP(PIN_JOG_J2_NEG);
  PIN_INPUT_PULLUP(PIN_JOG_J3_POS);
  PIN_INPUT_PULLUP(PIN_JOG_J3_NEG);
}

bool buttons_poll(uint32_t now_us, uint8_t* pressed, uint8_t* released) {
  if ((uint32_t)(now_us - g_last_us) < kSampleUs) return false;
  g_last_us = now_us;
  uint8_t raw = read_raw();
  if (raw != g_candidate) {
    g_candidate = raw;
    g_count = 0;
    return false;
  }
  if (g_count < kStableSamples) ++g_count;
  if (g_count < kStableSamples || raw == g_state) return false;
  *pressed = (uint8_t)(raw & ~g_state);
  *released = (uint8_t)(g_state & ~raw);
  g_state = raw;
  return true;
}

uint8_t buttons_state() { return g_state; }

}  // namespace fw
