// Compile-time constants of the firmware: version, timing of the step generator, sizes of the
// buffers (smaller on the Uno's 2 KiB of RAM) and the default settings. The defaults that
// describe the robot (speed and acceleration limits, servo pulses, gripper angles, belt
// coupling, endstop and home counts, homing directions, pull-off) come from fw_description.h,
// which the build generates from the robot description (config/scara.toml, or the file
// SCARATWIN_ROBOT_DESCRIPTION names; firmware/tools/fw_description.cpp); the static_asserts
// below hold them to the ranges of the settings. tests/firmware checks the generated values
// against the description. Everything that the user may change at run time is a setting
// (settings.h), stored in EEPROM.
#pragma once

#include <stdint.h>

#include "fw_description.h"  // generated in <build>/firmware/generated

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

// defaults of the robot description, converted to the firmware's units (fw_description.h)
static_assert(desc::kMaxSpeedStepsS >= 1 && desc::kMaxSpeedStepsS <= (int32_t)(kTickHz / 2),
              "robot description: max_speed_steps_s must be 1..10000 (one step per two ticks)");
static_assert(desc::kMaxAccelStepsS2 >= 1 && desc::kMaxAccelStepsS2 <= 60000,
              "robot description: max_accel_steps_s2 must be 1..60000");
static_assert(desc::kGripOpenCdeg >= 0 && desc::kGripOpenCdeg <= 18000 &&
                  desc::kGripClosedCdeg >= 0 && desc::kGripClosedCdeg <= 18000,
              "robot description: gripper open_deg and closed_deg must be 0..180");
static_assert(desc::kServoSpeedCdegS >= 100 && desc::kServoSpeedCdegS <= 60000,
              "robot description: servo max_speed_deg_s must be 1..600");
static_assert(desc::kCouplingPermille >= 0 && desc::kCouplingPermille <= 5000,
              "robot description: coupling_steps_per_j2_step must be 0..5");
static_assert(desc::kServoMinUs >= 200 && desc::kServoMinUs < desc::kServoMaxUs &&
                  desc::kServoMaxUs <= 3000,
              "robot description: servo pulses must be 200 <= pulse_min_us < pulse_max_us <= 3000");
static_assert(desc::kPulloffSteps >= 1 && desc::kPulloffSteps <= 1000,
              "robot description: endstops.pulloff_steps must be 1..1000");
constexpr uint16_t kDefaultMaxSpeed = (uint16_t)desc::kMaxSpeedStepsS;   // steps/s, all steppers
constexpr uint16_t kDefaultMaxAccel = (uint16_t)desc::kMaxAccelStepsS2;  // steps/s^2
constexpr uint16_t kDefaultGripOpenCdeg = (uint16_t)desc::kGripOpenCdeg;
constexpr uint16_t kDefaultGripClosedCdeg = (uint16_t)desc::kGripClosedCdeg;
constexpr uint16_t kDefaultServoSpeed = (uint16_t)desc::kServoSpeedCdegS;  // cdeg/s
constexpr uint16_t kDefaultServoMinUs = (uint16_t)desc::kServoMinUs;
constexpr uint16_t kDefaultServoMaxUs = (uint16_t)desc::kServoMaxUs;
constexpr uint16_t kDefaultCouplingPermille = (uint16_t)desc::kCouplingPermille;  // per 1000 J2
constexpr uint16_t kDefaultPulloff = (uint16_t)desc::kPulloffSteps;  // steps backed off a switch

// Endstops: the count each axis takes when its switch closes while homing (J3's is a joint
// count: the firmware adds the coupling of the J2 motor), and the direction homing seeks it.
constexpr int32_t kDefaultEndstop[kNumAxes] = {desc::kEndstopZ, desc::kEndstopJ2, desc::kEndstopJ3};
constexpr int8_t kDefaultHomingDir[kNumAxes] = {desc::kHomingDirZ, desc::kHomingDirJ2,
                                                desc::kHomingDirJ3};
// Joint limits as counts (Z and J2 motor counts, J3 a joint count), for the companion dialect.
constexpr int32_t kLimitMin[kNumAxes] = {desc::kLimitMinZ, desc::kLimitMinJ2, desc::kLimitMinJ3};
constexpr int32_t kLimitMax[kNumAxes] = {desc::kLimitMaxZ, desc::kLimitMaxJ2, desc::kLimitMaxJ3};
static_assert(desc::kLimitMinZ < desc::kLimitMaxZ && desc::kLimitMinJ2 < desc::kLimitMaxJ2 &&
                  desc::kLimitMinJ3 < desc::kLimitMaxJ3,
              "robot description: every joint needs a range of at least one step");
// Home pose: motor counts the robot moves to after homing.
constexpr int32_t kDefaultHome[kNumAxes] = {desc::kHomeZ, desc::kHomeJ2, desc::kHomeJ3};

// firmware settings that the robot description does not hold
constexpr uint16_t kDefaultReportHz = 100;
constexpr uint16_t kDefaultBaudHundreds = 1152;  // 115200 baud
constexpr uint16_t kDefaultHomingSpeed = 1500;   // steps/s while seeking an endstop
constexpr uint16_t kDefaultJogSpeed = 1000;      // steps/s for buttons and JG

}  // namespace fw
