// Compile-time constants of the firmware: version, timing of the step generator, sizes of the
// buffers (smaller on the Uno's 2 KiB of RAM) and the default settings. The defaults are the
// paper's robot as described in config/scara.toml (steps per metre / radian, motor limits,
// servo pulses); tests/firmware checks that they agree with that file. Everything that the
// user may change at run time is a setting (settings.h), stored in EEPROM.
#pragma once

#include <stdint.h>

#define FW_VERSION "0.1.0"
#define FW_PROTO_VERSION 1

namespace fw {

constexpr uint8_t kNumAxes = 3;  // steppers: 0 Z, 1 J2, 2 J3

// step generator: a fixed-rate tick; at most one step per axis per tick
constexpr uint32_t kTickHz = 20000;
constexpr uint16_t kTicksPerMs = kTickHz / 1000;

// trajectory points queued (credit for the host's flow control)
#if defined(__AVR_ATmega2560__)
constexpr uint8_t kQueueSize = 64;
#else
constexpr uint8_t kQueueSize = 16;
#endif

constexpr uint16_t kJogSegmentMs = 10;  // duration of generated jog / homing segments
constexpr uint16_t kMaxPointMs = 5000;  // longest dt_ms of one trajectory point
constexpr uint8_t kLineMax = 96;        // longest serial packet including "\r\n"

// defaults of config/scara.toml, converted to the firmware's units
constexpr uint16_t kDefaultMaxSpeed = 5000;  // steps/s, all steppers
constexpr uint16_t kDefaultMaxAccel = 1500;  // steps/s^2
constexpr uint16_t kDefaultReportHz = 100;
constexpr uint16_t kDefaultGripOpenCdeg = 0;
constexpr uint16_t kDefaultGripClosedCdeg = 7500;
constexpr uint16_t kDefaultHomingSpeed = 1500;  // steps/s while seeking an endstop
constexpr uint16_t kDefaultJogSpeed = 1000;     // steps/s for buttons and JG
constexpr uint16_t kDefaultServoSpeed = 30000;  // cdeg/s (300 deg/s)
constexpr uint16_t kDefaultServoMinUs = 544;
constexpr uint16_t kDefaultServoMaxUs = 2400;
constexpr uint16_t kDefaultCouplingPermille = 800;  // J3 motor steps per 1000 J2 steps
constexpr uint16_t kDefaultPulloff = 40;            // steps backed off an endstop

// Endstops: the motor count each axis takes when its switch closes while homing. Z's switch
// is at the top (d1 = 0.1225 m), J2's beyond +115 deg (q2 = 117 deg), J3's beyond -75 deg
// (q3 = -77 deg; a J3 joint count, the firmware adds the coupling of the J2 motor).
constexpr int32_t kDefaultEndstop[kNumAxes] = {25181, 1930, -1955};
constexpr int8_t kDefaultHomingDir[kNumAxes] = {+1, +1, -1};
// Home pose (d1 = 0.12 m, q2 = q3 = 0): motor counts the robot moves to after homing.
constexpr int32_t kDefaultHome[kNumAxes] = {24667, 0, 0};

}  // namespace fw
