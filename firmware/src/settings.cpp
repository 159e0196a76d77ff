#include "settings.h"

namespace fw {

void settings_defaults(Settings& s) {
  uint8_t* p = (uint8_t*)&s;
  for (uint16_t i = 0; i < sizeof(Settings); ++i) p[i] = 0;
  s.version = kSettingsVersion;
  s.max_speed = kDefaultMaxSpeed;
  s.max_accel = kDefaultMaxAccel;
  s.report_hz = kDefaultReportHz;
  s.grip_open_cdeg = kDefaultGripOpenCdeg;
  s.grip_closed_cdeg = kDefaultGripClosedCdeg;
  s.homing_speed = kDefaultHomingSpeed;
  s.jog_speed = kDefaultJogSpeed;
  s.servo_speed = kDefaultServoSpeed;
  s.coupling_permille = kDefaultCouplingPermille;
  s.baud_hundreds = kDefaultBaudHundreds;
  s.servo_min_us = kDefaultServoMinUs;
  s.servo_max_us = kDefaultServoMaxUs;
  s.pulloff = kDefaultPulloff;
  for (uint8_t i = 0; i < kNumAxes; ++i) {
    s.endstop[i] = kDefaultEndstop[i];
    s.homing_dir[i] = kDefaultHomingDir[i];
    s.home[i] = kDefaultHome[i];
  }
  settings_seal(s);
}

uint16_t settings_checksum(const Settings& s) {
  const uint8_t* p = (const uint8_t*)&s;
  uint16_t a = 0, b = 0;
  for (uint16_t i = 0; i < (uint16_t) __builtin_offsetof(Settings, checksum); ++i) {
    a = (uint16_t)((a + p[i]) % 255);
    b = (uint16_t)((b + a) % 255);
  }
  return (uint16_t)((b << 8) | a);
}

bool settings_valid(const Settings& s) {
  return s.version == kSettingsVersion && s.checksum == settings_checksum(s);
}

void settings_seal(Settings& s) { s.checksum = settings_checksum(s); }

namespace {

struct KeyInfo {
  uint16_t Settings::*field;
  int32_t min;
  int32_t max;
};

// CF keys 1..11; the speed limit keeps at most one step per axis per two ticks
const KeyInfo kKeys[] = {
    {&Settings::max_speed, 1, (int32_t)(kTickHz / 2)},
    {&Settings::max_accel, 1, 60000},
    {&Settings::report_hz, 0, 1000},
    {&Settings::grip_open_cdeg, 0, 18000},
    {&Settings::grip_closed_cdeg, 0, 18000},
    {&Settings::homing_speed, 1, 5000},
    {&Settings::jog_speed, 1, 5000},
    {&Settings::servo_speed, 100, 60000},
    {&Settings::coupling_permille, 0, 5000},
    {&Settings::companion, 0, 2},
    {&Settings::baud_hundreds, 96, 10000},  // settings_baud_listed
};
constexpr int32_t kNumKeys = (int32_t)(sizeof(kKeys) / sizeof(kKeys[0]));

}  // namespace

bool settings_baud_listed(int32_t h) {
  return h == 96 || h == 576 || h == 1152 || h == 2500 || h == 5000 || h == 10000;
}

SettingError settings_get(const Settings& s, int32_t key, int32_t* value) {
  if (key < 1 || key > kNumKeys) return kSettingUnknownKey;
  *value = s.*(kKeys[key - 1].field);
  return kSettingOk;
}

SettingError settings_set(Settings& s, int32_t key, int32_t value) {
  if (key < 1 || key > kNumKeys) return kSettingUnknownKey;
  const KeyInfo& k = kKeys[key - 1];
  if (value < k.min || value > k.max) return kSettingBadValue;
  if (k.field == &Settings::baud_hundreds && !settings_baud_listed(value)) return kSettingBadValue;
  s.*(k.field) = (uint16_t)value;
  settings_seal(s);
  return kSettingOk;
}

}  // namespace fw
