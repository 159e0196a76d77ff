// Settings (pure part: no hardware, built for the host's unit tests too). Everything a user
// may tune at run time without reflashing, changed with CF and kept in EEPROM as one block
// with a layout version and a Fletcher-16 checksum: a blank, corrupted or older EEPROM falls
// back to the defaults of fw_config.h. The CF keys are numbered; keys 1-6 are those of
// docs/protocol.md, 7-11 are firmware extras.
#pragma once

#include <stdint.h>

#include "fw_config.h"

namespace fw {

constexpr uint8_t kSettingsVersion = 2;  // 2: keys 10 and 11

struct Settings {
  uint8_t version;
  uint16_t max_speed;          // steps/s, every stepper          (CF key 1)
  uint16_t max_accel;          // steps/s^2, every stepper        (CF key 2)
  uint16_t report_hz;          // default ST rate at reset, 0 off (CF key 3)
  uint16_t grip_open_cdeg;     //                             (CF key 4)
  uint16_t grip_closed_cdeg;   //                             (CF key 5)
  uint16_t homing_speed;       // steps/s while seeking a switch  (CF key 6)
  uint16_t jog_speed;          // steps/s for JG and the buttons  (CF key 7)
  uint16_t servo_speed;        // cdeg/s, wrist and gripper       (CF key 8)
  uint16_t coupling_permille;  // J3 motor steps per 1000 J2 steps (CF key 9)
  uint16_t companion;          // 1: read the companion dialect, 2: + single-class (CF key 10)
  uint16_t baud_hundreds;      // serial baud / 100 (CF key 11): settings_baud_listed
  uint16_t servo_min_us;       // pulse at 0 deg
  uint16_t servo_max_us;       // pulse at 180 deg
  uint16_t pulloff;            // steps backed off a switch after it closed
  int32_t endstop[kNumAxes];   // count taken when the switch closes (J3: joint count)
  int8_t homing_dir[kNumAxes];
  int32_t home[kNumAxes];  // counts moved to after homing
  uint16_t checksum;       // Fletcher-16 of every byte before it
};

// The serial rates of CF key 11, in hundreds of baud: those the Uno's 16 MHz clock makes within
// 1 % with U2X (9615, 57143, 117647 as the Arduino core has 115200, then exactly 250000, 500000
// and 1000000).
bool settings_baud_listed(int32_t hundreds);

enum SettingError : uint8_t { kSettingOk = 0, kSettingUnknownKey, kSettingBadValue };

void settings_defaults(Settings& s);
uint16_t settings_checksum(const Settings& s);
// True if the block has the current version and a matching checksum.
bool settings_valid(const Settings& s);
void settings_seal(Settings& s);  // recomputes the checksum

// CF access. get: kSettingUnknownKey for a key not in the table. set: also
// kSettingBadValue for a value outside the key's range (ranges in settings.cpp).
SettingError settings_get(const Settings& s, int32_t key, int32_t* value);
SettingError settings_set(Settings& s, int32_t key, int32_t value);

}  // namespace fw
