// Physical jog buttons, the paper's manual control: six push buttons to ground with the
// internal pull-ups, Z+ / Z- on A2 / A3, J2+ / J2- on A4 / A5, J3+ / J3- on D12 / D13 (Mega:
// the same Arduino pin numbers). Sampled every 5 ms and debounced over four samples (20 ms).
// Button b is axis b / 2, positive for even b.
#pragma once

#include <stdint.h>

namespace fw {

constexpr uint8_t kNumButtons = 6;

void buttons_init();
// Samples the buttons when 5 ms have passed; returns true when the debounced state changed
// and sets *pressed / *released to the buttons that went down / up.
bool buttons_poll(uint32_t now_us, uint8_t* pressed, uint8_t* released);
uint8_t buttons_state();  // debounced, bit b = button b held

}  // namespace fw
