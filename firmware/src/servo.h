// Servo pulses for the gripper (A0) and the wrist (A1), generated here rather than with a
// library: Timer1 runs free at F_CPU/8 (0.5 us per count) and its compare interrupt raises
// one servo's pin, lowers it after that servo's pulse width, raises the next one, and waits
// for the end of the 20 ms frame. The main loop moves each servo's output towards its target
// at the configured servo speed once per frame; the state reports carry the pulse width that
// is actually being output, converted back to centidegrees.
#pragma once

#include <stdint.h>

namespace fw {

enum ServoId : uint8_t { kServoGrip = 0, kServoWrist = 1 };

void servo_init(uint16_t min_us, uint16_t max_us, int16_t grip_cdeg, int16_t wrist_cdeg);
void servo_set_range(uint16_t min_us, uint16_t max_us);
void servo_set_target(uint8_t servo, int16_t cdeg);
int16_t servo_target(uint8_t servo);
// Once per main-loop pass: moves the outputs towards the targets at `speed_cdeg_s`.
void servo_update(uint32_t now_us, uint16_t speed_cdeg_s);
// Angle of the pulse width being output now.
int16_t servo_output_cdeg(uint8_t servo);

}  // namespace fw
