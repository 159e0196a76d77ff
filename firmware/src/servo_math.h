// Servo angle <-> pulse conversion (pure: no hardware, built for the host's unit tests too).
// Hobby servos take a pulse every 20 ms whose width maps linearly to the angle: servo_min_us
// at 0 deg and servo_max_us at 180 deg. The generator counts in half microseconds (Timer1 at
// F_CPU/8); the state reports convert the width actually being output back to centidegrees.
#pragma once

#include <stdint.h>

namespace fw {

constexpr int32_t kServoFullCdeg = 18000;

// Pulse width in 0.5 us units for an angle in cdeg (clamped to 0..180 deg).
inline uint16_t servo_cdeg_to_halfus(int32_t cdeg, uint16_t min_us, uint16_t max_us) {
  if (cdeg < 0) cdeg = 0;
  if (cdeg > kServoFullCdeg) cdeg = kServoFullCdeg;
  int32_t span = 2 * ((int32_t)max_us - (int32_t)min_us);
  return (uint16_t)(2 * (int32_t)min_us + (span * cdeg + kServoFullCdeg / 2) / kServoFullCdeg);
}

// Angle in cdeg of a pulse width in 0.5 us units (nearest).
inline int16_t servo_halfus_to_cdeg(uint16_t halfus, uint16_t min_us, uint16_t max_us) {
  int32_t span = 2 * ((int32_t)max_us - (int32_t)min_us);
  if (span <= 0) return 0;
  int32_t off = (int32_t)halfus - 2 * (int32_t)min_us;
  int32_t cdeg = (off * kServoFullCdeg + (off >= 0 ? span / 2 : -span / 2)) / span;
  return (int16_t)cdeg;
}

}  // namespace fw
